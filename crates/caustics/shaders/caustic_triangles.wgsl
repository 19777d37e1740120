// Stage: caustic_triangles. Caustic triangles from the dense photon grid: the photons of grid
// cells (i, j), (i+1, j), (i, j+1), (i+1, j+1) form a quad, split along its (i, j)-(i+1, j+1)
// diagonal into two triangles. Each photon gives a quarter of its flux to each of the four quads
// around it; a quad's flux is shared equally by its two triangles, and a triangle spreads its
// flux uniformly over its area in the caustic map: the flux of each texel is the triangle's flux
// times the exact area of the triangle inside the texel (polygon clipping) over the triangle's
// area, so density comes from geometry, not from counting photons.
// - Folds: a triangle that flips orientation (past a caustic cusp) is a sheet of light like any
//   other: its flux is spread over its (unsigned) area, and overlapping sheets add up.
// - Discontinuities: a quad is used only if its four photons are valid, land on the same face
//   (or, for a point light's cube, on faces the quad's corners all lie in front of: the quad is
//   then spread over the faces across the seam, shared/triangles.wgsl `triangle_cube`),
//   followed the same path (Photon.flux.w: the path signature the tracer writes: objects and
//   internal reflections) and no edge spans more than `max_edge` texels (an edge that long
//   crosses a gap between surfaces). Otherwise each valid corner's quarter is splatted as a
//   normalised Gaussian at the photon, as wide as its beam (half its ray-differential diameter,
//   Photon._pad: the image of one grid cell on the receiver; at least the fixed splat's sigma,
//   at most MAX_FALLBACK_SIGMA texels): light is never smeared across a silhouette or a total-internal-reflection
//   boundary, and where light spreads thin (quads dropped for their length) it stays smooth.
//   (Accepting long quads whose area matches the differentials was tried: it helps the ball
//   and the ring but moves light across gaps on the scanned meshes, whose differentials are
//   noisy.)
// Conservation: the parts of a triangle outside the map and any rounding go to the texel of
// its centroid (clamped), so every photon's flux lands exactly once.
// A pass handles the quad rows r0 - 1 .. r0 - 1 + quad_rows of one face: photon row r0 - 1 is
// held at index 0 of `photons` (has_prev), rows r0 .. r0 + rows from index cur_off.

#import splat
#import triangles

struct TriParams {
    n: u32,
    r0: u32,
    rows: u32,
    quad_rows: u32,
    cur_off: u32,
    has_prev: u32,
    max_edge: f32,
    _pad: u32,
}

// Widest fallback Gaussian, in texels. 12 rather than 6: where a mesh spreads light into fine,
// dim filaments (bunny_over_ball) the rejected quads' photons are isolated, and 6-texel splats
// drew them as blotches (region HDR-FLIP 0.151 -> 0.128 against the CPU reference with 12).
// Wider is not better on lavapipe: a splat loops over (6 sigma + 1)^2 texels twice, and lavapipe
// ends an invocation's loops after about 65536 iterations in all, so four corners at sigma 18
// lose light; at 12 four corners take 42 600 iterations.
const MAX_FALLBACK_SIGMA: f32 = 12.0;

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> tp: TriParams;
@group(0) @binding(2) var<storage, read> photons: array<Photon>;
@group(0) @binding(3) var<storage, read_write> accum: array<atomic<u32>>;

fn load(x: i32, y: i32) -> Photon {
    var p: Photon;
    p.face = INVALID;
    let n = i32(tp.n);
    if (x < 0 || x >= n || y < 0 || y >= n) { return p; }
    let r0 = i32(tp.r0);
    if (y == r0 - 1) {
        if (tp.has_prev == 0u) { return p; }
        return photons[u32(x)];
    }
    if (y < r0 || y >= r0 + i32(tp.rows)) { return p; }
    return photons[tp.cur_off + u32(y - r0) * tp.n + u32(x)];
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x > tp.n || gid.y >= tp.quad_rows) { return; }
    let x = i32(gid.x) - 1;
    let y = i32(tp.r0) - 1 + i32(gid.y);
    var q: array<Photon, 4>;
    q[0] = load(x, y);
    q[1] = load(x + 1, y);
    q[2] = load(x, y + 1);
    q[3] = load(x + 1, y + 1);
    // The corners' landing points in face f's texel coordinates.
    var pos = array<vec2f, 4>(q[0].pos, q[1].pos, q[2].pos, q[3].pos);
    let f = q[0].face;
    var ok = f != INVALID;
    var one_path = f != INVALID;
    for (var k = 1; k < 4; k++) {
        ok = ok && q[k].face == f && q[k].flux.w == q[0].flux.w;
        one_path = one_path && q[k].face != INVALID && q[k].flux.w == q[0].flux.w;
    }
    if (!ok && one_path && light.info.x == 6u) {
        // A quad across a seam of a cube: its corners in face f's coordinates (extended past
        // its map); `triangle` spreads each triangle over the faces it covers.
        var inside = true;
        for (var k = 0; k < 4; k++) {
            var c = vec3f(q[k].pos, 1.0);
            if (q[k].face != f) { c = texel_in_face(light.faces[q[k].face], light.faces[f], q[k].pos, f32(light.info.w)); }
            inside = inside && c.z != 0.0;
            pos[k] = c.xy;
        }
        ok = inside;
    }
    if (ok) {
        let e = max(max(distance(pos[0], pos[1]), distance(pos[0], pos[2])),
                    max(max(distance(pos[1], pos[3]), distance(pos[2], pos[3])), distance(pos[0], pos[3])));
        ok = e <= tp.max_edge;
    }
    if (ok) {
        let quad = 0.25 * (q[0].flux.rgb + q[1].flux.rgb + q[2].flux.rgb + q[3].flux.rgb);
        triangle(f, pos[0], pos[1], pos[3], 0.5 * quad);
        triangle(f, pos[0], pos[3], pos[2], 0.5 * quad);
        return;
    }
    for (var k = 0; k < 4; k++) {
        if (q[k].face == INVALID) { continue; }
        var sigma = light.params.z;
        let d = bitcast<f32>(q[k]._pad);
        if (d > 0.0 && d < 1e30) { sigma = clamp(0.5 * d, light.params.z, MAX_FALLBACK_SIGMA); }
        gauss_splat(q[k].face, q[k].pos, 0.25 * q[k].flux.rgb, sigma);
    }
}
