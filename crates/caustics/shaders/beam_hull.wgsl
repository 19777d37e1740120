// Stage: beam_hull. Each ordered beam's hulls on the image, for beam_raster (the volume caustic)
// or beam_surface_raster (the surface caustic) to draw (Liktor & Dachsbacher 2011, section 4.3:
// a bounding volume per beam, rasterized so that only the pixels a beam can reach run its
// integral). One thread per entry of the ordered list (beam_order), an indirect dispatch sized
// by beam_order; run before each of the two draws.
//
// The beam's points between two heights y0 and y1 over its base lie in the convex hull of its
// sections there, v_i + y s_i (the sections are linear in the height): six corners. For the
// volume caustic (`mode.x` 0) the heights from the base to the farthest end, split at the
// beam's foci between where that hull would cover the whole image (up to BEAM_HULL_PARTS
// parts, each its own polygon and instance; the fragment integrates only its part's heights,
// `HullVertex::heights`): across a focus the convex hull of the end sections holds the whole
// waist region, and a camera near a focus sat inside the hulls of every beam through it (the
// test's camera in the cone: 0.14 of the fragments lit with one hull per beam, 0.43 split);
// for the surface
// caustic (`mode.x` 1) those of the points beam_irradiance (shared/beam_receive.wgsl) lights,
// the ends' heights widened by its tolerance (half the end triangle's longest side): the
// beam's end, not its length (on the tests' floors a half to two thirds of the fragments of
// the whole beam's hull). The projection of a convex hull in front of the camera is the convex
// hull of the projected corners, so the tightest convex bound's silhouette is a 2-D hull of
// six points, and a triangle fan over it covers each pixel once (no faces to choose, no
// watertight seams, the camera's side of the hull does not matter). The paper's six-triangle
// hull and its prism fallback bound the same convex hull from outside, looser. A pixel's rays
// and footprint reach its whole square, so the polygon is the hull grown by the pixel's square
// (the hull of the points corner +- (m, m), m = BEAM_HULL_MARGIN half pixels: the rasterizer's
// snapping of vertices to its sub-pixel grid stays inside the margin).
//
// Only the part of the hull in front of the camera matters (the rays start at the camera). A
// hull that reaches behind it (the camera in the fog, beams passing it) is cut at the plane
// w = eps just in front of the camera (w the depth along the view axis, eps = HULL_NEAR times
// the farthest corner's depth): its part beyond is the convex hull of the corners beyond and
// of the points where the segments between corners cross the plane (the hull's edges among
// them), projected (up to some 1 / HULL_NEAR image sizes out; the rasterizer clips the polygon
// to the image). The part between the camera and the plane is seen only if it meets the
// view's frustum there: then the whole image (a beam that holds the camera lights every pixel;
// so does the convex hull of a beam through a focus with the camera near that focus, though
// the beam lights only some of the pixels). Before this cut (2026-12-05) every hull reaching
// behind the camera got the whole image: on volume_caustic_fog 79 % of the hulls' fragments,
// none of them lit; the cut draws the same bits. (A cut at 1e-4 of the depth put the points
// 10^4 image sizes out, and rounding lost some light at the polygons' edges, also with the
// polygon in homogeneous clip coordinates and 3x3 determinants as the orientation test; it
// saved no fragments on the tests' views.)
//
// Gift wrapping over the points; a polygon of more than BEAM_HULL_MAX vertices (rounding on
// near-collinear points) becomes their bounding rectangle.

#import beams

@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(2) var<storage, read> order: array<u32>;
@group(0) @binding(3) var<storage, read> stats: array<u32>;
@group(0) @binding(4) var<storage, read_write> hulls: array<BeamHull>;
// x: 0 the hulls of the whole beams (beam_raster), 1 of their ends (beam_surface_raster).
@group(0) @binding(5) var<storage, read> mode: vec4u;

// Half the side of the square each corner is grown by (pixels): half a pixel, an eighth for the
// rasterizer's vertex snapping (Vulkan guarantees at least 4 sub-pixel bits) and 1/128 for the
// rounding of the corners (add_point).
const BEAM_HULL_MARGIN: f32 = 0.6328125;
// The cut in front of the camera, as a fraction of the hull's farthest corner's depth.
const HULL_NEAR: f32 = 0.01;

// The points the polygon wraps (pixels), each grown by the margin (4 each): the corners beyond
// the plane w = eps and the points where segments between corners cross it (at most 9).
var<private> pts: array<vec2f, 60>;

