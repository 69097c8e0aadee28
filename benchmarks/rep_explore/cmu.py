# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
import streamseg.online.repetition as R
for kv in sys.argv[2:]:
    k, v = kv.split("="); setattr(R.RepetitionCounter, k, eval(v))
print("\n".join(B.cmu(RepetitionConfig(), sys.argv[1])))
