import numpy as np
def sub_dtw(T, S, fixed_end=True):
    """Align the whole template T (n,D) to a piece of S (m,D).
    fixed_end=True: the piece ends at S[-1], its start is free (open begin).
    fixed_end=False: the piece starts at S[0], its end is free (open end).
    Returns (normalised cost, piece start or end index in S)."""
    if not fixed_end:
        c,j=sub_dtw(T[::-1],S[::-1],True); return c,len(S)-1-j
    n,m=len(T),len(S)
    C=np.linalg.norm(T[:,None]-S[None],axis=2)
    D=np.full((n,m),np.inf); K=np.zeros((n,m)); B=np.zeros((n,m),int)
    # open begin: T[0] may match any S[j]; path runs T[0..n-1] x S[j0..m-1], must end at (n-1,m-1)
    D[0,:]=C[0,:]; K[0,:]=1; B[0,:]=np.arange(m)
    for j in range(1,m):  # staying on T[0] while S advances = the piece started earlier: no, restart is free
        pass
    for i in range(1,n):
        for j in range(m):
            best=(np.inf,0,0)
            for di,dj in ((1,1),(1,0),(0,1)):
                a,b=i-di,j-dj
                if b<0: continue
                if a<0: continue
                if di==0 and a==0: continue  # horizontal moves on row 0 would mean an earlier start
                v=(D[a,b]+C[i,j])/(K[a,b]+1)
                if v<best[0]: best=(v,a,b)
            _,a,b=best
            if np.isfinite(best[0]):
                D[i,j]=D[a,b]+C[i,j]; K[i,j]=K[a,b]+1; B[i,j]=B[a,b]
    return D[n-1,m-1]/K[n-1,m-1], int(B[n-1,m-1])