// Point c (clip-space x, y, w; w > 0) projected to pixels, as the four corners of its square
// of half side m. The projection is rounded to 1/64 pixel: corners that nearly coincide (a
// section at a focus, where beam_hull splits a beam) become the same point, which the gift
// wrapping handles exactly, where points a millionth of a pixel apart gave its orientation tests
// a random direction and wrong polygons (the margin carries the rounding).
fn add_point(n: ptr<function, u32>, c: vec3f, m: f32) {
    let exact = vec2f((c.x / c.z + 1.0) * 0.5 * f32(bp.width), (1.0 - c.y / c.z) * 0.5 * f32(bp.height));
    let p = round(exact * 64.0) / 64.0;
    for (var q = 0u; q < 4u; q++) {
        pts[*n] = p + vec2f(select(-m, m, (q & 1u) != 0u), select(-m, m, (q & 2u) != 0u));
        *n += 1u;
    }
}

// A vertex of the hull's part nearer than the plane: is it outside each of the frustum's side
// planes (x > w, x < -w, y > w, y < -w, a little beyond the image's edges)? (Every vertex
// outside one of them: the part is outside the frustum.)
fn near_vertex(c: vec3f, out: ptr<function, vec4<bool>>) {
    let w = 1.01 * c.z;
    let o = vec4f(c.x - w, -w - c.x, c.y - w, -w - c.y) > vec4f(0.0);
    *out = *out & o;
}

fn set_vertex(h: ptr<function, BeamHull>, i: u32, p: vec2f) {
    if ((i & 1u) == 0u) {
        (*h).p[i / 2u] = vec4f(p, (*h).p[i / 2u].zw);
    } else {
        (*h).p[i / 2u] = vec4f((*h).p[i / 2u].xy, p);
    }
}

// The rectangle from lo to hi.
fn rectangle(h: ptr<function, BeamHull>, lo: vec2f, hi: vec2f) {
    (*h).info.x = 4u;
    (*h).p[0] = vec4f(lo, hi.x, lo.y);
    (*h).p[1] = vec4f(hi, lo.x, hi.y);
}

fn whole_image(h: ptr<function, BeamHull>) {
    rectangle(h, vec2f(-1.0), vec2f(f32(bp.width) + 1.0, f32(bp.height) + 1.0));
}

fn cross2(a: vec2f, b: vec2f) -> f32 {
    return a.x * b.y - a.y * b.x;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let count = min(stats[1u + BS_ORDERED], bp.capacity);
    let k = gid.x;
    if (k >= count) { return; }
    let bi = order[k];
    let b = beams[bi];
    let v = array<vec3f, 3>(b.v0.xyz, b.v1.xyz, b.v2.xyz);
    let d = array<vec3f, 3>(b.d0.xyz, b.d1.xyz, b.d2.xyz);
    let len = vec3f(b.d0.w, b.d1.w, b.d2.w);
    let nrm = beam_normal(v, d);
    let cs = vec3f(dot(nrm, d[0]), dot(nrm, d[1]), dot(nrm, d[2]));
    let ys = len * cs;
    let ym = max(max(ys.x, ys.y), ys.z);
    let e0 = v[0] + d[0] * len.x;
    let e1 = v[1] + d[1] * len.y;
    let e2 = v[2] + d[2] * len.z;
    // The heights the parts split: from y0 to y1, at the foci between.
    var cut = array<f32, 4>(0.0, ym * (1.0 + 1e-4), 0.0, 0.0);
    var n_parts = 1u;
    if (mode.x == 1u) {
        // (beam_irradiance's range; one part)
        let tol = 0.5 * max(max(length(e1 - e0), length(e2 - e1)), length(e0 - e2)) + 1e-4 * ym;
        cut[0] = max(min(min(ys.x, ys.y), ys.z) - tol, 0.0);
        cut[1] = ym + tol;
    }
    var first: BeamHull;
    first.info = vec4u(0u, bi, bitcast<u32>(cut[0]), bitcast<u32>(cut[1]));
    // Split at the foci only where the whole beam's hull would cover the whole image (its part
    // near the camera meets the view): elsewhere a split costs more than it saves (the
    // fragments near a focus, where the footprint integral runs, twice; +17 % beam_raster time
    // on volume_caustic_fog).
    if (part_polygon(&first, v, d, cs, cut[0], cut[1]) && mode.x == 0u) {
        n_parts = focus_cuts(v, d, cs, nrm, &cut);
    }
    for (var p = 0u; p < BEAM_HULL_PARTS; p++) {
        var h: BeamHull;
        h.info = vec4u(0u, bi, 0u, 0u);
        if (n_parts == 1u && p == 0u) {
            h = first;
        } else if (p < n_parts) {
            h.info.z = bitcast<u32>(cut[p]);
            h.info.w = bitcast<u32>(cut[p + 1u]);
            _ = part_polygon(&h, v, d, cs, cut[p], cut[p + 1u]);
        }
        hulls[k * BEAM_HULL_PARTS + p] = h;
    }
}

