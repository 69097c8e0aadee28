import sys; sys.path.insert(0,'/tmp/i33')
from proto7 import *; from proto5 import summary; from sets import make_sets
from collections import defaultdict
for kv in sys.argv[2:]:
    k,v=kv.split('='); setattr(P,k,float(v))
verbose='-v' in sys.argv[1]
rows=evaluate(make_sets(actors=tuple(sys.argv[1].strip('-v').split(','))),verbose=verbose)
print('all',summary(rows)); print('2-6',summary([r for r in rows if r[2]<=6]))
by=defaultdict(list)
for r in rows: by[r[0][:8]].append(r)
for k,v in by.items(): print(k, {a:round(float(b),3) for a,b in summary(v).items()})
