# ruff: noqa
"""The still_ratio sweep of docs/decisions.md (bd, stressed sets with rests and tempo)."""
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
d = load("bd")
d2 = dict(d); d2["stress"] = [x for x in d["stress"] if x[1].startswith(("rest", "tempo"))
                and not x[1].startswith("restless")]
for sr in (0.0, 0.15, 0.25, 0.3, 0.4, 0.5):
    r = run(d2, RepetitionConfig(still_ratio=sr, max_anchors=16))  # 16: the default then
    print(sr, f"bd obj {r['obj']:.4f} rout {r['routine']:.3f} | rest+tempo exact {r['stress'][1]:.3f} obo {r['stress'][2]:.3f}", " ".join(f"{k}:{r[k][1]:.2f}" for k in sorted(r) if k.startswith(("rest","tempo"))))
