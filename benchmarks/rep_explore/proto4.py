import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from feat import features
from sets import make_sets
from proto1 import causal_lp
from proto2 import resample, dtw, excursion

class P:
    A=0.8; rho=0.45; beta=0.4; gamma=0.25; dabs=0.15; eta=0.1; tau=0.0; sim=0.4; L=24

def strokes(F, fps, p=P):
    """boundaries of closed loops (online logic, run offline)."""
    V=np.zeros_like(F); V[1:]=(F[1:]-F[:-1])*fps
    Z=np.concatenate([F,p.tau*V],1) if p.tau>0 else F
    n=len(Z); a=0; bounds=[0]; amps=[]
    M=0.0; mt=0; m=np.inf; mi=0; phase=0  # 0 rising (looking for peak), 1 after peak (looking for trough)
    t=1
    while t<n:
        d=np.linalg.norm(Z[t]-Z[a])
        if d>M: M=d; m=np.inf
        if d<m: m=d; mi=t
        typ=np.median(amps[-5:]) if amps else 0
        thr=max(p.A,p.beta*typ)
        rising = d>=m+max(p.dabs,p.gamma*(M-m))
        if M>=thr and m<=p.rho*M and (rising or t==n-1):
            # cut at middle of the low stretch around mi
            D=np.linalg.norm(Z[a:t+1]-Z[a],axis=1)
            low=D<=m+p.eta*(M-m); lo=mi-a; hi=mi-a
            while lo>0 and low[lo-1] and a+lo-1>a+np.argmax(D[:mi-a+1]): lo-=1
            while hi<len(D)-1 and low[hi+1]: hi+=1
            b=a+(lo+hi)//2 if t<n-1 else n-1
            if t==n-1 and hi==len(D)-1: b=n-1
            bounds.append(b); amps.append(M); a=b
            D2=np.linalg.norm(Z[a:t+1]-Z[a],axis=1)
            M=D2.max(); m=D2[np.argmax(D2):].min(); mi=a+np.argmax(D2)+np.argmin(D2[np.argmax(D2):])
        t+=1
    if bounds[-1]!=n-1:
        # tail: a partial loop; counted as a rep if it went away and came back part way
        pass
    return bounds, amps

def similar(F,bounds,p=P):
    out=[]
    for i in range(len(bounds)-2):
        a,b,c=bounds[i],bounds[i+1],bounds[i+2]
        A=resample(F[a:b+1],p.L); B=resample(F[b:c+1],p.L)
        amp=0.5*(excursion(F,a,b)+excursion(F,b,c))
        out.append(dtw(A,B)/amp)
    return out

if __name__=='__main__':
    actor=sys.argv[1] if len(sys.argv)>1 else 'bd'
    sets=make_sets(actors=(actor,),draws=1)
    ok=0
    for s in sets:
        F=causal_lp(features(s['pos'],s['names']),120,3.0)
        b,amps=strokes(F,120)
        c=len(b)-1; ok+=c==s['k']
        tb=[x for x,_ in s['reps']]+[s['reps'][-1][1]]
        print(f"{s['cls'][:12]:12s} {actor} k={s['k']:2d} found={c:2d} b={b} true={tb} amps={np.round(amps,1).tolist()}")
    print(ok,len(sets))
