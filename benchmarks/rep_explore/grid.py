import sys; sys.path.insert(0,'/tmp/i33')
import itertools, json
from proto7 import *; from sets import make_sets; from routines import make_routines, score_routine
actor=sys.argv[1]
S=make_sets(actors=(actor,)); R=make_routines(actor,n=6)
FS=[features(s['pos'],s['names']) for s in S]; FR=[features(r['pos'],r['names']) for r in R]
def score(changes):
    for k,v in changes.items(): setattr(P,k,v)
    rows=[]
    for s,F in zip(S,FS):
        found,tr=run(F,120,P); reps=max(found,key=len) if found else []
        rows.append((s['cls'],actor,s['k'],len(reps),alpha_overlap(reps,s['reps'])))
    sm=summary([r for r in rows if r[2]<=6])
    ok=tot=0
    for r,F in zip(R,FR):
        found,tr=run(F,120,P)
        for cls,k,c,g in score_routine(found,r['truth']):
            if k: tot+=1; ok+=g
    return sm['exact']+sm['alpha']+ok/tot, sm, ok/tot
base=dict(rho=0.55,smax=0.7,A=0.8,kappa=0.6,lp_hz=3.0,beta=0.5,lagcomp=1.0,gamma=0.35,ext=1,rho_end=0.6)
grid=dict(rho=[0.45,0.55,0.65],smax=[0.5,0.6,0.7],A=[0.6,0.8,1.0],kappa=[0.6,0.75,0.9],lp_hz=[2.0,3.0,4.0],beta=[0.3,0.4,0.5],gamma=[0.25,0.35,0.45],rho_end=[0.5,0.6,0.7])
best=score(base); print('base',best)
for rnd in range(2):
    for k,vals in grid.items():
        for v in vals:
            if v==base[k]: continue
            c=dict(base); c[k]=v; r=score(c)
            print(k,v,round(r[0],4),{a:round(float(b),3) for a,b in r[1].items()},round(r[2],3),flush=True)
            if r[0]>best[0]+1e-9: best=r; base=c
    print('round',rnd,base,best,flush=True)
