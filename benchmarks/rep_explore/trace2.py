# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from trace import *
d = load("bd")
name, kind = sys.argv[1], sys.argv[2]
for pl, k, X, reps in d["stress"]:
    if pl.name == name and k == kind:
        print("truth", reps, "n", len(X))
        c = traced(); c.learn_many(X)
        print("k", c._k*4, "search", c._search, "anchors", [(int(c._st[i,0])*4, round(float(c._Mm[i,0]),2), round(float(c._Mm[i,1]),2)) for i in range(c._na[0])])
        print("cands", {k*4:(v[0]*4,v[1]*4,round(v[2],2)) if v else None for k,v in c._cands.items()})
        for i in range(c._na[0]):
            print(" last_loop", i, c._last_loop(i, c._k, False))
        for e in sorted(c._cands, reverse=True):
            prev = c._cands[e]
            if prev is None: continue
            L = c._length(prev); print(" edge_after from", e*4, "L", L*4, "avail", (c._k-e)*4)
            piece = c._edge_after(prev, e, c._k); print("  piece", piece)
        c.finish()
        for s in c.sets_: print("SET", s.repetitions, s.end_reason, [None if x is None else round(x,2) for x in s.dissimilarity])
        c2 = traced(); 
        import io, contextlib
        with contextlib.redirect_stdout(io.StringIO()): c2.learn_many(X)
        for i in range(c2._na[0]):
            s_ = int(c2._st[i,0]); prev = c2._cands.get(s_)
            lp = c2._last_loop(i, c2._k, False)
            if prev and lp:
                p, q = prev, lp
                print(" finish cand", s_*4, "r", round(c2._dissimilarity(p, q),2), "spread", c2._spread(p, q), "act", [x*4 for x in c2._active(p)], [x*4 for x in c2._active(q)])
                W = c2._rows(p[0], q[1]); i_ = int(np.argmax(np.linalg.norm(W - W[0], axis=1))); span = float(np.linalg.norm(W - W[i_], axis=1).max())
                print("   span", round(span,2), "M", round(p[2],2), round(q[2],2))
