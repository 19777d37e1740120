#!/usr/bin/env python3
"""Recover the scene parameters of the two reference images by fitting.

Usage:  python3 tools/fit_reference_scenes.py /work/shared/references [--quick]

Dependencies: Python 3.9+, numpy, scipy, OpenEXR (the `OpenEXR` pip package, v3 API:
OpenEXR.File), imageio (v3 API) + pillow for PNG.  No GPU.  Runtime: a few minutes
(--quick skips the Monte Carlo albedo / caustic-energy checks).

What it does (see docs/reference-scenes.md):
  * a numpy ray caster of the camera of docs/scene-format.md (pinhole, vertical fov,
    image x = forward x up, pixel (0,0) top-left, pixel centre at +0.5, box filter);
  * sub-pixel edge points are extracted from anti-aliased images (specmask silhouette,
    shadow edges and floor-rectangle edges of NAME_nocaustic.exr) by inverting the
    coverage of a straight edge through a box pixel; model curves (sphere / cylinder
    outlines, shadow outlines, rectangle edges) are projected and the signed distance
    edge point -> curve is a residual;
  * lit-floor pixels of NAME_nocaustic.exr are fitted with analytic direct lighting of a
    Lambertian floor (L = albedo/pi * E), 2x2 supersampled;
  * scipy.optimize.least_squares fits all of it; then the round values are substituted
    and the residuals compared;
  * checks: energy.sum_nocaster (exact analytic), albedo from the indirect light in the
    sphere's shadow (floor -> glass -> floor), caustic image sums by photon tracing, and the
    mirror reflectance from the mirror pixels of the ring's nocaustic image.
"""
import os, sys, json
import numpy as np
import OpenEXR
import imageio.v3 as iio
from scipy import ndimage
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

W = H = 512
QUICK = '--quick' in sys.argv

# ----------------------------------------------------------------------------- I/O
def rd_exr(p):
    return OpenEXR.File(p).parts[0].channels['RGB'].pixels.astype(np.float64)

def load(ref, n):
    nc = rd_exr(os.path.join(ref, n + '_nocaustic.exr'))[..., 1]   # images are grey
    c = rd_exr(os.path.join(ref, n + '_caustic.exr'))[..., 1]
    m = iio.imread(os.path.join(ref, n + '_specmask.png'))[..., 0] / 255.0
    meta = json.load(open(os.path.join(ref, n + '.json')))
    return nc, c, m, meta

# ----------------------------------------------------------------------------- camera
def norm(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)

def cam_basis(pos, look, up=(0, 1, 0)):
    pos = np.asarray(pos, float)
    f = norm(np.asarray(look, float) - pos)
    r = norm(np.cross(f, np.asarray(up, float)))     # image x = forward x up
    u = np.cross(r, f)
    return pos, f, r, u

def cam_rays(pos, look, fov, px, py):
    """px, py: continuous pixel coordinates, (0,0) = top-left corner of the image."""
    o, f, r, u = cam_basis(pos, look)
    t = np.tan(np.radians(fov) / 2)
    sx = (2 * px / W - 1) * t
    sy = (1 - 2 * py / H) * t
    return o, norm(f + sx[..., None] * r + sy[..., None] * u)

def project(pos, look, fov, X):
    o, f, r, u = cam_basis(pos, look)
    v = X - o
    z = v @ f
    t = np.tan(np.radians(fov) / 2)
    return np.stack([((v @ r) / z / t + 1) * W / 2, (1 - (v @ u) / z / t) * H / 2], -1)

def pix_area(Q, pos, look, fov):
    """floor area (y=0 plane) seen by one pixel at floor point Q"""
    o, f, r, u = cam_basis(pos, look)
    v = Q - o
    dist = np.linalg.norm(v, axis=-1)
    cosa = (v @ f) / dist
    fpx = (H / 2) / np.tan(np.radians(fov) / 2)
    return dist ** 2 * cosa ** 3 / (fpx ** 2 * np.abs(v[..., 1]) / dist)

def in_view(Q, pos, look, fov):
    p = project(pos, look, fov, Q)
    return (p[:, 0] >= 0) & (p[:, 0] < W) & (p[:, 1] >= 0) & (p[:, 1] < H)

# ----------------------------------------------------------------------------- intersections
def hit_sphere(o, d, c, rad, eps=1e-7):
    oc = o - c
    b = np.sum(oc * d, -1)
    cc = np.sum(oc * oc, -1) - rad * rad
    disc = b * b - cc
    sq = np.sqrt(np.maximum(disc, 0))
    t1, t2 = -b - sq, -b + sq
    t = np.where(t1 > eps, t1, np.where(t2 > eps, t2, np.inf))
    return np.where(disc > 0, t, np.inf)

