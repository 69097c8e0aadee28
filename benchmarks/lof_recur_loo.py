"""Recurrence against the last seconds, whatever the cuts (issue 11, round 16).

Diagnosis (``benchmarks/lof_misses.py``, 2026-12-03): 10 of the 11 false cuts of the CMU 02
joins lie inside 15-22 s trials labelled with one activity (punch/strike, swordplay, wash self)
whose sub-movements alternate. Round 7's recurrence check (reject a cut whose after window is
within cosine distance ``recur`` of a window of the current segment) looked back only to the
previous cut, and the false cuts themselves keep that segment short.

Candidate (replayed, ``benchmarks/_lof_replay.py``, ``recur`` with ``recur_lookback``): the
check looks back ``L`` seconds whatever cuts lie between. A true cut back into an action seen
within ``L`` s is rejected too: the LOO decides whether that costs more than it saves.

Protocol, declared before the first run: candidates off, and L in {10, 20} s x recur in {0.1,
0.15, 0.2}. Leave-one-out over all 27 labelled recordings, each fold choosing by pooled F1
over the other 26 (ties: the earlier candidate, off first); adopted only if LOO pooled F1 >=
the defaults' + 0.02, no set mean lower, no more recordings below 0.4, median latency <= 2.5 s
(the rule of rounds 12-15). Not blind: the idea came from the diagnosis of the cmu02 pair.

Run: .venv/bin/python benchmarks/lof_recur_loo.py   (under a minute)
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from lof_accuracy import FPS  # noqa: E402
from lof_threshold_loo import loo_round  # noqa: E402

CANDIDATES = {"recurrence off": {},
              **{f"recur {r:g} over {lb} s": {"recur": r, "recur_lookback": int(lb * FPS)}
                 for lb in (10, 20) for r in (0.1, 0.15, 0.2)}}

if __name__ == "__main__":
    loo_round(CANDIDATES)
