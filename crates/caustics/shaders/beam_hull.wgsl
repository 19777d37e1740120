// Stage: beam_hull. Each ordered beam's hull on the image, for beam_raster to draw (Liktor &
// Dachsbacher 2011, section 4.3: a bounding volume per beam, rasterized so that only the pixels
// a beam can reach run its scattering integral). One thread per entry of the ordered list
// (beam_order), an indirect dispatch sized by beam_order.
//
// The beam's points lie in the convex hull of its six corners: its base v_i and its section
// at a height yt, v_i + yt s_i (the sections are linear in the height), yt the farthest end
// height plus the tolerance the surface caustic's point test allows past the ends
// (beam_irradiance in shared/beam_receive.wgsl: half the end triangle's longest side). The projection of a convex hull is the convex hull
// of the projected corners, so the tightest convex bound's silhouette is a 2-D hull of six
// points, and a triangle fan over it covers each pixel once (no faces to choose, no watertight
// seams, the camera's side of the hull does not matter). The paper's six-triangle hull and its
// prism fallback bound the same convex hull from outside, looser. A pixel's rays and footprint
// reach its whole square, so the polygon is the hull grown by the pixel's square (the hull of
// the 24 points corner +- (m, m), m = BEAM_HULL_MARGIN half pixels: the rasterizer's snapping
// of vertices to its sub-pixel grid stays inside the margin). Gift wrapping over the 24 points;
// a polygon of more than BEAM_HULL_MAX vertices (rounding on near-collinear points) becomes
// their bounding rectangle. A beam that reaches behind the camera (or so near it that the
// projection's scale varies a thousandfold across the beam) gets the whole image.

#import beams

@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(2) var<storage, read> order: array<u32>;
@group(0) @binding(3) var<storage, read> stats: array<u32>;
@group(0) @binding(4) var<storage, read_write> hulls: array<BeamHull>;

// Half the side of the square each corner is grown by (pixels): half a pixel, and an eighth for
// the rasterizer's vertex snapping (Vulkan guarantees at least 4 sub-pixel bits).
const BEAM_HULL_MARGIN: f32 = 0.625;

var<private> pts: array<vec2f, 24>;

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
    var h: BeamHull;
    h.info = vec4u(0u, bi, 0u, 0u);
    let wf = f32(bp.width);
    let hf = f32(bp.height);
    // The six corners (as beam_refine's bounding sphere).
    let v = array<vec3f, 3>(b.v0.xyz, b.v1.xyz, b.v2.xyz);
    let d = array<vec3f, 3>(b.d0.xyz, b.d1.xyz, b.d2.xyz);
    let len = vec3f(b.d0.w, b.d1.w, b.d2.w);
    var nrm = normalize(cross(v[1] - v[0], v[2] - v[0]));
    if (dot(nrm, d[0] + d[1] + d[2]) < 0.0) { nrm = -nrm; }
    let cs = vec3f(dot(nrm, d[0]), dot(nrm, d[1]), dot(nrm, d[2]));
    let ys = len * cs;
    let ym = max(max(ys.x, ys.y), ys.z);
    let e0 = v[0] + d[0] * len.x;
    let e1 = v[1] + d[1] * len.y;
    let e2 = v[2] + d[2] * len.z;
    let tol = 0.5 * max(max(length(e1 - e0), length(e2 - e1)), length(e0 - e2)) + 1e-4 * ym;
    let yt = ym + tol;
    var zmin = 1e30;
    var zmax = 0.0;
    var far = 0.0;
    var corners: array<vec2f, 6>;
    for (var i = 0u; i < 6u; i++) {
        let j = i % 3u;
        var x = v[j];
        if (i >= 3u) { x += d[j] * (yt / cs[j]); }
        let c = bp.world_to_clip * vec4f(x, 1.0);
        zmin = min(zmin, c.w);
        zmax = max(zmax, c.w);
        corners[i] = vec2f((c.x / c.w + 1.0) * 0.5 * wf, (1.0 - c.y / c.w) * 0.5 * hf);
        far = max(far, max(abs(corners[i].x), abs(corners[i].y)));
    }
    // (NaN fails every test: the whole image too)
    if (!(zmin > 1e-3 * zmax) || !(far < 1e7)) {
        rectangle(&h, vec2f(-1.0), vec2f(wf + 1.0, hf + 1.0));
        hulls[k] = h;
        return;
    }
    let m = BEAM_HULL_MARGIN;
    var lo = vec2f(1e30);
    var hi = vec2f(-1e30);
    var start = 0u;
    for (var i = 0u; i < 24u; i++) {
        let sx = select(-m, m, (i & 1u) != 0u);
        let sy = select(-m, m, (i & 2u) != 0u);
        let p = corners[i / 4u] + vec2f(sx, sy);
        pts[i] = p;
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
        set_vertex(&h, n, pts[cur]);
        n++;
        var nxt = (cur + 1u) % 24u;
        for (var j = 0u; j < 24u; j++) {
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
        h.info.x = n;
    } else {
        rectangle(&h, lo, hi);
    }
    hulls[k] = h;
}
