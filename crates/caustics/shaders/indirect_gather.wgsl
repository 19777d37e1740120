// Stage: indirect_gather. The diffuse surfaces the camera sees, lit by the light that reached
// them after at least one diffuse bounce (src/indirect/, docs/indirect.md): per pixel whose
// first surface is diffuse (point y, normal n turned toward the camera, albedo rho), the
// cache's irradiance as a density estimate in the surface's plane,
//   E(y) = sum_c F_c K(r_c) / coverage,  K(r) = 3 / (pi R^2) (1 - r^2 / R^2)^2  (r < R = 2 h),
// over the cells c near y whose mean normal lies within 60 degrees of n and whose mean position
// lies within R / 2 of y's plane, r_c its distance to y in that plane (a kernel of unit
// integral over the plane: a flat surface keeps every photon's flux). Near a surface's edge
// (a room's corners) part of the kernel falls off the surface and would darken the estimate:
// `coverage` is the share of the kernel, summed over the 5 x 5 columns of cells in the plane
// at their centres, that the columns holding such a cell carry (1 inside a surface, about
// 1/2 at an edge, 1/4 in a corner; at least 1/4). Adds rho / pi E to the eye's radiance (not
// the caustic-only image). Runs before `composite`, so surfaces seen through glass and in
// mirrors show it.

#import scene
#import indirect

@group(0) @binding(0) var<uniform> ip: IndirectParams;
@group(0) @binding(1) var<storage, read> keys: array<u32>;
@group(0) @binding(2) var<storage, read> cells: array<vec4f>;
@group(0) @binding(3) var eye_pos: texture_2d<f32>;
@group(0) @binding(4) var eye_nrm: texture_2d<f32>;
@group(0) @binding(5) var<storage, read_write> radiance: array<vec4f>;

// The slot that holds `key`, or IC_NONE.
fn ic_find(key: u32) -> u32 {
    var s = ic_home(key);
    for (var k = 0u; k < IC_PROBES; k++) {
        let v = keys[s];
        if (v == key) { return s; }
        if (v == 0u) { return IC_NONE; }
        s = (s + 1u) & (ip.capacity - 1u);
    }
    return IC_NONE;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= ip.width || gid.y >= ip.height) { return; }
    let pw = textureLoad(eye_pos, vec2i(gid.xy), 0);
    if (pw.w < 0.0) { return; }
    let mat = materials[u32(pw.w)];
    if (mat.kind.x != KIND_DIFFUSE || !any(mat.a.rgb > vec3f(0.0))) { return; }
    let y = pw.xyz;
    var n = normalize(textureLoad(eye_nrm, vec2i(gid.xy), 0).xyz);
    if (dot(n, ip.camera.xyz - y) < 0.0) { n = -n; }
    let h = ip.origin.w;
    let r2max = 4.0 * h * h;
    let c = ic_coord(y);
    // Two cells either way in the plane, one across it.
    let a = abs(n);
    var span = vec3i(2);
    var ax = 2u;
    if (a.x >= a.y && a.x >= a.z) { ax = 0u; } else if (a.y >= a.z) { ax = 1u; }
    span[ax] = 1;
    // The plane's two axes: the columns of cells are (offset along u, offset along v).
    let u = (ax + 1u) % 3u;
    let v = (ax + 2u) % 3u;
    var columns = 0u;
    var e = vec3f(0.0);
    for (var b = 0u; b < 6u; b++) {
        if (dot(ic_axis(b), n) <= 0.3) { continue; }
        for (var dz = -span.z; dz <= span.z; dz++) {
            for (var dy = -span.y; dy <= span.y; dy++) {
                for (var dx = -span.x; dx <= span.x; dx++) {
                    let q = c + vec3i(dx, dy, dz);
                    if (any(q < vec3i(0)) || any(q > vec3i(IC_AXIS))) { continue; }
                    let s = ic_find(ic_key(q, b));
                    if (s == IC_NONE) { continue; }
                    let f = cells[s * 3u];
                    if (!(f.w > 0.0)) { continue; }
                    let p = cells[s * 3u + 1u].xyz / f.w;
                    let cn = cells[s * 3u + 2u].xyz;
                    if (dot(cn, n) < 0.5 * length(cn)) { continue; }
                    let dv = p - y;
                    let along = dot(dv, n);
                    if (abs(along) > h) { continue; }
                    let d = vec3i(dx, dy, dz);
                    columns |= 1u << u32((d[u] + 2) * 5 + d[v] + 2);
                    let r2 = max(dot(dv, dv) - along * along, 0.0);
                    if (r2 >= r2max) { continue; }
                    let t = 1.0 - r2 / r2max;
                    e += f.rgb * (3.0 / (PI * r2max) * t * t);
                }
            }
        }
    }
    // The kernel's share on the columns that hold the surface, at the columns' centres.
    var all = 0.0;
    var held = 0.0;
    for (var i = 0; i < 5; i++) {
        for (var j = 0; j < 5; j++) {
            let cu = ip.origin[u] + (f32(c[u] + i - 2) + 0.5) * h - y[u];
            let cv = ip.origin[v] + (f32(c[v] + j - 2) + 0.5) * h - y[v];
            let r2 = cu * cu + cv * cv;
            if (r2 >= r2max) { continue; }
            let t = 1.0 - r2 / r2max;
            all += t * t;
            if ((columns & (1u << u32(i * 5 + j))) != 0u) { held += t * t; }
        }
    }
    if (all > 0.0 && held > 0.0) { e /= max(held / all, 0.25); }
    let idx = gid.y * ip.width + gid.x;
    radiance[idx] += vec4f(mat.a.rgb / PI * e, 0.0);
}
