# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
d = load("bd")
for ma in (16, 64):
    print(ma, fmt(run(d, RepetitionConfig(max_anchors=ma))))
