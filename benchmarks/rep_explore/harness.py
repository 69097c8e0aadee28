# ruff: noqa
import os
from pathlib import Path
"""Exploration harness (outside the tree): bd material, stressed bd, CMU blocks."""
import sys, time, pickle, zlib
from dataclasses import replace
from pathlib import Path
import numpy as np
import os
ROOT = os.environ.get("ROOT", str(Path(__file__).resolve().parents[2]))
sys.path.insert(0, ROOT + "/benchmarks")
sys.path.insert(0, ROOT)
import repetitions as B
from streamseg.config import RepetitionConfig
from streamseg.evaluation.rep_sets import hdm05_rep_sets, load_plan
from streamseg.online.repetition import stream_features, RepetitionCounter
from streamseg.recording import Recording

DATA = B.DATA

def pingpong(P, n, length):
    """n frames: the last `length` frames of P played back and forth, ending on P[-1]."""
    seg = P[-length:]
    cyc = np.concatenate([seg[::-1][1:], seg[1:]])  # from P[-1] back to start, then forward
    reps = int(np.ceil(n / len(cyc))) + 1
    full = np.concatenate([cyc] * reps)
    # end on P[-1]: take the last n frames of a sequence that ends at P[-1]
    return full[len(full) - n:]

def hold(P, n, rng):
    """n frames: the last pose held, with a slow sway (1 Hz low-passed noise, 2 % of the
    thigh length per coordinate)."""
    from scipy.signal import butter, sosfiltfilt
    from streamseg.online.repetition import body_scale
    from streamseg.skeleton.names import POINTS, resolve
    sos = butter(2, 1.0, fs=120.0, output="sos")
    W = rng.normal(size=(n + 240,) + P.shape[1:])
    W = sosfiltfilt(sos, W, axis=0)[120:120 + n]
    W = W / W.std() * 0.01 * SCALE[0]
    return P[-1][None] + W

SCALE = [1.0]

def stretch(P, f):
    n = P.shape[0]
    m = max(2, int(round(n * f)))
    x = np.linspace(0, n - 1, m)
    i = np.floor(x).astype(int); j = np.minimum(i + 1, n - 1); w = (x - i)[:, None, None]
    return P[i] * (1 - w) + P[j] * w

