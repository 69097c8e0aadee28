# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
import matplotlib; matplotlib.use("Agg"); import matplotlib.pyplot as plt
from streamseg.io import read
from scipy.signal import butter, sosfilt
seq, lo, hi, out = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
rec = read(DATA / "cmu_exercise" / f"{seq}.amc.gz", skeleton=DATA / "cmu86" / "86.asf")
F = stream_features(rec)
Y = sosfilt(butter(2, 4, fs=120, output="sos"), F, axis=0)
a, b = int(lo*120), int(hi*120)
c = RepetitionCounter(RepetitionConfig(), 120.0); c.learn_many(F); c.finish()
names = ["l_uarm", "l_farm", "r_uarm", "r_farm", "l_thigh", "l_shin", "r_thigh", "r_shin"]
fig, axes = plt.subplots(5, 1, figsize=(16, 12), sharex=True)
t = np.arange(a, b) / 120
for k, ax in enumerate(axes[:4]):
    for j in range(3):
        ax.plot(t, Y[a:b, 3*(2*k if k < 4 else 0) + j] if False else Y[a:b, 6*k + j], lw=1)
        ax.plot(t, Y[a:b, 6*k + 3 + j], lw=1, ls="--")
    ax.set_ylabel(f"{names[2*k]} / {names[2*k+1]}")
axes[4].plot(t, Y[a:b, 24:28]); axes[4].set_ylabel("trunk, pelvis h")
for i, st in enumerate(c.sets_):
    for r0, r1 in st.repetitions:
        if r1 < a or r0 > b: continue
        for ax in axes: ax.axvline(r0/120, color=f"C{i%10}", lw=2, alpha=0.6)
    for ax in axes: ax.axvline(st.end/120, color="k", lw=1, ls=":")
axes[0].set_xlim(lo, hi)
fig.savefig(out, dpi=60, bbox_inches="tight")
