# Copies a dense folder with every image resampled bilinearly by (s, s) px and
# the principal point moved with it: same geometry, one bilinear resampling.
import sys, os, shutil, re, numpy as np, cv2
src, dst, s = sys.argv[1], sys.argv[2], float(sys.argv[3])
shutil.rmtree(dst, ignore_errors=True); shutil.copytree(src, dst)
for f in os.listdir(f'{dst}/images'):
    img = cv2.imread(f'{src}/images/{f}', cv2.IMREAD_UNCHANGED)
    M = np.float32([[1, 0, s], [0, 1, s]])
    out = cv2.warpAffine(img, M, (img.shape[1], img.shape[0]), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    cv2.imwrite(f'{dst}/images/{f}', out)
for d in ('cams', 'cams_gt'):
    if not os.path.isdir(f'{dst}/{d}'): continue
    for f in os.listdir(f'{dst}/{d}'):
        L = open(f'{dst}/{d}/{f}').read().split('\n')
        i = L.index('intrinsic')
        r0 = L[i + 1].split(); r0[2] = repr(float(r0[2]) + s); L[i + 1] = ' '.join(r0)
        r1 = L[i + 2].split(); r1[2] = repr(float(r1[2]) + s); L[i + 2] = ' '.join(r1)
        open(f'{dst}/{d}/{f}', 'w').write('\n'.join(L))
