"""Session 18: which camera does the estimated depth of a rolling-shutter keyframe belong to?

Per pixel (u, v) of a rotation-rectified keyframe (every row given the middle
row's rotation R), the estimate d_est places the point C_mid + d_est ray. Two
models: (G) the surface where the middle camera's ray meets it, depth d_gs from
the global-shutter render of the same frame (/tmp/gsonly); (R) the surface seen
from the row's own centre C(y) along the same direction, placed from C_mid: what
first-order stereo gives (X_r - s), depth d_r from the rolling-shutter render's
depth (/tmp/rsonly) at the raw pixel of that ray. Regressing d_est - d_gs on
d_r - d_gs over many pixels gives beta: 1 = model R (the points need +s), 0 =
model G (the points are on the surface).
usage: rs_perpixel.py RUN_DIR   (an amhmvs_map output of /tmp/rsonly)
"""
import os, sys
import numpy as np
sys.path.insert(0, '/work/main/scripts')
from dense_folder_to_bag import read_cam, read_pfm
RS = '/tmp/rsonly'; GS = '/tmp/gsonly'; period = 0.5; readout = 0.025
run = sys.argv[1]
cams = [read_cam(f'{RS}/cams_gt/{k:08d}_cam.txt') for k in range(8)]
R = [E[:3, :3] for E, K in cams]; C = [-E[:3, :3].T @ E[:3, 3] for E, K in cams]; K = cams[0][1]
Ki = np.linalg.inv(K)

def slerp(Ra, Rb, f):
    M = Rb @ Ra.T
    ang = np.arccos(np.clip((np.trace(M) - 1) / 2, -1, 1))
    if ang < 1e-12: return Ra
    ax = np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]]) / (2 * np.sin(ang))
    a = ang * f; X = np.array([[0, -ax[2], ax[1]], [ax[2], 0, -ax[0]], [-ax[1], ax[0], 0]])
    return (np.eye(3) + np.sin(a) * X + (1 - np.cos(a)) * X @ X) @ Ra

def cam_at(k, seconds):
    pos = k + seconds / period; seg = int(np.clip(np.floor(pos), 0, 6)); f = pos - seg
    return slerp(R[seg], R[seg + 1], f), (1 - f) * C[seg] + f * C[seg + 1]

def bilinear(img, x, y):
    H, W = img.shape
    if not (0 <= x < W - 1 and 0 <= y < H - 1): return np.nan
    x0, y0 = int(x), int(y); fx, fy = x - x0, y - y0
    p = img[y0:y0 + 2, x0:x0 + 2]
    return (p[0, 0] * (1 - fx) + p[0, 1] * fx) * (1 - fy) + (p[1, 0] * (1 - fx) + p[1, 1] * fx) * fy

allx, ally = [], []
for k in range(1, 7):
    est = read_pfm(f'{run}/depth/{k:06d}.pfm'); rsd = read_pfm(f'{RS}/depth_gt/{k:08d}.pfm')
    gsd = read_pfm(f'{GS}/depth_gt/{k:08d}.pfm'); H = est.shape[0]
    xs, ys = [], []
    for v in range(4, H - 4, 3):
        for u in range(4, est.shape[1] - 4, 3):
            de, dg = est[v, u], gsd[v, u]
            if not (np.isfinite(de) and np.isfinite(dg)) or abs(de / dg - 1) > 0.02: continue
            ray = R[k].T @ (Ki @ np.array([u, v, 1.0]))      # world direction, middle rotation
            y = v
            for _ in range(8):                                # the raw row that sees this direction
                Rr, Cr = cam_at(k, readout * (y / (H - 1) - 0.5))
                p = K @ (Rr @ ray); x, y = p[0] / p[2], p[1] / p[2]
            z = bilinear(rsd, x, y)
            if not np.isfinite(z): continue
            Xr = Cr + Rr.T @ (Ki @ np.array([x, y, 1.0])) * z
            dr = (R[k] @ (Xr - Cr))[2]                        # placed from C_mid along the same ray
            if abs(dr / dg - 1) > 0.02: continue              # edges
            xs.append(dr - dg); ys.append(de - dg)
    xs, ys = np.array(xs), np.array(ys)
    beta = np.polyfit(xs, ys, 1)[0]
    print(f'kf {k}: n {len(xs)}, median |d_r - d_gs| {np.median(np.abs(xs))*1000:.2f} mm, '
          f'median d_est - d_gs {np.median(ys)*1000:+.2f} mm, beta {beta:+.2f}')
    allx.append(xs); ally.append(ys)
x, y = np.concatenate(allx), np.concatenate(ally)
print(f'all: n {len(x)}, beta {np.polyfit(x, y, 1)[0]:+.2f}; mean abs residual to G {np.mean(np.abs(y))*1000:.2f} mm, '
      f'to R {np.mean(np.abs(y - x))*1000:.2f} mm')
