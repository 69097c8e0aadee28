import csv, pickle, os, numpy as np, sys
sys.path.insert(0, '/work/wt/i33')
from streamseg.io import read
P='/tmp/i33/clips.pkl'
def load():
    if os.path.exists(P): return pickle.load(open(P,'rb'))
    out=[]
    root='/work/wt/i33/data/hdm05_reps'
    for row in csv.DictReader(open(root+'/clips.csv')):
        rec=read(f"{root}/{row['class']}/{row['file']}.gz", skeleton=f"{root}/asf/HDM_{row['actor']}.asf")
        out.append(dict(cls=row['class'],actor=row['actor'],file=row['file'],pos=rec.positions.astype(np.float32),names=rec.skeleton.names, up=rec.skeleton.up))
    pickle.dump(out,open(P,'wb'))
    return out
if __name__=='__main__':
    c=load(); print(len(c), c[0]['names'], c[0]['up'], c[0]['pos'].shape)
