# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
from collections import defaultdict
d = load("bd")
off = defaultdict(list); al = defaultdict(list)
for pl, X, reps in d["sets"]:
    if len(reps) > 6: continue
    f = B.count_sets(X, 120.0, RepetitionConfig())
    c, a = B.score_set(f, reps)
    cls = pl.parts[0][0]
    al[cls].append(a)
    if c != len(reps): continue
    inside = [sum(max(0, min(b, reps[-1][1]) - max(x, reps[0][0])) for x, b in s) for s in f]
    best = f[int(np.argmax(inside))]
    for (fa, fb), (ta, tb) in zip(best, reps):
        off[cls].append((fa - ta, fb - tb))
for cls in off:
    o = np.array(off[cls])
    inner_s = o[1:, 0] if len(o) > 1 else o[:, 0]
    print(f"{cls:30s} alpha {np.mean(al[cls]):.3f}  start off median {np.median(o[:,0]):+.0f} (IQR {np.percentile(o[:,0],25):+.0f}..{np.percentile(o[:,0],75):+.0f})  end off median {np.median(o[:,1]):+.0f} (IQR {np.percentile(o[:,1],25):+.0f}..{np.percentile(o[:,1],75):+.0f})")
