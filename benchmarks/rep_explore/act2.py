# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
d = load(sys.argv[1] if len(sys.argv) > 1 else "bd")
for pl, X, tr in d["routines"]:
    f = B.count_sets(X, 120.0, RepetitionConfig())
    r = B.score_routine(f, tr)
    for (s,e,cls,reps), x in zip(tr, r):
        if not reps and not x[3]:
            sets = [st for st in f if any(s <= (a+b)//2 < e for a,b in st)]
            print(pl.name, cls, s, e, x[2], [(st[0][0], st[-1][1], len(st)) for st in sets])
