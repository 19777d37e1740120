# Caustic-region mask for `caustics compare --mask` (docs/benchmarks.md): needs numpy, pillow, OpenEXR (pip).
# region_mask.py REF.exr GPU.exr MASK.png: black where the reference's or the GPU's caustic exceeds
# 2 % of the reference's 99.5th-percentile luminance (as the retired tracers example's region), white elsewhere.
import sys, numpy as np, OpenEXR
from PIL import Image
def lum(p):
    with OpenEXR.File(p) as f:
        ch = f.channels()
        if 'RGB' in ch: a = ch['RGB'].pixels
        else: a = np.stack([ch[c].pixels for c in 'RGB'], -1)
    a = a.astype(np.float64)
    return 0.2126*a[...,0]+0.7152*a[...,1]+0.0722*a[...,2]
r, g = lum(sys.argv[1]), lum(sys.argv[2])
rp = np.sort(r[r > 0]); t = 0.02*rp[int(len(rp)*0.995)]
m = (r > t) | (g > t)
Image.fromarray(np.where(m, 0, 255).astype(np.uint8)).save(sys.argv[3])
print("region pixels", int(m.sum()))
