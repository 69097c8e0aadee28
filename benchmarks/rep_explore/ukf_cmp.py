import sys, os, pickle, numpy as np, time
sys.path.insert(0,'/tmp/i33')
from sets import make_sets
from proto5 import alpha_overlap, summary
from streamseg.online.repetition import RepetitionCounter, pose_features
from streamseg.kinematics.model import bone_directions, limb_points, observations, estimate_noise, fit_angles
def ukf_dirs(pos, names, fps=120.0):
    pts=limb_points(pos.astype(np.float64), names)
    Y,scale,pdir,l0=observations(pts,fps,2.0)
    noise=max(0.05, estimate_noise(pos, scale))
    a,_=fit_angles(Y,fps,pdir,l0,position_noise=noise,angle_speed=8.0,length_speed=0.02,passes=4)
    return bone_directions(a)
cache='/tmp/i33/ukf_cache.pkl'
C=pickle.load(open(cache,'rb')) if os.path.exists(cache) else {}
res={'direct':[], 'ukf':[]}
for i,s in enumerate(make_sets(actors=('bd',))):
    key=(s['cls'],s['k'],i)
    if key not in C: C[key]=ukf_dirs(s['pos'],s['names'])
    D=C[key]
    F=pose_features(s['pos'],s['names'],'y')
    # UKF: humerus, radius (l, r), femur, tibia (l, r) = columns 3:9, 12:18, 18:30 of the 30
    U=np.concatenate([D[:,3:9],D[:,12:18],D[:,18:30],F[:,24:]],axis=1)
    for name,X in (('direct',F),('ukf',U)):
        c=RepetitionCounter(fps=120.0); c.learn_many(X); c.finish()
        sets=[x.repetitions for x in c.sets_]; reps=max(sets,key=len) if sets else []
        res[name].append((s['cls'],'bd',s['k'],len(reps),alpha_overlap(reps,s['reps'])))
pickle.dump(C,open(cache,'wb'))
for k,v in res.items(): print(k, summary([r for r in v if r[2]<=6]))