// The foci strictly between cut[0] and cut[1] (beam_foci, away from the ends by a thousandth of
// the range), inserted in order; the number of parts. Between foci the beam is a truncated
// cone or pyramid whose end sections' convex hull is tight; across one, the convex hull of the
// two end sections holds the whole waist region (a camera near a focus sits inside the hulls
// of every beam through it).
fn focus_cuts(v: array<vec3f, 3>, d: array<vec3f, 3>, cs: vec3f, nrm: vec3f, cut: ptr<function, array<f32, 4>>) -> u32 {
    // (as beam_space in shared/beams.wgsl: the same bits)
    let s = array<vec3f, 3>(d[0] / cs.x, d[1] / cs.y, d[2] / cs.z);
    let lo = (*cut)[0];
    let hi = (*cut)[1];
    let r = beam_foci(section_area(v, s, nrm), hi);
    let margin = 1e-3 * (hi - lo);
    var n = 1u;
    for (var i = 0u; i < 2u; i++) {
        if (r[i] > lo + margin && r[i] < hi - margin && r[i] > (*cut)[n - 1u] + margin) {
            (*cut)[n + 1u] = (*cut)[n];
            (*cut)[n] = r[i];
            n++;
        }
    }
    return n;
}

// The hull polygon of the beam's points at heights y0 to y1 into h (none where the camera
// cannot see them); true where it is the whole image (the part near the camera meets the
// view, or the corners are not finite).
fn part_polygon(h: ptr<function, BeamHull>, v: array<vec3f, 3>, d: array<vec3f, 3>, cs: vec3f, y0: f32, y1: f32) -> bool {
    // The corners in clip space (x, y, w).
    var cc: array<vec3f, 6>;
    var zmax = -1e30;
    var fin = true;
    for (var i = 0u; i < 6u; i++) {
        let j = i % 3u;
        let x = v[j] + d[j] * (select(y0, y1, i >= 3u) / cs[j]);
        let c = bp.world_to_clip * vec4f(x, 1.0);
        cc[i] = c.xyw;
        zmax = max(zmax, c.w);
        fin = fin && all(abs(c.xyw) < vec3f(1e30));
    }
    // (NaN fails every test: the whole image)
    if (!fin) {
        whole_image(h);
        return true;
    }
    // Wholly behind the camera: no ray reaches it.
    if (zmax <= 0.0) {
        return false;
    }
    let eps = HULL_NEAR * zmax;
    let m = BEAM_HULL_MARGIN;
    var n_pts = 0u;
    var out_of_view = vec4<bool>(true);
    var near = false;
    for (var i = 0u; i < 6u; i++) {
        let c = cc[i];
        if (c.z >= eps) {
            add_point(&n_pts, c, m);
            continue;
        }
        near = true;
        near_vertex(c, &out_of_view);
        for (var j = 0u; j < 6u; j++) {
            let e = cc[j];
            if (e.z < eps) { continue; }
            let x = vec3f(mix(c.xy, e.xy, (eps - c.z) / (e.z - c.z)), eps);
            near_vertex(x, &out_of_view);
            add_point(&n_pts, x, m);
        }
    }
    if (near && !any(out_of_view)) {
        whole_image(h);
        return true;
    }
    var lo = vec2f(1e30);
    var hi = vec2f(-1e30);
    var start = 0u;
    for (var i = 0u; i < n_pts; i++) {
        let p = pts[i];
        lo = min(lo, p);
        hi = max(hi, p);
        let s = pts[start];
        if (p.x < s.x || (p.x == s.x && p.y < s.y)) { start = i; }
    }
    // Gift wrapping: from the leftmost point, each next vertex the one with every point on its
    // left (the farthest of collinear ones).
    var cur = start;
    var n = 0u;
    var closed = false;
    for (var step = 0u; step < BEAM_HULL_MAX; step++) {
        set_vertex(h, n, pts[cur]);
        n++;
        var nxt = (cur + 1u) % n_pts;
        for (var j = 0u; j < n_pts; j++) {
            if (j == cur) { continue; }
            let a = pts[nxt] - pts[cur];
            let c = pts[j] - pts[cur];
            let x = cross2(a, c);
            if (x < 0.0 || (x == 0.0 && dot(c, c) > dot(a, a))) { nxt = j; }
        }
        cur = nxt;
        if (all(pts[cur] == pts[start])) {
            closed = true;
            break;
        }
    }
    if (closed && n >= 3u) {
        (*h).info.x = n;
    } else {
        rectangle(h, lo, hi);
    }
    return false;
}
