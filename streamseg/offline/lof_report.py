"""One LOF run over a whole feature matrix, offline or streamed, with its curve and timings.

What ``segment``/``eval --method lof`` and the evaluation corpus share: the cuts, their
latencies (streamed), the LOF curve for pictures and the wall time.
"""

from __future__ import annotations

import time

import numpy as np

from streamseg.config import LOFConfig


def lof_report(angles: np.ndarray, fps: float, config: LOFConfig, online: bool) -> dict:
    """Cut a feature matrix offline or streamed, with what a report or picture needs.

    Returns
    -------
    dict with ``cuts`` (list of int; with two stages the final ones), ``latency`` (frames
    from each cut to its final decision, online only), ``first_latency`` (to its first
    emission: a pending cut settled later; online only), ``withdrawn`` (frames of pending
    cuts taken back, online only), ``centres`` and
    ``lof`` (the curve: offline the whole one; online each window's LOF when it was decided,
    plus ``final``, the buffer's curve at the end), ``threshold`` (offline), ``seconds``
    """
    t0 = time.perf_counter()
    if online:
        from streamseg.online.lof import StreamingLOFSegmenter

        det = StreamingLOFSegmenter(config, fps)
        delay, step = det.geometry["delay"], det.geometry["step"]
        events, dec_x, dec_y = [], [], []
        # step-sized packets (results do not depend on packet size) so the value each window
        # had when it was decided can be recorded for the picture
        for i in range(0, angles.shape[0], step):
            seen = det.n_windows_
            events += det.learn_many(angles[i : i + step])
            if det.n_windows_ > seen and det.n_windows_ > delay:
                dec_x.append(int(det.buffer_centres()[-1 - delay]))
                dec_y.append(float(det.buffer_lof()[-1 - delay]))
        events += det.finish()
        from streamseg.online.events import WithdrawEvent, final_cuts, first_emissions

        final = final_cuts(events)  # with one stage: every event
        out = dict(
            cuts=[c.frame for c in final],
            latency=[c.latency for c in final],
            first_latency=[
                e - c.frame for e, c in zip(first_emissions(events), final, strict=True)
            ],
            withdrawn=[e.frame for e in events if isinstance(e, WithdrawEvent)],
            scores=[c.score for c in final],
            centres=np.array(dec_x),
            lof=np.array(dec_y),
            final=(det.buffer_centres(), det.buffer_lof()),
            threshold=None,
            n_nan_frames=det.n_nan_frames_,
            geometry=det.geometry,
        )
    else:
        from streamseg.offline.lof import LOFSegmenter

        seg = LOFSegmenter(config, fps).fit(angles)
        out = dict(
            cuts=[int(c) for c in seg.cuts_],
            latency=None,
            scores=[float(v) for v in seg.scores_],
            centres=seg.centres_,
            lof=seg.lof_,
            threshold=seg.threshold_,
            n_nan_frames=seg.n_nan_frames_,
            geometry=seg.geometry,
        )
    out["seconds"] = time.perf_counter() - t0
    return out
