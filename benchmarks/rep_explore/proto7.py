"""Online cycle tracker prototype v3: replayable search/track modes."""
import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from feat import features
from proto1 import causal_lp
from proto2 import resample, dtw
from proto5 import alpha_overlap, summary
from ext import sub_dtw

class P:
    rate=30.0; A=0.8; rho=0.55; gamma=0.25; dabs=0.15; eta=0.1; beta=0.4
    smax=0.6; L=32; pause_s=3.0; tmax_s=8.0; lp_hz=3.0; rho_end=0.6; widen=0.0
    kmax=16; asep_s=0.2; kappa=0.75; lagcomp=0.0; ext=1; spmode=0; tfac=3.0

class Anchor:
    __slots__=('s','M','tM','m','tm')
    def __init__(self,s): self.s=s; self.M=0.0; self.tM=s; self.m=np.inf; self.tm=s

class Tracker:
    def __init__(self,p=P):
        self.p=p; self.Z=[]; self.sp=[]
        self.pause=int(round(p.pause_s*p.rate)); self.tmax=int(round(p.tmax_s*p.rate))
        self.asep=max(1,int(round(p.asep_s*p.rate)))
        self.anchors=[]; self.cands={}
        self.cur=None; self.sets=[]; self.events=[]; self.log=[]
        self.track=None; self.pos=-1; self.now=-1; self.origin=0
    def dist(self,t,s): return float(np.linalg.norm(self.Z[t]-self.Z[s]))
    def upd(self,an,t):
        d=self.dist(t,an.s)
        if d>an.M: an.M=d; an.tM=t; an.m=np.inf
        if t>an.tM and d<an.m: an.m=d; an.tm=t
        return d
    def push(self,z):
        self.Z.append(np.asarray(z,float)); t=len(self.Z)-1; self.now=t
        self.sp.append(0.0 if t==0 else float(np.linalg.norm(self.Z[t]-self.Z[t-1])))
        if t==0: self.anchors=[Anchor(0)]; self.pos=0; return
        while self.pos<t:
            self.pos+=1; u=self.pos
            if self.track is not None: self._track(u)
            else: self._search(u)
    def search_from(self,s):
        """switch to search mode starting at frame s (frames after s are replayed)."""
        self.track=None; self.anchors=[Anchor(s)]; self.pos=s; self.origin=s
        self.cands={k:v for k,v in self.cands.items() if k==s}
    def closes(self,an,t,thr):
        p=self.p; d=self.upd(an,t)
        if an.M>=thr and an.m<=p.rho*an.M:
            level=an.m+p.eta*(an.M-an.m)
            if d>an.m+max(p.dabs,p.gamma*(an.M-an.m)):
                e,x=self.low(an,level,t); return 'close',self.place(an,e,x,t)
            e,_=self.low(an,level,t)
            if t-e>=self.pause and d<=level: return 'pause',e+self.pause//2
        return None,None
    def low(self,an,level,t):
        e=an.tm
        while e-1>an.tM and self.dist(e-1,an.s)<=level: e-=1
        x=an.tm
        while x+1<t and self.dist(x+1,an.s)<=level: x+=1
        return e,x
    def place(self,an,e,x,t):
        w=int(self.p.widen*(x-e+1))
        lo=max(an.tM+1,e-w); hi=min(t-1,x+w)
        sp=[self.dist(u+1,u-1) for u in range(lo,hi+1)]
        return lo+int(np.argmin(sp))
    def thr(self):
        return max(self.p.A,self.p.beta*np.median([c[2] for c in self.cur['cycles'][-5:]]))
    def _track(self,t):
        an=self.track
        kind,cut=self.closes(an,t,self.thr())
        if kind:
            cyc=(an.s,cut,an.M); prev=self.cur['cycles'][-1]
            r=self.ratio(prev,cyc); self.log.append(cyc+(r,'T'))
            if r<=self.p.smax:
                self.cur['cycles'].append(cyc); self.emit(cyc)
                if kind=='pause': self.end_set('pause'); self.search_from(cut)
                else:
                    self.track=Anchor(cut)
                    for u in range(cut+1,t+1): self.upd(self.track,u)
            else:
                self.end_set('dissimilar'); self.cands={an.s:None}; self.search_from(an.s)
            return
        med=np.median([c[1]-c[0] for c in self.cur['cycles']])
        if t-an.s>min(self.tmax,self.p.tfac*med):
            self.end_set('timeout'); self.search_from(an.s)
    def _search(self,t):
        # new anchor at a speed minimum (t-1)
        if t>=2 and self.sp[t-1]<=self.sp[t-2] and self.sp[t-1]<self.sp[t]:
            if not self.anchors or t-1-self.anchors[-1].s>=self.asep:
                an=Anchor(t-1); self.anchors.append(an)
        closed=[]; keep=[]
        for an in self.anchors:
            kind,cut=self.closes(an,t,self.p.A)
            if kind: closed.append((an,kind,cut))
            elif t-an.s<=self.tmax: keep.append(an)
        self.anchors=keep[-self.p.kmax:]
        for an,kind,cut in closed:
            cyc=(an.s,cut,an.M)
            prev=self.cands.get(an.s)
            r=self.ratio(prev,cyc) if prev else None
            ok=prev is not None and r<=self.p.smax and self.spread_ok(prev,cyc)
            self.log.append(cyc+(r,'S'))
            if ok:
                self.start_set(prev,cyc)
                self.cands={}; self.anchors=[]
                if kind=='pause': self.end_set('pause'); self.search_from(cut)
                else:
                    self.track=Anchor(cut)
                    for u in range(cut+1,t+1): self.upd(self.track,u)
                return
            self.cands[cut]=cyc
            if kind!='pause' and all(a.s!=cut for a in self.anchors):
                a2=Anchor(cut)
                for u in range(cut+1,t+1): self.upd(a2,u)
                self.anchors.append(a2); self.anchors.sort(key=lambda a:a.s)
        self.cands={k:v for k,v in self.cands.items() if t-k<=self.tmax}
    def start_set(self,prev,cyc):
        cycles=[prev,cyc]
        while True:
            b=self.cands.get(cycles[0][0])
            if b is None or b[2]<self.p.beta*np.median([c[2] for c in cycles]): break
            if self.ratio(b,cycles[0])>self.p.smax: break
            cycles.insert(0,b)
        if self.p.ext:
            f=cycles[0]; L=f[1]-f[0]; lo=max(self.origin,f[0]-2*L)
            if f[0]-lo>=0.5*L:
                T=np.array(self.Z[f[0]:f[1]+1]); S=np.array(self.Z[lo:f[0]+1])
                c,j=sub_dtw(T,S,True); b=lo+j
                amp=np.linalg.norm(S[j:]-S[-1],axis=1).max()
                if f[0]-b>=0.5*L and c/(0.5*(f[2]+amp))<=self.p.smax and amp>=self.p.beta*f[2]:
                    cycles.insert(0,(b,f[0],amp)); self.log.append((b,f[0],amp,c,'B'))
        self.cur=dict(cycles=[])
        for c in cycles: self.cur['cycles'].append(c); self.emit(c)
    def fwd(self,last,a,t):
        L=last[1]-last[0]
        if t-a<0.5*L or not self.p.ext: return None
        T=np.array(self.Z[last[0]:last[1]+1]); S=np.array(self.Z[a:min(t,a+2*L)+1])
        c,j=sub_dtw(T,S,False); amp=np.linalg.norm(S[:j+1]-S[0],axis=1).max()
        if j>=0.5*L and c/(0.5*(last[2]+amp))<=self.p.smax and amp>=self.p.beta*last[2]:
            return (a,a+j,amp)
        return None
    def spread_ok(self,c1,c2):
        W=np.array(self.Z[c1[0]:c2[1]+1]); i=np.argmax(np.linalg.norm(W-W[0],axis=1))
        D=np.linalg.norm(W-W[i],axis=1).max()
        if self.p.spmode==1: return max(c1[2],c2[2])>=self.p.kappa*D and min(c1[2],c2[2])>=self.p.beta*max(c1[2],c2[2])
        return min(c1[2],c2[2])>=self.p.kappa*D
    def ratio(self,c1,c2):
        A=resample(np.array(self.Z[c1[0]:c1[1]+1]),min(self.p.L,c1[1]-c1[0]+1))
        B=resample(np.array(self.Z[c2[0]:c2[1]+1]),min(self.p.L,c2[1]-c2[0]+1))
        return dtw(A,B)/(0.5*(c1[2]+c2[2]))
    def emit(self,cyc):
        self.events.append((cyc[0],cyc[1],len(self.cur['cycles']),self.now))
    def end_set(self,why):
        if self.cur is not None: self.cur['why']=why; self.sets.append(self.cur); self.cur=None
    def finish(self):
        p=self.p; t=len(self.Z)-1
        if self.track is not None:
            an=self.track
            if an.M>=self.thr() and an.m<=p.rho_end*an.M:
                if an.m<=p.rho*an.M:
                    level=an.m+p.eta*(an.M-an.m); e,x=self.low(an,level,t+1)
                    cut=min(t,e+self.pause//2) if x>=t-1 else self.place(an,e,x,t)
                else: cut=t
                cyc=(an.s,cut,an.M); r=self.ratio(self.cur['cycles'][-1],cyc); self.log.append(cyc+(r,'F'))
                if r<=p.smax: self.cur['cycles'].append(cyc); self.emit(cyc); self.end_set('end'); return
            cyc=self.fwd(self.cur['cycles'][-1],an.s,t)
            if cyc: self.log.append(cyc+(None,'X')); self.cur['cycles'].append(cyc); self.emit(cyc)
        else:
            for an in self.anchors:
                prev=self.cands.get(an.s)
                if prev is None: continue
                if an.M>=p.A and an.m<=p.rho_end*an.M:
                    cyc=(an.s,t,an.M); r=self.ratio(prev,cyc); self.log.append(cyc+(r,'F'))
                    if r<=p.smax and self.spread_ok(prev,cyc):
                        self.start_set(prev,cyc); break
            else:
                for e in sorted(self.cands,reverse=True):
                    prev=self.cands[e]
                    if prev is None: continue
                    cyc=self.fwd(prev,e,t)
                    if cyc and self.spread_ok(prev,cyc):
                        self.log.append(cyc+(None,'X')); self.start_set(prev,cyc); break
        self.end_set('end')

def run(F,fps,p=P):
    dec=max(1,int(round(fps/p.rate)))
    Fl=causal_lp(F,fps,p.lp_hz)
    tr=Tracker(p)
    for z in Fl[::dec]: tr.push(z)
    tr.finish()
    n=len(F); last=len(tr.Z)-1
    lag=int(round(p.lagcomp*np.sqrt(2)/(2*np.pi*p.lp_hz)*fps))
    def f(x):
        if x==0: return 0
        if x>=last: return n
        return max(0,min(n,x*dec-lag))
    sets=[[(f(a),f(b)) for a,b,_ in s['cycles']] for s in tr.sets]
    return sets,tr

def evaluate(sets_,p=P,verbose=False):
    rows=[]
    for s in sets_:
        found,tr=run(features(s['pos'],s['names']),120,p)
        reps=max(found,key=len) if found else []
        c=len(reps); k=s['k']; al=alpha_overlap(reps,s['reps'])
        rows.append((s['cls'],s['actor'],k,c,al))
        if verbose and c!=k:
            tb=[x for x,_ in s['reps']]+[s['reps'][-1][1]]
            print(f"{s['cls'][:12]:12s} {s['actor']} k={k:2d} found={[len(x) for x in found]} true={tb} log={[(a*4,b*4,round(m,1),r if r is None else round(r,2),w) for a,b,m,r,w in tr.log]}")
    return rows
