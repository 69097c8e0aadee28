import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from feat import features
from sets import make_sets
from proto1 import causal_lp

def speed_minima(F, fps, min_sep_s=0.15):
    V=np.zeros_like(F); V[1:]=(F[1:]-F[:-1])*fps
    s=np.linalg.norm(V,axis=1)
    c=[0]
    for t in range(1,len(s)-1):
        if s[t]<=s[t-1] and s[t]<s[t+1]:
            if t-c[-1] < min_sep_s*fps:
                if s[t]<s[c[-1]] and c[-1]!=0: c[-1]=t
            else: c.append(t)
    if c[-1]!=len(s)-1: c.append(len(s)-1)
    return np.array(c), s

def resample(X, L):
    n=len(X); x=np.linspace(0,n-1,L); i=np.floor(x).astype(int); i1=np.minimum(i+1,n-1); w=(x-i)[:,None]
    return X[i]*(1-w)+X[i1]*w

def dtw(A,B):
    n,m=len(A),len(B); C=np.linalg.norm(A[:,None]-B[None],axis=2)
    D=np.full((n+1,m+1),np.inf); D[0,0]=0; K=np.zeros((n+1,m+1))
    for i in range(1,n+1):
        for j in range(1,m+1):
            opts=((D[i-1,j-1],K[i-1,j-1]),(D[i-1,j],K[i-1,j]),(D[i,j-1],K[i,j-1]))
            k=min(range(3),key=lambda q:opts[q][0])
            D[i,j]=opts[k][0]+C[i-1,j-1]; K[i,j]=opts[k][1]+1
    return D[n,m]/K[n,m]

def excursion(F,a,b):
    return np.linalg.norm(F[a:b+1]-F[a],axis=1).max()

class P: A=0.8; rho=0.35; beta=0.5; sim=0.35; L=24; tmax=10.0

def count(F, fps, p=P, verbose=False):
    cand,s=speed_minima(F,fps)
    sets=[]; cur=None  # cur: dict(bounds=[...], amps=[...])
    pending=[]  # candidate indices available as first anchors (searching)
    def sim(a,b,c):
        A=resample(F[a:b+1],p.L); B=resample(F[b:c+1],p.L)
        amp=0.5*(excursion(F,a,b)+excursion(F,b,c))
        return dtw(A,B)/amp
    for k,tk in enumerate(cand):
        if cur is not None:
            b=cur['bounds'][-1]
            exc=excursion(F,b,tk); ret=np.linalg.norm(F[tk]-F[b])
            typ=np.median(cur['amps'])
            if exc>=max(p.A,p.beta*typ) and ret<=p.rho*exc:
                a=cur['bounds'][-2]
                r=sim(a,b,tk)
                if r<=p.sim:
                    cur['bounds'].append(tk); cur['amps'].append(exc); cur['sims'].append(r); continue
                else:
                    sets.append(cur); cur=None; pending=[b]
            elif tk-b>p.tmax*fps:
                sets.append(cur); cur=None; pending=[]
            else:
                continue
        # searching: find i<j<k with returns i->j, j->k and similar cycles
        pending=[c for c in pending if tk-c<=p.tmax*fps]
        best=None
        for jj in range(len(pending)-1,-1,-1):
            j=pending[jj]
            e2=excursion(F,j,tk); r2=np.linalg.norm(F[tk]-F[j])
            if e2<p.A or r2>p.rho*e2: continue
            for ii in range(jj-1,-1,-1):
                i=pending[ii]
                e1=excursion(F,i,j); r1=np.linalg.norm(F[j]-F[i])
                if e1<p.A or r1>p.rho*e1: continue
                if min(e1,e2)<p.beta*max(e1,e2): continue
                r=sim(i,j,tk)
                if r<=p.sim and (best is None or r<best[0]): best=(r,i,j,e1,e2)
            if best: break
        if best:
            r,i,j,e1,e2=best
            cur=dict(bounds=[i,j,tk],amps=[e1,e2],sims=[r]); pending=[]
        else:
            pending.append(tk)
    if cur is not None: sets.append(cur)
    return sets

if __name__=='__main__':
    actor=sys.argv[1] if len(sys.argv)>1 else 'bd'
    sets=make_sets(actors=(actor,),draws=1)
    ok=0
    for s in sets:
        F=causal_lp(features(s['pos'],s['names']),120,3.0)
        found=count(F,120)
        cnt=[len(x['bounds'])-1 for x in found]
        c=max(cnt) if cnt else 0
        ok+=c==s['k']
        print(f"{s['cls'][:12]:12s} {s['actor']} k={s['k']:2d} sets={cnt} n={len(s['pos'])} first={[ (x['bounds'][0],x['bounds'][-1]) for x in found]} sims={[np.round(x['sims'],2).tolist() for x in found][:1]}")
    print(ok,len(sets))