def hit_cyl(o, d, R, h, eps=1e-6):
    """open vertical tube x^2+z^2=R^2, 0<=y<=h"""
    a = d[..., 0] ** 2 + d[..., 2] ** 2
    b = 2 * (o[..., 0] * d[..., 0] + o[..., 2] * d[..., 2])
    c = o[..., 0] ** 2 + o[..., 2] ** 2 - R * R
    disc = b * b - 4 * a * c
    sq = np.sqrt(np.maximum(disc, 0))
    a = np.maximum(a, 1e-12)
    best = np.full(o.shape[:-1], np.inf)
    for t in ((-b - sq) / (2 * a), (-b + sq) / (2 * a)):
        y = o[..., 1] + t * d[..., 1]
        ok = (disc > 0) & (t > eps) & (y >= 0) & (y <= h) & (t < best)
        best = np.where(ok, t, best)
    return best

def fresnel(cosi, eta):
    sin2t = (1 - cosi ** 2) / eta ** 2
    tir = sin2t >= 1
    cost = np.sqrt(np.maximum(1 - sin2t, 0))
    rs = (cosi - eta * cost) / (cosi + eta * cost)
    rp = (eta * cosi - cost) / (eta * cosi + cost)
    return np.where(tir, 1.0, 0.5 * (rs * rs + rp * rp)), cost

# ----------------------------------------------------------------------------- sub-pixel edges
def _cdf(z, a, b):
    a, b = np.maximum(a, b), np.maximum(np.minimum(a, b), 1e-6)
    return np.where(z <= -(a + b), 0.0,
           np.where(z <= -(a - b), (z + a + b) ** 2 / (8 * a * b),
           np.where(z <= a - b, (z + a) / (2 * a),
           np.where(z <= a + b, 1 - (a + b - z) ** 2 / (8 * a * b), 1.0))))

def edge_points(f, sel=None, lo=0.03, hi=0.97):
    """Sub-pixel points of a straight-edge model on an anti-aliased indicator image f
    (1 inside, 0 outside, box-filtered).  Returns points (px,py) and unit normals."""
    fs = ndimage.gaussian_filter(f, 1.0)
    gy, gx = ndimage.sobel(fs, 0), ndimage.sobel(fs, 1)
    g = np.hypot(gx, gy) + 1e-12
    cand = (f > lo) & (f < hi)
    if sel is not None:
        cand &= sel
    iy, ix = np.nonzero(cand)
    nx, ny = gx[iy, ix] / g[iy, ix], gy[iy, ix] / g[iy, ix]
    fv = np.clip(f[iy, ix], 1e-4, 1 - 1e-4)
    lo_, hi_ = -np.ones_like(fv), np.ones_like(fv)
    for _ in range(40):                      # invert coverage(s) = fv by bisection
        mid = (lo_ + hi_) / 2
        cm = _cdf(mid, np.abs(nx) / 2, np.abs(ny) / 2)
        lo_, hi_ = np.where(cm < fv, mid, lo_), np.where(cm < fv, hi_, mid)
    s = (lo_ + hi_) / 2
    return np.stack([ix + 0.5 - s * nx, iy + 0.5 - s * ny], -1), np.stack([nx, ny], -1)

def signed_curve_dist(pts, nrm, curve):
    tr = cKDTree(curve)
    d, i = tr.query(pts)
    n = len(curve)
    best, vec = d, pts - curve[i]
    for j in (-1, 1):
        k = np.clip(i + j, 0, n - 1)
        A, B = curve[i], curve[k]
        AB = B - A
        tt = np.clip(np.sum((pts - A) * AB, -1) / (np.sum(AB * AB, -1) + 1e-18), 0, 1)
        Q = A + tt[:, None] * AB
        dd = np.linalg.norm(pts - Q, axis=-1)
        better = dd < best
        best = np.where(better, dd, best)
        vec = np.where(better[:, None], pts - Q, vec)
    return np.sum(vec * nrm, -1)

def circle(cen, r, n=2000):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return cen + r * np.stack([np.cos(th), 0 * th, np.sin(th)], -1)

def seg(A, B, n=800):
    return A + np.linspace(0, 1, n)[:, None] * (B - A)

