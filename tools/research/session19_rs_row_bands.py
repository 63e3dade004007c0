"""Session 19: share of depth pixels within 2 cm of the global-shutter truth, per
keyframe and by sixths of the image rows (top to bottom), for amhmvs_map runs.
usage: /usr/bin/python3 session19_rs_row_bands.py GLOBAL_SHUTTER_DIR RUN_DIR...
"""
import sys, os, numpy as np
sys.path.insert(0, '/work/main/scripts')
from dense_folder_to_bag import read_pfm
gsdir=sys.argv[1]
for run in sys.argv[2:]:
    tot=np.zeros(6); cnt=np.zeros(6); kf=[]
    for k in range(8):
        est = read_pfm(f'{run}/depth/{k:06d}.pfm'); gs = read_pfm(f'{gsdir}/depth_gt/{k:08d}.pfm')
        H=est.shape[0]; m=np.isfinite(est)&np.isfinite(gs); err=np.abs(est-gs)
        ok=(err<0.02)&m
        kf.append(100*ok.sum()/m.sum())
        band=(np.arange(H)*6)//H
        for b in range(6):
            mb=m & (band[:,None]==b); tot[b]+=(ok&mb).sum(); cnt[b]+=mb.sum()
    print(run, 'per kf within 2cm:', ' '.join(f'{v:.1f}' for v in kf), '| by row band (top..bottom):', ' '.join(f'{v:.1f}' for v in 100*tot/cnt))
