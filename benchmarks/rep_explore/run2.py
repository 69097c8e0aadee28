import sys; sys.path.insert(0,'/tmp/i33')
from proto7 import *; from proto5 import summary; from sets import make_sets
from routines import make_routines, score_routine
for kv in sys.argv[2:]:
    k,v=kv.split('='); setattr(P,k,float(v))
tot=ok=act=actok=0
for actor in sys.argv[1].split(','):
    for R in make_routines(actor,n=6):
        F=features(R['pos'],R['names'])
        found,tr=run(F,120,P)
        res=score_routine(found,R['truth'])
        for cls,k,c,good in res:
            if k: tot+=1; ok+=good
            else: act+=1; actok+=good
        print(actor,[(cls[:5],k,c,int(g)) for cls,k,c,g in res])
print('rep sets right',ok,tot,'actions with 0',actok,act)
