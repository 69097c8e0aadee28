"""Shutdown: every stream's final events, then the sockets closed (SIGINT, SIGTERM, control)."""

from __future__ import annotations

import logging
import os
import time

from streamseg.daemon.pipeline import relabel
from streamseg.daemon.state_lock import unlock
from streamseg.daemon.worker import RelabelJob

log = logging.getLogger("streamseg.daemon")


def shutdown(daemon) -> None:
    """Final events for every stream, then close the sockets."""
    try:
        if daemon.endpoints:
            final_events(daemon)
    finally:
        if daemon.eventlog is not None and getattr(daemon, "pub", None) is not None:
            # the final events go out once committed, before the socket closes
            if not daemon.eventlog.sync(daemon.config.shutdown_relabel + 5.0):
                log.error("event log %s: the last events were not committed in time: not "
                          "published", daemon.eventlog.path)
            daemon._publish_logged()
        daemon.worker.stop(timeout=daemon.config.shutdown_relabel)
        ingest = getattr(daemon, "ingest", None)
        if ingest is not None:
            ingest.stop()
            ingest.close()
        for sock in (getattr(daemon, "control", None), getattr(daemon, "pub", None)):
            if sock is not None:
                sock.close()  # default linger: final events still reach listeners
        if daemon.security is not None:
            daemon.security.stop()
        if daemon.conn_ids is not None:
            daemon.conn_ids.stop()
        daemon.ctx.term()
        if daemon.eventlog is not None:
            daemon.eventlog.close()  # after the final events: they are logged too
            daemon.eventlog.notify = None
        for fd in (daemon._log_rx, daemon._log_tx):
            os.close(fd)
        if daemon.checkpoints is not None:
            daemon.checkpoints.close()
        unlock(daemon.state_lock)  # last: another daemon may take the directory now
        daemon.state_lock = None
        log.info("daemon stopped")


def final_events(daemon) -> None:
    """Close every stream: final cuts, a last relabel (bounded by ``shutdown_relabel``), then
    ``closed``; packets already received are processed first."""
    daemon.ingest.stop()  # every packet already received is still processed
    while daemon.ingest.items:
        daemon._take(time.monotonic())
    deadline = time.monotonic() + daemon.config.shutdown_relabel
    for st in list(daemon.streams.values()):
        daemon._close(st, "shutdown")
    # let the worker finish what it has (bounded), then do the rest here if time allows
    while daemon.closing and time.monotonic() < deadline:
        daemon._collect()
        if not daemon.worker.is_alive():
            break
        time.sleep(0.005)
    daemon._collect()
    for key, (st, reason) in list(daemon.closing.items()):
        feats, frames = st.pipeline.snapshot()
        if (time.monotonic() < deadline and not daemon.worker.running(key)
                and feats.shape[0] >= 2):
            try:
                res = relabel(daemon.algorithms, feats, frames, st.fps, st.pipeline.previous,
                              tuple(st.pipeline.cut_frames))
            except Exception as err:
                res = err
            job = RelabelJob(key, None, None, st.fps, None, final=True)
            daemon._relabelled(job, res)
        else:
            daemon.closing.pop(key, None)
            daemon._closed(st, reason)
    if daemon.config.heartbeat:
        daemon._beat(time.monotonic())
