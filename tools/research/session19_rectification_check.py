"""Session 19: is the rolling-shutter rectification exact? For keyframes of the
8-view room (rolling shutter only, /tmp/rsonly; its global-shutter render
/tmp/gsonly), rectify the rolling-shutter image as rolling_shutter.cpp does,
with (a) the chord angular velocity from the previous keyframe (what the
mapper uses) and (b) the path's true one (central difference over +-0.025 s
of /tmp/dense141: the same path rendered as 141 frames 0.025 s apart), then
measure the image motion left against the global-shutter render (phase
correlation of 48 px blocks), in the top and bottom thirds, on far (> 4 m) and
near (< 3 m) surfaces; beside it, what the translation during the readout
alone predicts for the same blocks.
usage: /usr/bin/python3 session19_rectification_check.py
"""
import sys, numpy as np, cv2
sys.path.insert(0, '/work/main/scripts')
from dense_folder_to_bag import read_cam, read_pfm
RS, GS, DENSE, readout = '/tmp/rsonly', '/tmp/gsonly', '/tmp/dense141', 0.025

def cam(d, k):
    E, K = read_cam(f'{d}/cams/{k:08d}_cam.txt'); return E[:3, :3], K

def angular_velocity(R_earlier, R_later, dt):  # as cameraAngularVelocity (later camera's frame)
    M = R_earlier @ R_later.T
    ang = np.arccos(np.clip((np.trace(M) - 1) / 2, -1, 1))
    if ang < 1e-12: return np.zeros(3)
    axis = np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]]) / (2 * np.sin(ang))
    return ang * axis / dt

def rectify(img, K, w):
    H, W = img.shape; speed = np.linalg.norm(w)
    if speed == 0: return img.astype(np.float32)
    axis = w / speed; u, v = np.meshgrid(np.arange(W, dtype=float), np.arange(H, dtype=float))
    ray = np.stack([(u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1], np.ones_like(u)], -1)
    axr = np.cross(np.broadcast_to(axis, ray.shape), ray); adr = ray @ axis
    row = v.copy()
    for _ in range(2):
        a = -speed * (row * readout / (H - 1) - 0.5 * readout)
        s, omc = np.sin(a)[..., None], (1 - np.cos(a))[..., None]
        seen = ray * (1 - omc) + axr * s + axis * (adr[..., None] * omc)
        row = K[1, 1] * seen[..., 1] / seen[..., 2] + K[1, 2]
    su = (K[0, 0] * seen[..., 0] / seen[..., 2] + K[0, 2]).astype(np.float32)
    return cv2.remap(img.astype(np.float32), su, row.astype(np.float32), cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

def band_blocks(depth):
    """(band label, [(x0, y0), ...]) of the 48 px blocks whose true depth is
    all far or all near, in the top and bottom thirds; bands with < 3 blocks left out."""
    H, W = depth.shape
    for name, y0s in (('top', range(4, H // 3 - 24, 24)), ('bottom', range(2 * H // 3 - 24, H - 52, 24))):
        for dn, test in (('far', lambda d: np.all(d > 4)), ('near', lambda d: np.all(d < 3))):
            blocks = [(x0, y0) for y0 in y0s for x0 in range(4, W - 52, 24) if test(depth[y0:y0 + 48, x0:x0 + 48])]
            if len(blocks) >= 3: yield f'{name}/{dn}', blocks

def predicted_translation(depth, K, velocity, label):
    """What the translation during the readout alone moves a rotation-rectified
    image by (px) at each block's centre: row camera centre tau(v) velocity."""
    H = depth.shape[0]; Ki = np.linalg.inv(K); out = []
    for band, blocks in band_blocks(depth):
        shifts = []
        for x0, y0 in blocks:
            u, v = x0 + 23.5, y0 + 23.5
            X = np.median(depth[y0:y0 + 48, x0:x0 + 48]) * (Ki @ np.array([u, v, 1.0]))
            tau = readout * (v / (H - 1) - 0.5)
            p = K @ (X - tau * velocity); shifts.append(p[:2] / p[2] - np.array([u, v]))
        m = np.mean(shifts, 0); out.append(f'{band} mean {m[0]:+.3f},{m[1]:+.3f}')
    print(f'  {label:22s}', ' | '.join(out))

def measured_motion(ref, img, depth, label):
    """Image motion of img against ref (px, phase correlation per block), mean
    and mean absolute value over a band's blocks."""
    ref32, img32 = ref.astype(np.float32), img.astype(np.float32)
    win = cv2.createHanningWindow((48, 48), cv2.CV_32F); out = []
    for band, blocks in band_blocks(depth):
        shifts = [cv2.phaseCorrelate(ref32[y0:y0 + 48, x0:x0 + 48], img32[y0:y0 + 48, x0:x0 + 48], win)[0]
                  for x0, y0 in blocks]
        m = np.mean(shifts, 0); a = np.mean(np.abs(shifts), 0)
        out.append(f'{band} ({len(shifts)} blocks) mean {m[0]:+.3f},{m[1]:+.3f} |.| {a[0]:.3f},{a[1]:.3f}')
    print(f'  {label:22s}', ' | '.join(out))

for k in range(1, 7):
    gray = lambda p: cv2.cvtColor(cv2.imread(p), cv2.COLOR_BGR2GRAY)
    rs, gs = gray(f'{RS}/images/{k:08d}.png'), gray(f'{GS}/images/{k:08d}.png')
    depth = read_pfm(f'{GS}/depth_gt/{k:08d}.pfm')
    R, K = cam(RS, k); Rp, _ = cam(RS, k - 1)
    w_chord = angular_velocity(Rp, R, 0.5)
    Ra, _ = cam(DENSE, 20 * k - 1); Rb, _ = cam(DENSE, 20 * k + 1)
    w_true = angular_velocity(Ra, Rb, 0.05)
    print(f'keyframe {k}: |w| chord {np.degrees(np.linalg.norm(w_chord)):.2f} deg/s, true {np.degrees(np.linalg.norm(w_true)):.2f}, '
          f'angle between {np.degrees(np.arccos(np.clip(w_chord @ w_true / np.linalg.norm(w_chord) / np.linalg.norm(w_true), -1, 1))):.1f} deg')
    measured_motion(gs, gs, depth, 'global vs itself')
    measured_motion(gs, rs, depth, 'raw rolling shutter')
    measured_motion(gs, rectify(rs, K, w_chord), depth, 'rectified, chord w')
    measured_motion(gs, rectify(rs, K, w_true), depth, 'rectified, true w')
    measured_motion(gs, rectify(rs, K, -w_true), depth, 'rectified, -true w')
    Ea, _ = read_cam(f'{DENSE}/cams/{20 * k - 1:08d}_cam.txt'); Eb, _ = read_cam(f'{DENSE}/cams/{20 * k + 1:08d}_cam.txt')
    centre = lambda E: -E[:3, :3].T @ E[:3, 3]
    velocity = R @ (centre(Eb) - centre(Ea)) / 0.05
    predicted_translation(depth, K, velocity, 'translation (model)')
