"""Session 17: idealized triangulation of rolling-shutter observations.

For points of keyframe REF's global-shutter truth (/tmp/gsonly, the room
rendered with `amhmvs_synthetic --scene room --views 8 --realism none
--frame_period 0.5`), finds the row at which the rolling-shutter camera
(/tmp/rsonly: the same with --rolling_shutter_s 0.025; row cameras
interpolated between the frames as the renderer does) sees each point in
REF and SRC, takes the observed rays with the rotation rectified, and
triangulates them from the frames' (middle-row) centres. Prints the median
distance of the triangulated point P to X, X - s and X + s, s the REF row's
centre offset.  usage: session17_rs_triangulation.py REF SRC
"""
import os, sys
import numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'scripts'))
from dense_folder_to_bag import read_cam, read_pfm
F='/tmp/rsonly'; period=0.5; rs=0.025; H=240
cams=[read_cam(f'{F}/cams/{k:08d}_cam.txt') for k in range(8)]
R=[E[:3,:3] for E,K in cams]; C=[-E[:3,:3].T@E[:3,3] for E,K in cams]; K=cams[0][1]
def slerp_R(Ra,Rb,f):
    # camera-to-world rotations Ra^T, Rb^T; interpolate via axis-angle of Rb^T Ra... use world-to-camera R
    M=Rb@Ra.T  # rotation from a to b in camera terms (world-to-camera)
    ang=np.arccos(np.clip((np.trace(M)-1)/2,-1,1))
    if ang<1e-12: return Ra
    ax=np.array([M[2,1]-M[1,2],M[0,2]-M[2,0],M[1,0]-M[0,1]])/(2*np.sin(ang))
    a=ang*f; Kx=np.array([[0,-ax[2],ax[1]],[ax[2],0,-ax[0]],[-ax[1],ax[0],0]])
    Rf=np.eye(3)+np.sin(a)*Kx+(1-np.cos(a))*Kx@Kx
    return Rf@Ra
def cam_at(k,seconds):
    pos=k+seconds/period; seg=int(np.clip(np.floor(pos),0,6)); f=pos-seg
    return slerp_R(R[seg],R[seg+1],f), (1-f)*C[seg]+f*C[seg+1]
def observe(k,X):
    y=H/2
    for _ in range(30):
        Rr,Cr=cam_at(k, rs*(y/(H-1)-0.5))
        x=K@(Rr@(X-Cr)); y=x[1]/x[2]
    return Rr,Cr,y
def tri(c1,d1,c2,d2):
    A=np.stack([d1,-d2],1); l=np.linalg.lstsq(A,c2-c1,rcond=None)[0]
    return 0.5*(c1+l[0]*d1+c2+l[1]*d2)
G=read_pfm('/tmp/gsonly/depth_gt/00000003.pfm')
ref, src = int(sys.argv[1]), int(sys.argv[2])
errs=[]
for v in range(10,230,20):
  for u in range(20,300,40):
    z=G[v,u]
    if not np.isfinite(z): continue
    X=C[ref]+R[ref].T@(np.linalg.inv(K)@np.array([u,v,1.0])*z)
    Rr,Cr,yr=observe(ref,X); Rs,Cs,ys=observe(src,X)
    # rotation-rectified rays: directions with the mid rotation, from the model (mid) centres
    dr=X-Cr
    ds=(X-Cs)
    P=tri(C[ref],dr,C[src],ds)
    s=Cr-C[ref]
    errs.append((np.linalg.norm(P-X),np.linalg.norm(P-(X-s)),np.linalg.norm(P-(X+s)), yr, ys))
e=np.array(errs)
print('n',len(e),'median |P-X| mm %.2f, |P-(X-s)| %.2f, |P-(X+s)| %.2f'%tuple(np.median(e[:,:3],0)*1000))
print('median |row diff| %.1f px'%np.median(np.abs(e[:,3]-e[:,4])))
