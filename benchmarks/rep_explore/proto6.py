"""Online cycle tracker prototype v2: multi-anchor search, single-anchor tracking."""
import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from feat import features
from proto1 import causal_lp
from proto2 import resample, dtw
from proto5 import alpha_overlap, summary

class P:
    rate=30.0; A=0.8; rho=0.55; gamma=0.25; dabs=0.15; eta=0.1; beta=0.4
    smax=0.6; L=32; pause_s=3.0; tmax_s=8.0; lp_hz=3.0; rho_end=0.6; widen=0.0
    kmax=16; asep_s=0.2

class Anchor:
    __slots__=('s','M','tM','m','tm')
    def __init__(self,s): self.s=s; self.M=0.0; self.tM=s; self.m=np.inf; self.tm=s

class Tracker:
    def __init__(self,p=P):
        self.p=p; self.Z=[]; self.sp=[]
        self.pause=int(round(p.pause_s*p.rate)); self.tmax=int(round(p.tmax_s*p.rate))
        self.asep=max(1,int(round(p.asep_s*p.rate)))
        self.anchors=[]; self.cands={}  # end index -> cycle (s,e,M)
        self.cur=None; self.sets=[]; self.events=[]; self.log=[]
        self.track=None  # Anchor in tracking mode
    def dist(self,t,s): return float(np.linalg.norm(self.Z[t]-self.Z[s]))
    def upd(self,an,t):
        d=self.dist(t,an.s)
        if d>an.M: an.M=d; an.tM=t; an.m=np.inf
        if t>an.tM and d<an.m: an.m=d; an.tm=t
        return d
    def seeded(self,s,t):
        an=Anchor(s)
        for u in range(s+1,t+1): self.upd(an,u)
        return an
    def push(self,z):
        self.Z.append(np.asarray(z,float)); t=len(self.Z)-1
        self.sp.append(0.0 if t==0 else float(np.linalg.norm(self.Z[t]-self.Z[t-1])))
        if t==0: self.anchors=[Anchor(0)]; return
        # speed minimum at t-1 -> new search anchor
        if t>=2 and self.sp[t-1]<=self.sp[t-2] and self.sp[t-1]<self.sp[t] and self.track is None:
            if not self.anchors or t-1-self.anchors[-1].s>=self.asep:
                self.anchors.append(self.seeded(t-1,t-1))
        if self.track is not None: self._track(t)
        else: self._search(t)
    # --- closing test shared by both modes
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
        sp=[self.dist(u+1,u-1) if u>=1 and u+1<len(self.Z) else 1e9 for u in range(lo,hi+1)]
        return lo+int(np.argmin(sp))
    def thr(self):
        if self.cur is None: return self.p.A
        return max(self.p.A,self.p.beta*np.median([c[2] for c in self.cur['cycles'][-5:]]))
    def _track(self,t):
        an=self.track
        kind,cut=self.closes(an,t,self.thr())
        if kind:
            cyc=(an.s,cut,an.M); prev=self.cur['cycles'][-1]
            r=self.ratio(prev,cyc); self.log.append(cyc+(r,'T'))
            if r<=self.p.smax:
                self.cur['cycles'].append(cyc); self.emit(cyc,t)
                if kind=='pause': self.end_set('pause'); self.to_search(cut,t,[])
                else: self.track=self.seeded(cut,t)
            else:
                self.end_set('dissimilar'); self.cands={cut:cyc}
                self.to_search(an.s,t,[cut])
        elif t-an.s>self.tmax:
            self.end_set('timeout'); self.to_search(an.s,t,[])
    def to_search(self,after,t,extra):
        self.track=None
        # seed anchors: the cut(s) and speed minima after `after`
        pts=set(extra)
        for u in range(after+1,t):
            if self.sp[u]<=self.sp[u-1] and self.sp[u]<self.sp[u+1]: pts.add(u)
        pts=sorted(x for x in pts if x>=after)
        self.anchors=[self.seeded(u,t) for u in pts][-self.p.kmax:]
    def _search(self,t):
        closed=[]
        keep=[]
        for an in self.anchors:
            kind,cut=self.closes(an,t,self.p.A)
            if kind: closed.append((an,kind,cut))
            elif t-an.s<=self.tmax: keep.append(an)
        self.anchors=keep[-self.p.kmax:]
        for an,kind,cut in closed:
            cyc=(an.s,cut,an.M)
            prev=self.cands.get(an.s)
            r=self.ratio(prev,cyc) if prev else None
            self.log.append(cyc+(r,'S'))
            if prev is not None and r<=self.p.smax:
                self.cur=dict(cycles=[prev,cyc]); self.emit(prev,t); self.emit(cyc,t)
                self.cands={}
                if kind=='pause': self.end_set('pause'); self.to_search(cut,t,[]) 
                else: self.track=self.seeded(cut,t); self.anchors=[]
                return
            self.cands[cut]=cyc
            if kind!='pause' and all(a.s!=cut for a in self.anchors):
                self.anchors.append(self.seeded(cut,t)); self.anchors.sort(key=lambda a:a.s)
        # forget old candidate cycles
        self.cands={k:v for k,v in self.cands.items() if t-k<=self.tmax}
    def ratio(self,c1,c2):
        A=resample(np.array(self.Z[c1[0]:c1[1]+1]),min(self.p.L,c1[1]-c1[0]+1))
        B=resample(np.array(self.Z[c2[0]:c2[1]+1]),min(self.p.L,c2[1]-c2[0]+1))
        return dtw(A,B)/(0.5*(c1[2]+c2[2]))
    def emit(self,cyc,t):
        self.events.append((cyc[0],cyc[1],len(self.cur['cycles']),t))
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
                if r<=p.smax: self.cur['cycles'].append(cyc); self.emit(cyc,t)
        else:
            for an in self.anchors:
                prev=self.cands.get(an.s)
                if prev is None: continue
                if an.M>=p.A and an.m<=p.rho_end*an.M:
                    cyc=(an.s,t,an.M); r=self.ratio(prev,cyc); self.log.append(cyc+(r,'F'))
                    if r<=p.smax:
                        self.cur=dict(cycles=[prev,cyc]); self.emit(prev,t); self.emit(cyc,t); break
        self.end_set('end')

def run(F,fps,p=P):
    dec=max(1,int(round(fps/p.rate)))
    Fl=causal_lp(F,fps,p.lp_hz)
    tr=Tracker(p)
    for z in Fl[::dec]: tr.push(z)
    tr.finish()
    n=len(F); last=len(tr.Z)-1
    sets=[[(min(n,a*dec),min(n,b*dec if b<last else n)) for a,b,_ in s['cycles']] for s in tr.sets]
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
