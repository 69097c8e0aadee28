import sys; sys.path.insert(0,'/tmp/i33')
import numpy as np
from load import load
CLASSES=["squat1Reps","elbowToKnee1RepsLelbowStart","rotateArmsBothBackward1Reps","kickLFront1Reps","hopBothLegs1hops"]
def make_sets(actors=('bd','bk','dg'), sizes=(2,3,4,6,10), per=4, seed=0, draws=None):
    clips=load(); rng=np.random.default_rng(seed); out=[]
    for cls in CLASSES:
        for actor in actors:
            g=[c for c in clips if c['cls']==cls and c['actor']==actor]
            for k in sizes:
                if len(g)>=k:
                    starts=sorted(set(np.linspace(0,len(g)-k,per).round().astype(int).tolist()))
                    idxs=[list(range(s,s+k)) for s in starts]
                else:
                    idxs=[list(rng.choice(len(g),size=k,replace=True)) for _ in range(2)]
                for idx in idxs:
                    parts=[g[j]['pos'] for j in idx]
                    b=np.cumsum([0]+[len(p) for p in parts])
                    out.append(dict(cls=cls,actor=actor,k=k,pos=np.concatenate(parts),names=g[0]['names'],
                        reps=list(zip(b[:-1].tolist(),b[1:].tolist()))))
    return out
