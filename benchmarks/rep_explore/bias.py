import sys; sys.path.insert(0,'/tmp/i33')
from proto7 import *; from sets import make_sets
from collections import defaultdict
for kv in sys.argv[2:]:
    k,v=kv.split('='); setattr(P,k,float(v))
err=defaultdict(list)
for s in make_sets(actors=(sys.argv[1],)):
    found,tr=run(features(s['pos'],s['names']),120,P)
    if not found: continue
    reps=max(found,key=len)
    tj=np.array([a for a,b in s['reps']][1:])
    for a,b in reps[1:]:
        j=tj[np.argmin(abs(tj-a))]; err[s['cls'][:6]].append(a-j)
for k,v in err.items(): print(k, 'median',np.median(v),'mean abs',np.mean(np.abs(v)).round(1), np.percentile(v,[10,90]))
