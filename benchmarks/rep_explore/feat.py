import numpy as np, sys
sys.path.insert(0, '/work/wt/i33')
from streamseg.skeleton.names import POINTS, resolve
from scipy.signal import butter, sosfiltfilt
PTS=("pelvis","sternum","l_hip","r_hip","l_shoulder","l_elbow","l_wrist","r_shoulder","r_elbow","r_wrist","l_knee","l_ankle","r_knee","r_ankle")
BONES=[("l_shoulder","l_elbow"),("l_elbow","l_wrist"),("r_shoulder","r_elbow"),("r_elbow","r_wrist"),("l_hip","l_knee"),("l_knee","l_ankle"),("r_hip","r_knee"),("r_knee","r_ankle")]
def unit(v): return v/np.maximum(np.linalg.norm(v,axis=-1,keepdims=True),1e-12)
def features(pos, names, upaxis='y', root_w=1.0):
    idx=dict(zip(PTS, resolve(list(names), PTS, POINTS)))
    P={k:pos[:,i].astype(np.float64) for k,i in idx.items()}
    up_w=np.zeros(3); up_w['xyz'.index(upaxis)]=1
    up=unit(P['sternum']-P['pelvis'])
    lat=P['l_hip']-P['r_hip']; lat=unit(lat-np.sum(lat*up,1,keepdims=True)*up)
    fwd=np.cross(lat,up)
    R=np.stack([lat,up,fwd],1)
    out=[]
    for a,b in BONES:
        out.append(np.einsum('nij,nj->ni',R,unit(P[b]-P[a])))
    # trunk in heading frame
    h=fwd-np.sum(fwd*up_w,1,keepdims=True)*up_w; h=unit(h)
    s=np.cross(up_w[None],h)
    out.append(np.stack([np.sum(up*h,1),np.sum(up*s,1),np.sum(up*up_w,1)],1))
    scale=np.median(np.linalg.norm(P['l_knee']-P['l_hip'],axis=1))
    height=(P['pelvis']@up_w)/scale
    out.append(root_w*(height-np.median(height))[:,None])
    return np.concatenate(out,1)
def lowpass(X,fps,hz,order=2):
    sos=butter(order,hz,fs=fps,output='sos'); return sosfiltfilt(sos,X,axis=0)
