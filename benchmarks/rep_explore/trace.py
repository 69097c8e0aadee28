# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
import streamseg.online.repetition as R
def traced(cfg=None):
    c = R.RepetitionCounter(cfg or RepetitionConfig(), 120.0)
    orig_s, orig_t = c._on_search, c._on_track
    def on_s(loops, t):
        for s, kind, cut, M in loops:
            prev = c._cands.get(s)
            r = c._dissimilarity(prev, (s, cut, M)) if prev else None
            sp = c._spread(prev, (s,cut,M)) if prev else None
            print(f"  search t={t*4} loop {s*4}-{cut*4} kind={kind} M={M:.2f} prev={None if not prev else (prev[0]*4, prev[1]*4, round(prev[2],2))} r={None if r is None else round(r,2)} spread={sp}")
        orig_s(loops, t)
    def on_t(loop, t):
        s, kind, cut, M = loop
        r = c._dissimilarity(c._last(), (s, cut, M)) if kind != 3 else None
        print(f"  track t={t*4} loop {s*4}-{cut*4} kind={kind} M={M:.2f} r={None if r is None else round(r,2)}")
        orig_t(loop, t)
    c._on_search, c._on_track = on_s, on_t
    return c
if __name__ == "__main__":
    d = load("bd")
    name, kind = sys.argv[1], sys.argv[2]
    for pl, k, X, reps in d["stress"]:
        if pl.name == name and k == kind:
            print("truth", reps)
            c = traced(); c.learn_many(X); c.finish()
            for s in c.sets_: print("SET", s.repetitions, s.end_reason, [None if x is None else round(x,2) for x in s.dissimilarity])