def cos_dirs(n, rng):
    k = int(np.sqrt(n))
    u1 = (np.arange(k)[:, None] + rng.random((k, k))) / k
    u2 = (np.arange(k)[None, :] + rng.random((k, k))) / k
    r, ph = np.sqrt(u1.ravel()), 2 * np.pi * u2.ravel()
    return np.stack([r * np.cos(ph), np.sqrt(1 - r * r), r * np.sin(ph)], -1)

def fit_report(names, p, free, fun, label):
    """least squares on the free subset; prints value +- 1 sigma (scaled by the
    reduced chi^2 when that is > 1)"""
    free = np.asarray(free)
    def f(x):
        q = p.copy(); q[free] = x
        return fun(q)
    fr = least_squares(f, p[free], diff_step=1e-6, x_scale=0.1)
    q = p.copy(); q[free] = fr.x
    J = fr.jac
    red = max(1.0, 2 * fr.cost / max(1, len(fr.fun) - len(free)))
    sd = np.zeros(len(p))
    sd[free] = np.sqrt(np.diag(np.linalg.pinv(J.T @ J)) * red)
    print(f'  [{label}] cost {fr.cost:.1f}  ({len(fr.fun)} residuals)')
    for i in free:
        print(f'    {names[i]:10s} {q[i]:11.5f} +- {sd[i]:.5f}')
    return q, sd, fr.cost

# ============================================================================= scene A
SC, SR, IOR = np.array([0, 0.9, 0.0]), 0.5, 1.5
A_NAMES = ['cam_x', 'cam_y', 'cam_z', 'look_y', 'fov', 'light_x', 'light_y', 'light_z',
           'cone', 'falloff', 'K=alb*I/pi']
A_ROUND = np.array([0, 2.6, 4.2, 0.45, 38.0, 0, 5.0, 0, 20.0, 15.0, 30 / np.pi])

def a_unpack(p):
    return (np.array([p[0], p[1], p[2]]), np.array([0, p[3], 0.0]), p[4],
            np.array([p[5], p[6], p[7]]), p[8], p[9], p[10])

def spot_floor(P, Lp, cone, fs, K, occl=True):
    v = Lp - P
    dist = np.linalg.norm(v, axis=-1)
    v = v / dist[..., None]
    ang = np.degrees(np.arccos(np.clip(v[..., 1], -1, 1)))     # spot axis (0,-1,0)
    fall = np.clip((cone - ang) / (cone - fs), 0, 1)
    L = K * fall * v[..., 1] / dist ** 2
    sh = np.isfinite(hit_sphere(P, v, SC, SR)) if occl else np.zeros(P.shape[:-1], bool)
    return np.where(sh, 0.0, L), sh

def a_floor_img(p, occl=True, ss=2):
    pos, look, fov, Lp, cone, fs, K = a_unpack(p)
    yy, xx = np.mgrid[0:H, 0:W]
    acc, shany = 0.0, np.zeros((H, W), bool)
    off = (np.arange(ss) + 0.5) / ss
    for a in off:
        for b in off:
            o, d = cam_rays(pos, look, fov, xx + a, yy + b)
            t = -o[1] / d[..., 1]
            P = o + t[..., None] * d
            L, sh = spot_floor(P, Lp, cone, fs, K, occl)
            if occl:
                L = np.where(np.isfinite(hit_sphere(np.broadcast_to(o, d.shape), d, SC, SR)), 0, L)
            acc = acc + np.where(t > 0, L, 0) / ss ** 2
            shany |= sh & (t > 0)
    return acc, shany

def tangent_circle(apex, n=1440):
    u = apex - SC
    D = np.linalg.norm(u); u = u / D
    cc, rr = SC + u * SR * SR / D, SR * np.sqrt(1 - SR * SR / D / D)
    a = norm(np.cross(u, [0.3, 0.1, 1.0])); b = np.cross(u, a)
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return cc + rr * (np.cos(th)[:, None] * a + np.sin(th)[:, None] * b)

