// Caustic sphere tables (src/caustic_spheres/): the record of one (directional light, caustic
// object, blended stored direction), or of one object's compiled table, and the trilinear
// lookup shared by sphere_gather and sphere_compile (the CPU twin: CausticSpheres::sample).
// The stage declares `table: array<vec4u>`: per cell two vec4 of f32 bits (C, d), one of f16
// pairs (half floats), or three of f32 bits (a compiled table: V_r, V_g, V_b).

struct SphereRecord {
    // world -> the object's frame (the scene file's pose): rows of a 3x4 matrix.
    to_obj: array<vec4f, 3>,
    // The stored pattern's frame rotated onto the light: R a, R b, R w (w the stored direction).
    axes: array<vec4f, 3>,
    // Rows of R: a stored mean direction d appears as R d.
    rot: array<vec4f, 3>,
    // Sphere centre (xyz) and r_min (w).
    center: vec4f,
    // r_max, sphere count s, longitudes W, latitudes H.
    shape: vec4f,
    // Blend weight times the light's irradiance (W/m^2, rgb).
    irradiance: vec4f,
    // x: the table index of the stored direction's first cell; y: the caustic object's index;
    // z: 1 for half floats (one vec4u per cell: C and d as f16 pairs), 0 for f32 (two vec4u of
    // f32 bits per cell).
    base: vec4u,
}

// The lookup at object-frame point po: C (rgb, times the 1/r^2 fall-off outside the spheres)
// and the mean direction d (of length <= 1) turned by the record's rotation (object frame; zero
// where no light is); for a compiled record the three vectors V_c instead.
struct SphereSample {
    c: vec3f,
    d: vec3f,
    v0: vec3f,
    v1: vec3f,
    v2: vec3f,
}

fn sphere_cell(base: u32, sphere: u32, row: u32, col: u32, w: u32, h: u32, stride: u32) -> u32 {
    return base + ((sphere * h + row) * w + col) * stride;
}

fn sphere_lookup(r: SphereRecord, po: vec3f) -> SphereSample {
    var out = SphereSample(vec3f(0.0), vec3f(0.0), vec3f(0.0), vec3f(0.0), vec3f(0.0));
    let q = po - r.center.xyz;
    let rad = length(q);
    if (rad <= 0.0) { return out; }
    let loc = vec3f(dot(r.axes[0].xyz, q), dot(r.axes[1].xyz, q), dot(r.axes[2].xyz, q)) / rad;
    let s = u32(r.shape.y);
    let w = u32(r.shape.z);
    let h = u32(r.shape.w);
    let r_min = r.center.w;
    let r_max = r.shape.x;
    // Outside the spheres: 1/r^2 from the nearest one.
    var rr = rad;
    var fall = 1.0;
    if (rad < r_min) { rr = r_min; fall = (r_min / rad) * (r_min / rad); }
    if (rad > r_max) { rr = r_max; fall = (r_max / rad) * (r_max / rad); }
    // Equation (1) inverted: the sphere parameter.
    let fs = sqrt(max((rr - r_min) / (r_max - r_min), 0.0)) * f32(s - 1u);
    let s0 = min(u32(floor(fs)), s - 2u);
    let ws = clamp(fs - f32(s0), 0.0, 1.0);
    // Latitude (warped, theta = pi t^2) and longitude, cell centres at +0.5.
    let th = atan2(length(loc.xy), loc.z);
    let ft = sqrt(th / PI) * f32(h) - 0.5;
    var ph = atan2(loc.y, loc.x);
    if (ph < 0.0) { ph += 2.0 * PI; }
    let fp = ph / (2.0 * PI) * f32(w) - 0.5;
    let r0 = floor(ft);
    let wr = ft - r0;
    let c0 = floor(fp);
    let wc = fp - c0;
    let rows = vec2u(u32(clamp(i32(r0), 0, i32(h) - 1)), u32(clamp(i32(r0) + 1, 0, i32(h) - 1)));
    let iw = i32(w);
    let cols = vec2u(u32(((i32(c0) % iw) + iw) % iw), u32(((i32(c0) + 1) % iw + iw) % iw));
    var c = vec3f(0.0);
    var d = vec3f(0.0);
    var lum = 0.0;
    let mode = r.base.z;
    let stride = select(select(2u, 1u, mode == 1u), 3u, mode == 2u);
    for (var k = 0u; k < 8u; k++) {
        let si = k & 1u;
        let ri = (k >> 1u) & 1u;
        let ci = (k >> 2u) & 1u;
        let wt = select(1.0 - ws, ws, si == 1u) * select(1.0 - wr, wr, ri == 1u) * select(1.0 - wc, wc, ci == 1u);
        if (wt == 0.0) { continue; }
        let at = sphere_cell(r.base.x, s0 + si, rows[ri], cols[ci], w, h, stride);
        if (mode == 2u) {
            out.v0 += bitcast<vec4f>(table[at]).xyz * wt;
            out.v1 += bitcast<vec4f>(table[at + 1u]).xyz * wt;
            out.v2 += bitcast<vec4f>(table[at + 2u]).xyz * wt;
            continue;
        }
        var ce: vec3f;
        var de: vec3f;
        if (mode == 1u) {
            let v = table[at];
            ce = vec3f(unpack2x16float(v.x), unpack2x16float(v.y).x);
            de = vec3f(unpack2x16float(v.z), unpack2x16float(v.w).x);
        } else {
            ce = bitcast<vec4f>(table[at]).rgb;
            de = bitcast<vec4f>(table[at + 1u]).xyz;
        }
        c += ce * wt;
        d += de * (wt * (ce.r + ce.g + ce.b));
        lum += wt * (ce.r + ce.g + ce.b);
    }
    out.v0 *= fall;
    out.v1 *= fall;
    out.v2 *= fall;
    if (lum <= 0.0) { return out; }
    // The luminance-weighted mean of the cells' mean directions, not normalized (|d| <= 1: C d
    // is the vector irradiance, mod.rs).
    let dn = d / lum;
    out.c = c * fall;
    out.d = vec3f(dot(r.rot[0].xyz, dn), dot(r.rot[1].xyz, dn), dot(r.rot[2].xyz, dn));
    return out;
}
