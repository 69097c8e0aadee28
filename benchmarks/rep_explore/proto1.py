import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from scipy.signal import butter, sosfilt, sosfilt_zi
from feat import features
from sets import make_sets
def causal_lp(X,fps,hz):
    sos=butter(2,hz,fs=fps,output='sos'); zi=sosfilt_zi(sos)[:,:,None]*X[0][None,None,:]
    return sosfilt(sos,X,axis=0,zi=zi)[0]
def track(F,fps,A=0.6,rho=0.3,rho_exit=0.4,beta=0.4,tau=0.15,tmax=8.0):
    V=np.zeros_like(F); V[1:]=(F[1:]-F[:-1])*fps
    Z=np.concatenate([F,tau*V],1); n=len(Z)
    anchor=0; cycles=[]; peaks=[]; in_home=False; e_in=0; m=0.0; t=1
    while t<n:
        d=np.linalg.norm(Z[t]-Z[anchor])
        if not in_home:
            m=max(m,d)
            ref=max(A, beta*np.median(peaks[-3:])) if peaks else A
            if m>=ref and d<=rho*m: in_home=True; e_in=t
        else:
            if d>rho_exit*m:
                cut=(e_in+t)//2; cycles.append((anchor,cut)); peaks.append(m)
                anchor=cut; in_home=False
                m=max(np.linalg.norm(Z[anchor:t+1]-Z[anchor],axis=1).max(),0)
        if not in_home and t-anchor>tmax*fps:
            anchor=t; m=0.0
        t+=1
    if in_home: cycles.append((anchor,(e_in+n)//2 if n-e_in<fps else e_in)); peaks.append(m)
    return cycles, peaks
if __name__=='__main__':
    actor=sys.argv[1] if len(sys.argv)>1 else 'bd'
    sets=make_sets(actors=(actor,),draws=1)
    ok=0
    for s in sets:
        F=causal_lp(features(s['pos'],s['names']),120,3.0)
        cyc,pk=track(F,120)
        c=len(cyc); ok+=c==s['k']
        print(f"{s['cls'][:12]:12s} {s['actor']} k={s['k']:2d} found={c:2d} peaks={np.round(pk,2).tolist()}")
    print(ok,len(sets))
