"""Session 19: checks the row-camera-centre homography of the rolling-shutter
experiment (a patch, not kept; rowCentreHomography) against the
exact geometry. A world point is projected into two rolling-shutter cameras
whose rows are exposed from centres C + tau(y) v (rotation already rectified:
every row has the middle row's orientation), solving each row's fixed point;
the patch's formulas (q' = q / (1 + tau_r q^T K_r v_r), b' = b + tau_r K_s R v_r
- tau_s(y') K_s v_s, y' from one step) must map the reference pixel onto the
source pixel. Prints both and the global-shutter homography's answer.
usage: /usr/bin/python3 session19_row_centre_check.py  (numpy)
"""
import numpy as np
rng=np.random.default_rng(1)
def rot(a):
    a=np.asarray(a); th=np.linalg.norm(a); k=a/th; K=np.array([[0,-k[2],k[1]],[k[2],0,-k[0]],[-k[1],k[0],0]])
    return np.eye(3)+np.sin(th)*K+(1-np.cos(th))*K@K
K=np.array([[256,0,160],[0,256,120],[0,0,1.]]); H=240; ro=0.025
Rr=rot([0.1,0.2,0.05]); Cr=np.array([0.,0,0]); Rs=rot([0.12,0.05,0.1]); Cs=np.array([0.4,0.1,-0.05])
vw_r=np.array([0.7,0.2,0.3]); vw_s=np.array([-0.5,0.3,0.4])
X=Cr+Rr.T@np.array([0.3,-0.4,3.0])
nw=rng.normal(size=3); nw/=np.linalg.norm(nw)
# row camera projection: fixed point in row
def proj(R,C,v,X):
    y=H/2
    for _ in range(50):
        tau=ro*(y/(H-1)-0.5); c=R@(X-(C+tau*v)); p=K@c; p/=p[2]; y=p[1]
    return p,tau
p,tr=proj(Rr,Cr,vw_r,X); ps,ts=proj(Rs,Cs,vw_s,X)
# mid-frame geometry: plane through X in ref mid cam coords: n^T Xc + d = 0
n=Rr@nw; Xc=Rr@(X-Cr); d=-n@Xc
if d<0: n=-n; d=-d
R=Rs@Rr.T; t=Rs@(Cr-Cs)  # X_s = R X_r + t
A=K@R@np.linalg.inv(K); b=K@t; q=np.linalg.inv(K).T@n/d
v_r=Rr@vw_r; v_s=Rs@vw_s
a_r=ro/(H-1); c_r=-0.5*ro
tau_r=a_r*p[1]+c_r
q2=q/(1+tau_r*q@(K@v_r)); b2=b+tau_r*(K@R@v_r)
h=(A-np.outer(b2,q2))@p; tau_s=a_r*(h[1]/h[2])+c_r
b3=b2-tau_s*(K@v_s)
h=(A-np.outer(b3,q2))@p; h/=h[2]
print('true source pixel',ps,'model',h,'tau',tr,ts,tau_s)
h0=(A-np.outer(b,q))@p; h0/=h0[2]; print('global model',h0)
