//! Conservative ray-box tests: one box, a wide node's boxes lane by lane, and a 4-wide
//! node's in `Vec4` lanes.

use super::wide4::Ray4;
use super::{Node, NodeW};
use glam::{Vec3, Vec4};

/// The ray's (near, far) distances to one slab `[lo, hi]` of a box along one axis. A ray
/// parallel to the slab (`inv` infinite) that starts exactly on one of its planes gets
/// `0 · ∞ = NaN` there: it lies in the closed slab, which then does not constrain it
/// (-∞, +∞). (Before, a compare-and-select on the NaN could drop such a box: a ray grazing a
/// mesh along a box face, e.g. from a vertex's coordinate plane, could miss the mesh.)
#[inline(always)]
fn slab(lo: f32, hi: f32, o: f32, inv: f32) -> (f32, f32) {
    let t1 = (lo - o) * inv;
    let t2 = (hi - o) * inv;
    if t1.is_nan() || t2.is_nan() {
        (f32::NEG_INFINITY, f32::INFINITY)
    } else if t1 < t2 {
        (t1, t2)
    } else {
        (t2, t1)
    }
}

/// The box test of three slabs: (entry distance, whether the ray enters before `tmax`). The
/// interval is widened by 2γ₃ either way (Ize 2013) so the test is conservative for the
/// watertight triangle test: a triangle on a box face hit at t just below `tmax` is still
/// tested though the rounded entry distance may exceed t by an ulp.
#[inline(always)]
fn enter(near: [f32; 3], far: [f32; 3], tmax: f32) -> (f32, bool) {
    let m = if near[1] > near[2] { near[1] } else { near[2] };
    let t = if near[0] > m { near[0] } else { m } * 0.999_999_6;
    let tn = if t > 0.0 { t } else { 0.0 };
    let m = if far[1] < far[2] { far[1] } else { far[2] };
    let tf = if far[0] < m { far[0] } else { m } * 1.000_000_4;
    (tn, tn <= tf && tn < tmax)
}

/// Entry distance of the ray into the node's box, if it enters before `tmax`.
#[inline]
pub(super) fn box_hit(n: &Node, o: Vec3, inv: Vec3, tmax: f32) -> Option<f32> {
    let (nx, fx) = slab(n.lo.x, n.hi.x, o.x, inv.x);
    let (ny, fy) = slab(n.lo.y, n.hi.y, o.y, inv.y);
    let (nz, fz) = slab(n.lo.z, n.hi.z, o.z, inv.z);
    let (tn, hit) = enter([nx, ny, nz], [fx, fy, fz], tmax);
    hit.then_some(tn)
}

/// [`box_hit`] for the children of a wide node at once (the same arithmetic lane by lane,
/// written as plain array code so that it compiles to vector instructions); bit `c` of the mask
/// is set when child `c` is hit. Empty slots (box at infinity) never hit.
#[inline(always)]
pub(super) fn box_hit4<const W: usize>(n: &NodeW<W>, o: [f32; 3], inv: [f32; 3], tmax: f32) -> ([f32; W], u32) {
    let mut near = [[0f32; W]; 3];
    let mut far = [[0f32; W]; 3];
    for a in 0..3 {
        for c in 0..W {
            (near[a][c], far[a][c]) = slab(n.b[0][a][c], n.b[1][a][c], o[a], inv[a]);
        }
    }
    let mut tn = [0f32; W];
    let mut mask = 0;
    for c in 0..W {
        let hit;
        (tn[c], hit) = enter([near[0][c], near[1][c], near[2][c]], [far[0][c], far[1][c], far[2][c]], tmax);
        mask |= (hit as u32) << c;
    }
    (tn, mask)
}

/// Lane by lane `if x > m { x } else { m }`: a NaN `x` keeps `m`. On x86 that is exactly
/// SSE's `maxps(x, m)` (the second operand when either is NaN), which `glam`'s `max` is there
/// (or, with `glam`'s `scalar-math`, `f32::max`, which also returns the operand that is not
/// NaN; `m` never is). Elsewhere (NEON's max propagates NaN) the compare and select.
#[inline(always)]
fn max_keep(x: Vec4, m: Vec4) -> Vec4 {
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse"))]
    return x.max(m);
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse")))]
    return Vec4::select(x.cmpgt(m), x, m);
}

/// Lane by lane `if x < m { x } else { m }` (SSE's `minps(x, m)` on x86), see [`max_keep`].
#[inline(always)]
fn min_keep(x: Vec4, m: Vec4) -> Vec4 {
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse"))]
    return x.min(m);
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "sse")))]
    return Vec4::select(x.cmplt(m), x, m);
}

/// [`box_hit4`] for a 4-wide node in `Vec4` lanes, the same values without its min/max
/// selects: by the sign of the direction, the near plane's distance `(b - o) · inv` is the
/// smaller of the two (a product with a positive, resp. negative, factor is monotone in `b`,
/// rounding included). A NaN distance (a ray parallel to a slab, starting on its plane) leaves
/// the running maximum (resp. minimum) as it is, which is [`slab`]'s "this axis does not
/// constrain". Folding 0 into the entry maximum before the 2γ₃ widening gives the same entry
/// distance as [`enter`]'s clamp after it (the widening is monotone and keeps 0 at 0).
#[inline(always)]
pub(super) fn box_hit_w4(n: &NodeW<4>, r: &Ray4, tmax: f32) -> (Vec4, u32) {
    let mut tn = Vec4::ZERO;
    let mut tf = Vec4::INFINITY;
    for a in 0..3 {
        let near = r.near[a] & 1;
        let t_near = (Vec4::from_array(n.b[near][a]) - r.o[a]) * r.inv[a];
        let t_far = (Vec4::from_array(n.b[near ^ 1][a]) - r.o[a]) * r.inv[a];
        // `select(x > m, x, m)`: a NaN `x` keeps `m`.
        tn = max_keep(t_near, tn);
        tf = min_keep(t_far, tf);
    }
    let tn = tn * Vec4::splat(0.999_999_6);
    let tf = tf * Vec4::splat(1.000_000_4);
    (tn, (tn.cmple(tf) & tn.cmplt(Vec4::splat(tmax))).bitmask())
}
