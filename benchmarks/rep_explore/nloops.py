# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
import streamseg.online.repetition as R
d = load("bd")
tot_search = tot_sets = tot_track = 0
for group in ("sets", "routines"):
    for item in d[group]:
        X = item[1]
        c = R.RepetitionCounter(RepetitionConfig(), 120.0)
        ns = [0]; nt = [0]
        os_, ot = c._on_search, c._on_track
        def s_(loops, t): ns[0] += len(loops); os_(loops, t)
        def t_(loop, t): nt[0] += 1; ot(loop, t)
        c._on_search, c._on_track = s_, t_
        c.learn_many(X); c.finish()
        tot_search += ns[0]; tot_track += nt[0]; tot_sets += len(c.sets_)
print("search loops", tot_search, "track loops", tot_track, "sets", tot_sets, "search loops per set", tot_search / tot_sets)