def stressed(actor="bd"):
    cache = {}
    out = []
    for plan in hdm05_rep_sets(DATA, (actor,), sizes=(2, 3, 4, 6)):
        rec, truth = load_plan(DATA, plan, cache)
        from streamseg.online.repetition import body_scale
        from streamseg.skeleton.names import POINTS, resolve
        import streamseg._kernels.rep_track as KK
        idx = np.asarray(resolve(list(rec.skeleton.names), KK.POINTS, POINTS))
        SCALE[0] = body_scale(rec.positions[:30], idx)
        reps = truth[0][3]
        clips = [rec.positions[a:b] for a, b in reps]
        for kind, val in [("rest", 0.5), ("rest", 1.0), ("rest", 1.5), ("rest", 2.0),
                          ("tempo", 0), ("tempo", 1), ("fidget", 1.0), ("fidget", 2.0),
                          ("bounce", 0.5), ("restless", 1.0), ("restless", 2.0)]:
            rng = np.random.default_rng(zlib.crc32(f"{plan.name}/{kind}/{val}".encode()))
            pos, tr, at = [], [], 0
            for i, c in enumerate(clips):
                if kind == "tempo":
                    c = stretch(c, float(rng.uniform(0.7, 1.4)))
                pos.append(c); tr.append([at, at + len(c)]); at += len(c)
                if kind == "rest" and i < len(clips) - 1:
                    n = int(val * 120)
                    pos.append(hold(c, n, rng)); at += n
                    tr[-1].append(n)
                if kind == "restless" and i < len(clips) - 1:
                    n = int(val * 120)
                    H = hold(c, n, rng)
                    from scipy.signal import butter, sosfiltfilt
                    W = rng.normal(size=(n + 240,) + c.shape[1:])
                    W = sosfiltfilt(butter(2, 3.0, fs=120.0, output="sos"), W, axis=0)[120:120 + n]
                    H += W / W.std() * 0.01 * SCALE[0]
                    pos.append(H); at += n
                    tr[-1].append(n)
                if kind == "fidget" and i < len(clips) - 1:
                    n = int(val * 120)
                    H = hold(c, n, rng)
                    nxt = clips[i + 1]
                    m = min(60, n // 2)  # a small copy of the next repetition's first 60 %, in 0.5 s
                    src = nxt[np.linspace(0, 0.6 * (len(nxt) - 1), m).round().astype(int)]
                    f0 = (n - m) // 2
                    H[f0:f0 + m] += 0.35 * (src - src[0][None])
                    pos.append(H); at += n
                    tr[-1].append(n)
                if kind == "bounce" and i < len(clips) - 1:
                    nxt = clips[i + 1]
                    m = 30  # 0.25 s down, 0.25 s up: half of the next repetition's first 40 %
                    src = nxt[np.linspace(0, 0.4 * (len(nxt) - 1), m).round().astype(int)]
                    B_ = nxt[0][None] + 0.5 * (np.concatenate([src, src[::-1]]) - nxt[0][None])
                    pos.append(B_); at += len(B_)
                    tr[-1].append(len(B_))
            # truth: boundaries in the middle of rests
            T = []
            for i, t in enumerate(tr):
                a, b = t[0], t[1]
                if i > 0 and len(tr[i-1]) == 3: a -= tr[i-1][2] // 2
                if len(t) == 3: b += t[2] - t[2] // 2
                T.append((a, b))
            r2 = Recording(120.0, rec.skeleton, np.concatenate(pos), source=plan.name)
            out.append((plan, f"{kind}{val}", stream_features(r2), T))
    return out

def load(actor="bd"):
    p = Path(os.environ.get("TMPDIR", "/tmp")) / f"rep_explore_{actor}.pkl"
    if p.exists() and os.environ.get("REP_EXPLORE_CACHE"):
        return pickle.loads(p.read_bytes())
    mat = B.Material((actor,))
    st = stressed(actor)
    d = {"sets": [(pl, X, reps) for pl, X, reps, _ in mat.sets],
         "routines": [(pl, X, tr) for pl, X, tr, _ in mat.routines], "stress": st}
    p.write_bytes(pickle.dumps(d))
    return d

def run(d, cfg, verbose=False, stress=True):
    rows = []
    for pl, X, reps in d["sets"]:
        found = B.count_sets(X, 120.0, cfg)
        c, a = B.score_set(found, reps)
        rows.append((pl.name, len(reps), c, a))
    srows = []
    if stress:
        for pl, kind, X, reps in d["stress"]:
            found = B.count_sets(X, 120.0, cfg)
            c, a = B.score_set(found, reps)
            srows.append((pl.name, kind, len(reps), c, a))
    rout = []
    for pl, X, tr in d["routines"]:
        rout.append((pl.name, B.score_routine(B.count_sets(X, 120.0, cfg), tr)))
    s26 = [(k, c, a) for _, k, c, a in rows if k <= 6]
    n, e, o, m, al = B.summary(s26)
    parts = [x for _, res in rout for x in res if x[1]]
    acts = [x for _, res in rout for x in res if not x[1]]
    rr = np.mean([x[3] for x in parts])
    res = {"exact": e, "obo": o, "alpha": al, "routine": rr, "obj": e + al + rr,
           "noset_actions": sum(x[3] for x in acts), "n_act": len(acts),
           "ten": B.summary([(k, c, a) for _, k, c, a in rows if k == 10])}
    if stress:
        for kind in sorted({r[1] for r in srows}):
            sub = [(k, c, a) for _, kd, k, c, a in srows if kd == kind]
            res[kind] = B.summary(sub)
        allst = [(k, c, a) for _, kd, k, c, a in srows]
        res["stress"] = B.summary(allst)
        res["sobj"] = res["stress"][1] + res["stress"][4]
    if verbose:
        for r in rows:
            if r[1] != r[2]: print("  SET", r)
        for name, res_ in rout:
            for x in res_:
                if x[1] and not x[3]: print("  ROUT", name, x)
        if stress:
            for r in srows:
                if r[2] != r[3]: print("  STRESS", r)
    return res

def fmt(res):
    s = (f"obj {res['obj']:.4f} exact {res['exact']:.3f} obo {res['obo']:.3f} alpha {res['alpha']:.3f} "
         f"rout {res['routine']:.3f} noset {res['noset_actions']}/{res['n_act']} ten {res['ten'][1]:.2f}/{res['ten'][4]:.3f}")
    if "stress" in res:
        s += f" | stress exact {res['stress'][1]:.3f} obo {res['stress'][2]:.3f} alpha {res['stress'][4]:.3f} sobj {res['sobj']:.4f} ["
        s += " ".join(f"{k}:{res[k][1]:.2f}" for k in sorted(res) if k.startswith(("rest", "tempo", "fidget", "bounce")))
        s += "]"
    return s

if __name__ == "__main__":
    t = time.time()
    d = load("bd")
    print("loaded", time.time() - t)
    res = run(d, RepetitionConfig(), verbose="-v" in sys.argv)
    print(fmt(res)); print(time.time() - t)

def ab(label, **patch):
    import streamseg.online.repetition as R
    d = load("bd")
    old = {k: getattr(R.RepetitionCounter, k) for k in patch}
    for k, v in patch.items(): setattr(R.RepetitionCounter, k, v)
    res = run(d, RepetitionConfig())
    for k, v in old.items(): setattr(R.RepetitionCounter, k, v)
    print(label, fmt(res), flush=True)
    return res

def ab2(label, **patch):
    import streamseg.online.repetition as R
    d = load("bd")
    old = {k: getattr(R.RepetitionCounter, k) for k in patch}
    for k, v in patch.items(): setattr(R.RepetitionCounter, k, v)
    res = run(d, RepetitionConfig())
    print(label, fmt(res), flush=True)
    import io, contextlib
    print("\n".join(B.cmu(RepetitionConfig())))
    for k, v in old.items(): setattr(R.RepetitionCounter, k, v)
    return res
