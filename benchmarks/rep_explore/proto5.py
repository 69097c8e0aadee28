"""Online cycle tracker prototype (python), run offline."""
import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from scipy.optimize import linear_sum_assignment
from feat import features
from sets import make_sets
from proto1 import causal_lp
from proto2 import resample, dtw

class P:
    rate=30.0; A=0.8; rho=0.45; beta=0.4; gamma=0.25; dabs=0.15; eta=0.1
    smax=0.6; place=0; widen=0.5; rho_end=0.6; L=32; pause_s=3.0; tmax_s=8.0; lp_hz=3.0

class Tracker:
    def __init__(self, p=P):
        self.p=p; self.Z=[]; self.a=0; self.reset_loop(0)
        self.prev=None; self.active=False; self.count=0; self.sets=[]; self.cur=None; self.typ=[]
        self.events=[]  # (start,end,count,emitted_at)
        self.pause=int(round(p.pause_s*p.rate)); self.tmax=int(round(p.tmax_s*p.rate))
        self.log=[]
    def reset_loop(self, a):
        self.a=a; self.M=0.0; self.tM=a; self.m=np.inf; self.tm=a
    def d(self,t): return float(np.linalg.norm(self.Z[t]-self.Z[self.a]))
    def push(self, z):
        p=self.p; self.Z.append(np.asarray(z,float)); t=len(self.Z)-1
        if t==0: return
        self._step(t)
    def _step(self,t):
        p=self.p; d=self.d(t)
        if d>self.M: self.M=d; self.tM=t; self.m=np.inf
        if t>self.tM and d<self.m: self.m=d; self.tm=t
        thr=max(p.A, p.beta*np.median(self.typ[-5:])) if self.typ else p.A
        if self.M>=thr and self.m<=p.rho*self.M:
            level=self.m+p.eta*(self.M-self.m)
            if d>self.m+max(p.dabs,p.gamma*(self.M-self.m)):
                entry,exit_=self._low(level,t)
                self._close(self._place(entry,exit_,t),t,False)
            else:
                entry,_=self._low(level,t)
                if t-entry>=self.pause and self.d(t)<=level:
                    self._close(entry+self.pause//2,t,True)
        elif self.M<p.A and t-self.a>self.pause//2:
            self._reanchor(t-self.pause//2,t)
        elif t-self.a>self.tmax:
            self._end_set('timeout'); self.prev=None; self._reanchor(t,t)
    def _low(self,level,t):
        e=self.tm
        while e-1>self.tM and self.d(e-1)<=level: e-=1
        x=self.tm
        while x+1<t and self.d(x+1)<=level: x+=1
        return e,x
    def _place(self,entry,exit_,t):
        p=self.p
        if p.place==0: return (entry+exit_)//2
        if p.place==1: return self.tm
        # slowest frame in the low stretch widened by w
        w=int(p.widen*(exit_-entry+1))+1
        lo=max(self.tM+1,entry-w); hi=min(t-1,exit_+w)
        Z=np.array(self.Z[lo-1:hi+2]); sp=np.linalg.norm(Z[2:]-Z[:-2],axis=1)
        return lo+int(np.argmin(sp))
    def _reanchor(self,a,t):
        self.reset_loop(a)
        for u in range(a+1,t+1):
            d=self.d(u)
            if d>self.M: self.M=d; self.tM=u; self.m=np.inf
            if u>self.tM and d<self.m: self.m=d; self.tm=u
    def _close(self,cut,t,paused):
        cyc=(self.a,cut,self.M)
        self._cycle(cyc,t)
        if paused: self._end_set('pause'); self.prev=None
        self._reanchor(cut,t)
    def _ratio(self,c1,c2):
        A=resample(np.array(self.Z[c1[0]:c1[1]+1]),min(self.p.L,c1[1]-c1[0]+1))
        B=resample(np.array(self.Z[c2[0]:c2[1]+1]),min(self.p.L,c2[1]-c2[0]+1))
        return dtw(A,B)/(0.5*(c1[2]+c2[2]))
    def _cycle(self,cyc,t):
        prev=self.prev
        r=None
        if prev is not None and prev[1]==cyc[0]:
            r=self._ratio(prev,cyc)
        self.log.append(cyc+(r,))
        if r is not None:
            if r<=self.p.smax:
                if self.cur is None:
                    self.cur=dict(cycles=[prev],ratios=[]); self.typ=[prev[2]]
                    self._emit(prev,t)
                self.cur['cycles'].append(cyc); self.cur['ratios'].append(r); self.typ.append(cyc[2])
                self._emit(cyc,t)
                self.prev=cyc; return
            self._end_set('dissimilar')
        self.prev=cyc; self.typ=[cyc[2]]
    def _emit(self,cyc,t):
        self.count=len(self.cur['cycles'])
        self.events.append((cyc[0],cyc[1],self.count,t))
    def _end_set(self,why):
        if self.cur is not None:
            self.cur['why']=why; self.sets.append(self.cur); self.cur=None
        self.typ=[]
    def finish(self):
        p=self.p; t=len(self.Z)-1
        thr=max(p.A, p.beta*np.median(self.typ[-5:])) if self.typ else p.A
        if self.M>=thr and self.m<=p.rho_end*self.M:
            if self.m<=p.rho*self.M:
                level=self.m+p.eta*(self.M-self.m)
                entry,exit_=self._low(level,t+1)
                if exit_>=t-1: cut=min(t,entry+self.pause//2)
                else: cut=(entry+exit_)//2
            else: cut=t
            self._cycle((self.a,cut,self.M),t)
        self._end_set('end')

def run(F,fps,p=P):
    dec=max(1,int(round(fps/p.rate)))
    Fl=causal_lp(F,fps,p.lp_hz)
    tr=Tracker(p)
    for z in Fl[::dec]: tr.push(z)
    tr.finish()
    n=len(F)
    sets=[[(min(n,a*dec),min(n,b*dec if b<len(tr.Z)-1 else n)) for a,b,_ in s['cycles']] for s in tr.sets]
    return sets, tr

def alpha_overlap(found,truth):
    if not found or not truth: return 0.0
    I=np.array([[max(0,min(b,d)-max(a,c)) for (c,d) in truth] for (a,b) in found],float)
    r,c=linear_sum_assignment(-I)
    terms=[]
    for i,j in zip(r,c):
        if I[i,j]<=0: terms.append(0.0); continue
        L=truth[j][1]-truth[j][0]; e=abs((found[i][1]-found[i][0])-L); terms.append(1-e/L)
    D=min(len(found),len(truth))
    return float(np.sum(terms)/D)

def evaluate(sets_, p=P, verbose=False):
    rows=[]
    for s in sets_:
        F=features(s['pos'],s['names'])
        found,tr=run(F,120,p)
        reps=max(found,key=len) if found else []
        c=len(reps); k=s['k']
        al=alpha_overlap(reps,s['reps'])
        rows.append((s['cls'],s['actor'],k,c,al))
        if verbose and c!=k:
            tb=[x for x,_ in s['reps']]+[s['reps'][-1][1]]
            print(f"{s['cls'][:12]:12s} {s['actor']} k={k:2d} found={[len(x) for x in found]} b={[x for x,_ in reps]+[reps[-1][1]] if reps else []} true={tb} log={[(a*4,b*4,round(m,1),r if r is None else round(r,2)) for a,b,m,r in tr.log]}")
    return rows

def summary(rows):
    R=np.array([(k,c,al) for _,_,k,c,al in rows],float)
    k,c,al=R.T
    return dict(exact=np.mean(c==k),obo=np.mean(abs(c-k)<=1),mae=np.mean(abs(c-k)/k),alpha=np.mean(al),n=len(k))

if __name__=='__main__':
    actor=sys.argv[1] if len(sys.argv)>1 else 'bd'
    rows=evaluate(make_sets(actors=(actor,),draws=2),verbose=True)
    print(summary(rows))
    r26=[r for r in rows if r[2]<=6]; print('2-6',summary(r26))