def scene_a(ref):
    print('=' * 78 + '\nscene a_glass_sphere')
    nc, c, m, meta = load(ref, 'a_glass_sphere')
    yy, xx = np.mgrid[0:H, 0:W]
    spec = ndimage.binary_dilation(m > 0, iterations=3)
    sil_pts, sil_n = edge_points(m)
    lit = ndimage.maximum_filter(nc, 9)
    shf = np.clip(nc / np.maximum(lit, 1e-3), 0, 1)
    shsel = (~spec) & (lit > 0.2) & (yy > 260) & (yy < 400) & (xx > 140) & (xx < 370)
    sh_pts, sh_n = edge_points(shf, shsel, lo=0.08, hi=0.92)
    print(f'  edge points: silhouette {len(sil_pts)}, shadow {len(sh_pts)}')

    def edge_res(p):
        pos, look, fov, Lp = a_unpack(p)[:4]
        r1 = signed_curve_dist(sil_pts, sil_n, project(pos, look, fov, tangent_circle(pos)))
        X = tangent_circle(Lp)
        X = Lp + (X - Lp) * (Lp[1] / (Lp[1] - X[:, 1]))[:, None]     # onto the floor
        r2 = signed_curve_dist(sh_pts, sh_n, project(pos, look, fov, X))
        return r1, r2

    p0 = np.array([0, 3.0, 4.0, 0.5, 38, 0, 5.0, 0, 30, 20, 1.0])
    free_geo = [1, 2, 3, 4, 5, 6, 7]
    # camera x is a gauge freedom (scene symmetric about the y axis): held at 0
    p, _, _ = fit_report(A_NAMES, p0, free_geo, lambda q: np.concatenate(edge_res(q)) / 0.1, 'edges only')
    p[8:11] = [25, 18, 3.0]
    fsel = np.zeros((H, W), bool); fsel[::2, ::2] = True
    for it in range(2):
        _, sh = a_floor_img(p)
        sel = fsel & ~spec & ~ndimage.binary_dilation(sh, iterations=4)
        def res(q):
            L, _ = a_floor_img(q)
            r0 = (L - nc)[sel] / (0.005 * np.maximum(nc[sel], 0.05))
            r1, r2 = edge_res(q)
            return np.concatenate([r0, r1 / 0.1, r2 / 0.1])
        p, sd, cost = fit_report(A_NAMES, p, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10], res, f'edges + floor, pass {it}')
    pr = A_ROUND.copy()
    print('  round values:', dict(zip(A_NAMES, np.round(pr, 5))), ' cost', 0.5 * np.sum(res(pr) ** 2))

    def report(q, label):
        L, sh = a_floor_img(q)
        ok = ~spec & ~ndimage.binary_dilation(sh, iterations=4) & (L > 0.05 * L.max())
        rel = (nc - L)[ok] / L[ok]
        r1, r2 = edge_res(q)
        print(f'  {label}: lit-floor rel RMSE {np.sqrt(np.mean(rel ** 2)):.5f} (mean {rel.mean():+.5f}, '
              f'{ok.sum()} px, direct light only); silhouette rms {np.sqrt(np.mean(r1 ** 2)):.4f} px '
              f'(max {np.abs(r1).max():.3f}); shadow-edge rms {np.sqrt(np.mean(r2 ** 2)):.4f} px')
    report(p, 'fitted')
    report(pr, 'round ')
    if not QUICK:
        # the same residual with the first-order indirect light (floor -> glass -> floor, albedo 0.75)
        pos, look, fov, Lp, cone, fs, K = a_unpack(pr)
        L, sh = a_floor_img(pr)
        ok = ~spec & ~ndimage.binary_dilation(sh, iterations=4) & (L > 0.05 * L.max())
        ok[1::2, :] = False; ok[:, 1::2] = False
        iy, ix = np.nonzero(ok)
        o, d = cam_rays(pos, look, fov, ix + 0.5, iy + 0.5)
        P = o + (-o[1] / d[:, 1])[:, None] * d
        X = sphere_indirect(P, lambda Q: spot_floor(Q, Lp, cone, fs, K)[0], nd=256)
        rel = (nc[iy, ix] - L[iy, ix] - 0.75 * X) / L[iy, ix]
        print(f'  round + indirect (albedo 0.75): lit-floor rel RMSE {np.sqrt(np.mean(rel ** 2)):.5f} '
              f'(mean {rel.mean():+.5f}, {len(iy)} px); indirect is {np.mean(0.75 * X / L[iy, ix]):.5f} of direct on average')
    # silhouette as coverage: 8x8 supersampled mask vs specmask
    pos, look, fov = a_unpack(pr)[:3]
    cov = 0
    off = (np.arange(8) + 0.5) / 8
    for a in off:
        for b in off:
            o, d = cam_rays(pos, look, fov, xx + a, yy + b)
            cov = cov + np.isfinite(hit_sphere(np.broadcast_to(o, d.shape), d, SC, SR)) / 64
    print(f'  specmask: model coverage vs PNG: max |diff| {np.abs(cov - m).max():.3f}, '
          f'pixels differing > 0.1: {(np.abs(cov - m) > 0.1).sum()}, area model {cov.sum():.1f} ref {m.sum():.1f}')
    # nocaster sum: floor, no sphere, exact analytic
    Lnc, _ = a_floor_img(pr, occl=False, ss=4)
    print(f'  energy.sum_nocaster: model {3 * Lnc.sum():.2f}  ref {meta["energy"]["sum_nocaster"]:.2f}  '
          f'ratio {meta["energy"]["sum_nocaster"] / (3 * Lnc.sum()):.6f}')
    if QUICK:
        return
    # albedo from the indirect light in the sphere's shadow: L = albedo * X,
    # X = cosine-weighted mean over the hemisphere of (specular throughput * direct floor radiance)
    K = pr[10]
    o, d = cam_rays(pos, look, fov, xx + .5, yy + .5)
    t = -o[1] / d[..., 1]
    P = o + t[..., None] * d
    dr, _ = spot_floor(P, pr[5:8], pr[8], pr[9], K)
    shadow = ndimage.binary_erosion(dr <= 0, iterations=3) & ~spec & (t > 0) & (np.hypot(P[..., 0], P[..., 2]) < 1.0)
    shadow[1::2, :] = False; shadow[:, 1::2] = False
    iy, ix = np.nonzero(shadow)
    X = sphere_indirect(P[iy, ix], lambda Q: spot_floor(Q, pr[5:8], pr[8], pr[9], K)[0], nd=1024)
    y = nc[iy, ix]
    alb = y.sum() / X.sum()
    blk = (iy // 16) * 64 + (ix // 16); ub = np.unique(blk); rng = np.random.default_rng(0); bs = []
    for _ in range(300):
        s = np.concatenate([np.nonzero(blk == b)[0] for b in rng.choice(ub, len(ub))])
        bs.append(y[s].sum() / X[s].sum())
    print(f'  albedo from shadow indirect (floor->glass->floor, {len(iy)} px): {alb:.4f} +- {np.std(bs):.4f}'
          f'  -> intensity = {np.pi * K:.3f}/albedo = {np.pi * K / alb:.2f} W/sr (0.75 -> 40)')
    # caustic energy by photon tracing (first-order: light -> glass^k -> floor -> camera)
    tot, img = sphere_caustic(0.75, 40.0, pos, look, fov)
    r = np.hypot(xx - 256, yy - 316)
    print(f'  energy.sum_caustic: photon-traced first-order {tot:.1f}  ref {meta["energy"]["sum_caustic"]:.1f} '
          f'(ratio {meta["energy"]["sum_caustic"] / tot:.4f}; excess = multiple floor-glass bounces)')
    print(f'  focal peak: model {img.max():.2f}  ref {c.max():.2f};  sum within 20 px of the focus: '
          f'model {img[r < 20].sum():.1f} ref {c[r < 20].sum():.1f}')

def sphere_indirect(P, direct, nd=1024, seed=1, maxd=10):
    rng = np.random.default_rng(seed)
    D = cos_dirs(nd, rng)
    out = np.zeros(len(P))
    for i0 in range(0, len(P), 128):
        Pc = P[i0:i0 + 128]; n = len(Pc)
        o = np.repeat(Pc[:, None], len(D), 1).reshape(-1, 3); d = np.tile(D, (n, 1))
        w = np.ones(len(o)); idx = np.repeat(np.arange(n), len(D)); inside = np.zeros(len(o), bool)
        acc = np.zeros(n)
        for depth in range(maxd):
            t = hit_sphere(o, d, SC, SR); h = np.isfinite(t)
            esc = ~h & (depth > 0) & (d[:, 1] < 0)
            if esc.any():
                Q = o[esc] + (-o[esc, 1] / d[esc, 1])[:, None] * d[esc]
                np.add.at(acc, idx[esc], w[esc] * direct(Q))
            o, d, w, idx, inside, t = o[h], d[h], w[h], idx[h], inside[h], t[h]
            if len(o) == 0:
                break
            o, d, w, inside, extra = _dielectric_split(o, d, w, inside, t)
            idx = np.concatenate([idx, idx])[extra]
        out[i0:i0 + n] = acc / len(D)
    return out

def _dielectric_split(o, d, w, inside, t, wmin=1e-9):
    X = o + t[:, None] * d
    nrm = (X - SC) / SR
    ci = np.abs(np.sum(d * nrm, -1))
    eta = np.where(inside, 1 / IOR, IOR)
    nn = np.where(inside[:, None], -nrm, nrm)
    F, ct = fresnel(ci, eta)
    r = d + 2 * ci[:, None] * nn
    tr = d / eta[:, None] + (ci / eta - ct)[:, None] * nn
    o2 = np.concatenate([X, X]); d2 = norm(np.concatenate([r, tr]))
    w2 = np.concatenate([w * F, w * (1 - F)]); in2 = np.concatenate([inside, ~inside])
    keep = w2 > wmin * w2.max()
    return o2[keep], d2[keep], w2[keep], in2[keep], keep

def sphere_caustic(alb, I, pos, look, fov, N=2_000_000):
    Lp = np.array([0, 5.0, 0])
    rng = np.random.default_rng(0)
    ca = np.sqrt(1 - (SR / (Lp[1] - SC[1])) ** 2)            # cap of directions hitting the ball
    cz = 1 - rng.random(N) * (1 - ca); ph = 2 * np.pi * rng.random(N); sz = np.sqrt(1 - cz ** 2)
    d = np.stack([sz * np.cos(ph), -cz, sz * np.sin(ph)], -1)
    o = np.broadcast_to(Lp, d.shape).copy()
    w = np.full(N, I * 2 * np.pi * (1 - ca) / N)               # inside the 15 deg core: full intensity
    inside = np.zeros(N, bool)
    tot, img = 0.0, np.zeros((H, W))
    for depth in range(12):
        t = hit_sphere(o, d, SC, SR); h = np.isfinite(t)
        esc = ~h & (d[:, 1] < 0) & (depth > 0)
        if esc.any():
            Q = o[esc] + (-o[esc, 1] / d[esc, 1])[:, None] * d[esc]; ww = w[esc]
            vd = norm(Q - pos)
            vis = (hit_sphere(np.broadcast_to(pos, Q.shape), vd, SC, SR) > np.linalg.norm(Q - pos, axis=-1)) \
                & in_view(Q, pos, look, fov)
            contrib = alb / np.pi * ww[vis] / pix_area(Q[vis], pos, look, fov)
            pp = project(pos, look, fov, Q[vis]).astype(int)
            np.add.at(img, (pp[:, 1], pp[:, 0]), contrib)
            tot += contrib.sum()
        o, d, w, inside, t = o[h], d[h], w[h], inside[h], t[h]
        if len(o) == 0:
            break
        o, d, w, inside, _ = _dielectric_split(o, d, w, inside, t)
    return 3 * tot, img

# ============================================================================= scene B
RR, HH = 0.6, 0.5
B_NAMES = ['cam_y', 'cam_z', 'look_y', 'fov', 'light_azim', 'light_elev', 'floor_x0', 'floor_width',
           'floor_far_z', 'floor_rot']
B_ROUND = np.array([2.9, 1.3, 0.0, 40.0, 0.0, 25.0, 0.0, 2.4, -1.2, 0.0])
NEAR_Z = 1.2    # near floor edge: outside the view (bottom row sees z = 1.09), not observable

def b_unpack(p):
    return dict(pos=np.array([0, p[0], p[1]]), look=np.array([0, p[2], 0.0]), fov=p[3], az=p[4], el=p[5],
                x0=p[6], wid=p[7], zfar=p[8], rot=p[9])

def light_dir(q):
    a, e = np.radians(q['az']), np.radians(q['el'])
    return np.array([np.cos(e) * np.cos(a), -np.sin(e), np.cos(e) * np.sin(a)])

def rect_corners(q):
    a = np.radians(q['rot'])
    u = np.array([np.cos(a), 0, -np.sin(a)]); v = np.array([np.sin(a), 0, np.cos(a)])
    xs = [q['x0'] - q['wid'] / 2, q['x0'] + q['wid'] / 2]; zs = [q['zfar'], NEAR_Z]
    return [x * u + z * v for x, z in [(xs[0], zs[0]), (xs[1], zs[0]), (xs[1], zs[1]), (xs[0], zs[1])]]

def b_curves(q):
    o = q['pos']
    sil = [circle(np.zeros(3), RR), circle(np.array([0, HH, 0]), RR)]
    dd = np.array([o[0], 0, o[2]]); D = np.linalg.norm(dd); dd /= D
    al = np.arccos(RR / D)
    for s in (-1, 1):        # silhouette generators of the tube
        ca, sa = np.cos(s * al), np.sin(s * al)
        P = RR * np.array([ca * dd[0] - sa * dd[2], 0, sa * dd[0] + ca * dd[2]])
        sil.append(seg(P, P + [0, HH, 0], 200))
    L = light_dir(q)
    sh = -HH / L[1] * np.array([L[0], 0, L[2]])
    flo = [circle(sh, RR), circle(-sh, RR)]     # rim shadow; lit lens inside the ring
    nrm = norm(np.array([-L[2], 0, L[0]]))
    for s in (-1, 1):
        flo.append(seg(s * RR * nrm, s * RR * nrm + sh, 400))
    C = rect_corners(q)
    flo += [seg(C[i], C[(i + 1) % 4]) for i in range(4)]
    pr = lambda cs: np.concatenate([project(q['pos'], q['look'], q['fov'], c) for c in cs])
    return pr(sil), pr(flo)

def ring_direct(Q, Ld, L, half=1.2, near=None):
    near = half if near is None else near
    inr = (np.abs(Q[..., 0]) <= half) & (Q[..., 2] >= -half) & (Q[..., 2] <= near)
    vis = ~np.isfinite(hit_cyl(Q, np.broadcast_to(-L, Q.shape), RR, HH))
    return np.where(inr & vis, Ld, 0.0)

def scene_b(ref):
    print('=' * 78 + '\nscene b_mirror_ring')
    nc, c, m, meta = load(ref, 'b_mirror_ring')
    yy, xx = np.mgrid[0:H, 0:W]
    spec = ndimage.binary_dilation(m > 0, iterations=3)
    Lfloor = np.median(nc[(nc > 0.3) & ~spec])
    sil_pts, sil_n = edge_points(m)
    fe_pts, fe_n = edge_points(np.clip(nc / Lfloor, 0, 1), ~spec, lo=0.05, hi=0.97)
    print(f'  edge points: silhouette {len(sil_pts)}, floor/shadow {len(fe_pts)}')

    def edge_res(p):
        s, f = b_curves(b_unpack(p))
        return signed_curve_dist(sil_pts, sil_n, s), signed_curve_dist(fe_pts, fe_n, f)
    # gauge: ring base at the origin, camera in the x=0 plane (the tube is rotationally
    # symmetric, so camera azimuth, light azimuth and floor rotation are tied together)
    p0 = np.array([2.5, 2.0, 0.0, 38.0, 5.0, 30.0, 0.0, 3.0, -1.5, 0.0])
    p, sd, _ = fit_report(B_NAMES, p0, list(range(10)), lambda q: np.concatenate(edge_res(q)) / 0.1, 'edges')
    for lab, q in (('fitted', p), ('round ', B_ROUND)):
        r1, r2 = edge_res(q)
        print(f'  {lab}: silhouette rms {np.sqrt(np.mean(r1 ** 2)):.4f} px (max {np.abs(r1).max():.3f}); '
              f'floor+shadow edges rms {np.sqrt(np.mean(r2 ** 2)):.4f} px (max {np.abs(r2).max():.3f}); '
              f'cost {0.5 * np.sum((np.r_[r1, r2] / 0.1) ** 2):.1f}')
    e = np.radians(B_ROUND[5])
    print(f'  lit floor radiance (median) {Lfloor:.6f} -> albedo*irradiance = {Lfloor * np.pi / np.sin(e):.5f} W/m^2')
    # full nocaustic model (floor direct + floor seen in the mirror), 4x4 supersampled
    q = b_unpack(B_ROUND)
    Ld = 3.0 / np.pi * np.sin(e); L = light_dir(q)
    acc, direct_only = np.zeros((H, W)), np.zeros((H, W))
    off = (np.arange(4) + 0.5) / 4
    for a in off:
        for b in off:
            o, d = cam_rays(q['pos'], q['look'], q['fov'], xx + a, yy + b)
            o = np.broadcast_to(o, d.shape).copy(); w = np.ones((H, W)); alive = np.ones((H, W), bool)
            for k in range(8):
                tc = hit_cyl(o, d, RR, HH)
                tf = np.where(d[..., 1] < 0, -o[..., 1] / np.minimum(d[..., 1], -1e-12), np.inf)
                hc = np.isfinite(tc) & (tc < tf) & alive
                land = alive & ~hc & np.isfinite(tf)
                Q = o + np.where(np.isfinite(tf), tf, 0)[..., None] * d
                v = np.where(land, w * ring_direct(Q, Ld, L), 0)
                acc += v / 16
                if k == 0:
                    direct_only += v / 16
                alive = hc
                X = o + np.where(hc, tc, 0)[..., None] * d
                n = np.stack([X[..., 0], 0 * X[..., 0], X[..., 2]], -1) / RR
                d = np.where(hc[..., None], d - 2 * np.sum(d * n, -1, keepdims=True) * n, d)
                o = np.where(hc[..., None], X, o); w = np.where(hc, w * 0.95, w)
    shadow_edge = ndimage.binary_dilation(direct_only > 0, iterations=2) & ndimage.binary_dilation(direct_only <= 0, iterations=2)
    ok = ~spec & ~shadow_edge & (direct_only > 0.5 * Ld)
    rel = (nc - acc)[ok] / acc[ok]
    print(f'  lit-floor rel RMSE {np.sqrt(np.mean(rel ** 2)):.5f} (mean {rel.mean():+.6f}, {ok.sum()} px)')
    full = (m > 0.999) & ndimage.binary_erosion(m > 0.999, iterations=2) & (acc > 0.05)
    print(f'  mirror pixels (floor seen in the mirror): ref/model {nc[full].sum() / acc[full].sum():.5f} '
          f'-> reflectance {0.95 * nc[full].sum() / acc[full].sum():.4f}')
    print(f'  energy.sum_nocaustic: model {3 * acc.sum():.1f} ref {meta["energy"]["sum_nocaustic"]:.1f}')
    # nocaster: the floor alone
    cnt = 0
    for a in off:
        for b in off:
            o, d = cam_rays(q['pos'], q['look'], q['fov'], xx + a, yy + b)
            t = -o[1] / d[..., 1]; P = o + t[..., None] * d
            cnt = cnt + ((t > 0) & (np.abs(P[..., 0]) <= 1.2) & (np.abs(P[..., 2]) <= 1.2)) / 16
    print(f'  energy.sum_nocaster: model {3 * cnt.sum() * Ld:.1f} ref {meta["energy"]["sum_nocaster"]:.1f} '
          f'ratio {meta["energy"]["sum_nocaster"] / (3 * cnt.sum() * Ld):.5f}')
    if QUICK:
        return
    # caustic: light -> mirror^k -> floor -> camera, photon traced
    alb, E0 = 0.75, 4.0
    u1 = np.array([0, 0, 1.0]); u2 = norm(np.cross(L, u1))
    N = 4_000_000; rng = np.random.default_rng(0); A = 9.0
    s, t = (rng.random(N) - .5) * 3, (rng.random(N) - .5) * 3
    o = np.array([0, 0.25, 0]) - 4 * L + s[:, None] * u1 + t[:, None] * u2
    d = np.broadcast_to(L, o.shape).copy(); w = np.full(N, E0 * A / N)
    tot = 0.0
    for k in range(10):
        tc = hit_cyl(o, d, RR, HH)
        tf = np.where(d[:, 1] < 0, -o[:, 1] / np.minimum(d[:, 1], -1e-12), np.inf)
        hc = np.isfinite(tc) & (tc < tf)
        if k > 0:
            land = ~hc & np.isfinite(tf)
            Q = o[land] + tf[land, None] * d[land]; ww = w[land]
            inr = (np.abs(Q[:, 0]) <= 1.2) & (np.abs(Q[:, 2]) <= 1.2); Q, ww = Q[inr], ww[inr]
            vd = norm(Q - q['pos'])
            vis = (hit_cyl(np.broadcast_to(q['pos'], Q.shape).copy(), vd, RR, HH) > np.linalg.norm(Q - q['pos'], axis=-1)) \
                & in_view(Q, q['pos'], q['look'], q['fov'])
            tot += (alb / np.pi * ww[vis] / pix_area(Q[vis], q['pos'], q['look'], q['fov'])).sum()
        o, d, w, tc = o[hc], d[hc], w[hc], tc[hc]
        if len(o) == 0:
            break
        X = o + tc[:, None] * d
        n = np.stack([X[:, 0], 0 * X[:, 0], X[:, 2]], -1) / RR
        d = d - 2 * np.sum(d * n, -1, keepdims=True) * n; o = X; w = w * 0.95
    print(f'  energy.sum_caustic: photon-traced {3 * tot:.1f}  ref {meta["energy"]["sum_caustic"]:.1f} '
          f'ratio {meta["energy"]["sum_caustic"] / (3 * tot):.4f}')

if __name__ == '__main__':
    ref = next((a for a in sys.argv[1:] if not a.startswith('--')), '/work/shared/references')
    np.set_printoptions(suppress=True)
    scene_a(ref)
    scene_b(ref)
