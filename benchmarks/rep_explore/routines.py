import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from load import load
from sets import CLASSES
ACTIONS=["depositFloorR","grabHighR","lieDownFloor","throwBasketball","sneak2StepsLStart","jogLeftCircle4StepsRstart"]
def make_routines(actor, n=4, seed=0):
    clips=load(); rng=np.random.default_rng(seed+{'bd':0,'bk':1,'dg':2}[actor])
    by={c:[x for x in clips if x['cls']==c and x['actor']==actor] for c in CLASSES+ACTIONS}
    out=[]
    for r in range(n):
        order=list(rng.permutation(CLASSES))
        parts=[]; truth=[]; pos=[]; t=0
        for i,cls in enumerate(order):
            g=by[cls]; k=int(rng.integers(2,7))
            s=int(rng.integers(0,max(1,len(g)-k+1)))
            idx=[(s+j)%len(g) for j in range(k)]
            start=t
            for j in idx: pos.append(g[j]['pos']); t+=len(g[j]['pos'])
            truth.append((start,t,cls,k))
            if rng.random()<0.6:  # an action between sets
                a=ACTIONS[int(rng.integers(len(ACTIONS)))]; ga=by[a]; c=ga[int(rng.integers(len(ga)))]
                truth.append((t,t+len(c['pos']),a,0)); pos.append(c['pos']); t+=len(c['pos'])
        out.append(dict(actor=actor,pos=np.concatenate(pos),names=by[CLASSES[0]][0]['names'],truth=truth))
    return out
def score_routine(found_sets, truth):
    """found_sets: list of list of (a,b). returns per true rep set (ok, count, true)."""
    res=[]
    lab=[]
    for i,fs in enumerate(found_sets):
        for a,b in fs: lab.append(((a+b)//2,i))
    for s,e,cls,k in truth:
        mine=[i for m,i in lab if s<=m<e]
        if k==0: res.append((cls,k,len(mine),len(mine)==0)); continue
        ok=len(mine)==k and len(set(mine))==1
        res.append((cls,k,len(mine),ok))
    return res
