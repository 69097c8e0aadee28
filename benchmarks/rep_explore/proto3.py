import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from feat import features
from sets import make_sets
from proto1 import causal_lp
def pca_count(F, hi=0.6, lo=0.3):
    Fc=F-F.mean(0); U,S,Vt=np.linalg.svd(Fc,full_matrices=False); y=Fc@Vt[0]
    # orient: dwell level low
    if np.median(y) > 0.5*(y.min()+y.max()): y=-y
    q0,q1=np.percentile(y,5),np.percentile(y,95); y=(y-q0)/(q1-q0)
    n=0; up=False; cuts=[0]; lastmin=0; mn=np.inf
    for t,v in enumerate(y):
        if not up:
            if v<mn: mn=v; lastmin=t
            if v>hi: up=True; 
        else:
            if v<lo:
                up=False; n+=1; mn=v; lastmin=t
    return n, y
if __name__=='__main__':
    for actor in ('bd','bk','dg'):
        sets=make_sets(actors=(actor,),draws=2)
        ok=0; obo=0
        for s in sets:
            F=causal_lp(features(s['pos'],s['names']),120,3.0)
            c,_=pca_count(F)
            ok+=c==s['k']; obo+=abs(c-s['k'])<=1
            if c!=s['k']: print(f"{s['cls'][:12]:12s} {actor} k={s['k']:2d} found={c}")
        print(actor, ok, obo, len(sets))
