# ruff: noqa
import sys; sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from harness import *
import streamseg.online.repetition as R
mat = B.Material(("bd",))
from collections import Counter
cnt = Counter(); tot = 0
for _, X, _, rec in mat.sets + mat.routines:
    ev = R.stream_events(R.RepetitionCounter(RepetitionConfig(), rec.fps, rec.skeleton), rec.positions, 30)
    # group events by emission batch within a set
    by = {}
    for e in ev: by.setdefault((e.set_index, e.emitted_at), []).append(e)
    for e in ev:
        tot += 1
        d = (e.emitted_at - e.end) / rec.fps
        late = d > (e.end - e.start) / rec.fps + 0.5
        batch = by[(e.set_index, e.emitted_at)]
        pos = [x.count for x in batch].index(e.count)
        kind = "alone" if len(batch) == 1 else f"batch of {len(batch)}, #{pos+1}"
        if late: cnt[kind] += 1
        cnt["all " + ("alone" if len(batch) == 1 else "batch")] += 1
print(tot, dict(cnt))
