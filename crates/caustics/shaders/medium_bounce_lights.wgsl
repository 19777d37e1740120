// Stage: medium_bounce_lights. The light one light's diffuse receivers reflect, gathered into
// virtual point lights (VPLs) for `medium_bounce`, which scatters it into the medium toward the
// camera (light -> floor -> fog -> camera, and light -> glass -> floor -> fog -> camera).
//
// One workgroup per block of BxB texels (B = ceil(M / grid)) of one face of the light's
// receiver maps (M x M, the caustic map's size): dispatch (grid, grid, faces). Per texel whose
// receiver is a diffuse surface with albedo rho, and which no earlier face holds (the first face
// that contains a point owns it, as in `shade_receivers`):
//   direct flux  = I(w) cos / r^2 * area * shadow   (directional: E cos * area)
//   caustic flux = caustic irradiance (the light's map) * area
// both times the transmittance from the light to the texel (as `shade_receivers` attenuates
// them; not the caustic: the photons carried their own path's, shared/trace.wgsl), area = the receiver area the texel covers (`texel_area`). The reflected flux rho *
// (direct + caustic) leaves the surface as a Lambertian emitter. The block's sums become one VPL:
//   full    = sum of the reflected flux (W, rgb), into the full image;
//   caustic = the part of it that came as caustic, into the caustic-only image;
//   position = the flux-weighted mean of the texels' points (weight w = full.r + full.g + full.b),
//   r2 = 2 * (weighted variance of the points about it) + (weighted mean texel area) / pi: the
//        squared radius of the disk with the same spread (a uniform disk of radius R has
//        E|p - c|^2 = R^2 / 2), which `medium_bounce` adds to the squared distance: the
//        irradiance on the axis of a uniform Lambertian disk of flux F is F / (pi (h^2 + R^2)),
//        so the lookup is exact there and bounded near the surface;
//   normal = the flux-weighted mean of the texels' normals (turned toward the light).
// The sums run in a fixed order (each thread over a fixed stride, then a tree reduction), and
// the points are summed relative to the block's first receiver point (the lowest thread's), so
// the VPLs are the same bits in every run and far from the origin keep their precision.
// Writes `vpls[offset + (face * grid + by) * grid + bx]`; a block with no reflected light
// writes a VPL of zero flux (which `medium_bounce` skips).

#import medium
#import medium_bounce
#import scene

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> bp: BounceLightParams;
@group(0) @binding(2) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(3) var recv_nrm: texture_2d_array<f32>;
@group(0) @binding(4) var<storage, read> irradiance: array<vec4f>;
@group(0) @binding(5) var shadow_map: texture_depth_2d_array;
@group(0) @binding(6) var shadow_sampler: sampler_comparison;
@group(0) @binding(7) var<storage, read_write> vpls: array<Vpl>;

const WG: u32 = 64u;

// (full.rgb, w), (caustic.rgb, w * area), (w * (p - c), w |p - c|^2), (w * n, 0)
var<workgroup> s_full: array<vec4f, 64>;
var<workgroup> s_caus: array<vec4f, 64>;
var<workgroup> s_pos: array<vec4f, 64>;
var<workgroup> s_nrm: array<vec4f, 64>;
// Per thread: its first receiver point (w = 1 if it has one).
var<workgroup> s_first: array<vec4f, 64>;

// The direct light's visibility at receiver point p (normal n) in face f: 3x3 PCF with the
// normal offset of `shade_receivers` (its `shadow`, without the tile shortcut).
fn shadow(p: vec3f, n: vec3f) -> f32 {
    let s = f32(bp.shadow_size);
    var f = 0u;
    var q0 = vec4f(0.0);
    for (; f < light.info.x; f++) {
        q0 = project_face(light.faces[f], p, s);
        if (q0.w > 0.5) { break; }
    }
    if (f >= light.info.x) { return 1.0; }
    let l = to_light(light, p);
    let po = shadow_lookup_point(light.faces[f], p, n, l.xyz, s);
    let q = project_face(light.faces[f], po, s);
    if (q.w < 0.5) { return 1.0; }
    return shadow_pcf(shadow_map, shadow_sampler, q, f, s);
}

// The receiver at texel t of face f, if this face owns it: (point, object id) or w < 0.
fn receiver(t: vec2i, f: u32, m: u32) -> vec4f {
    let r = textureLoad(recv_pos, t, f, 0);
    if (r.w < 0.0) { return vec4f(-1.0); }
    let mat = materials[u32(r.w)];
    if (mat.kind.x != KIND_DIFFUSE || all(mat.a.rgb <= vec3f(0.0))) { return vec4f(-1.0); }
    for (var g = 0u; g < f; g++) {
        if (project_face(light.faces[g], r.xyz, f32(m)).w > 0.5) { return vec4f(-1.0); }
    }
    return r;
}

fn reduce(i: u32) {
    for (var k = WG / 2u; k > 0u; k = k / 2u) {
        if (i < k) {
            s_full[i] += s_full[i + k];
            s_caus[i] += s_caus[i + k];
            s_pos[i] += s_pos[i + k];
            s_nrm[i] += s_nrm[i + k];
        }
        workgroupBarrier();
    }
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3u, @builtin(local_invocation_index) i: u32) {
    let m = light.info.w;
    let f = wid.z;
    let grid = bp.grid;
    let b = (m + grid - 1u) / grid;
    let x0 = wid.x * b;
    let y0 = wid.y * b;
    let x1 = min(x0 + b, m);
    let y1 = min(y0 + b, m);
    let bw = max(x1, x0) - x0;
    let count = bw * (max(y1, y0) - y0);
    // Phase 1: each thread's first receiver point; the lowest thread's is the block's origin.
    var first = vec4f(0.0);
    for (var k = i; k < count; k += WG) {
        let t = vec2i(i32(x0 + k % bw), i32(y0 + k / bw));
        let r = receiver(t, f, m);
        if (r.w >= 0.0) {
            first = vec4f(r.xyz, 1.0);
            break;
        }
    }
    s_first[i] = first;
    workgroupBarrier();
    var c = vec3f(0.0);
    for (var k = 0u; k < WG; k++) {
        if (s_first[k].w > 0.5) {
            c = s_first[k].xyz;
            break;
        }
    }
    // Phase 2: the sums.
    var a_full = vec4f(0.0);
    var a_caus = vec4f(0.0);
    var a_pos = vec4f(0.0);
    var a_nrm = vec4f(0.0);
    for (var k = i; k < count; k += WG) {
        let t = vec2i(i32(x0 + k % bw), i32(y0 + k / bw));
        let r = receiver(t, f, m);
        if (r.w < 0.0) { continue; }
        let p = r.xyz;
        let l = to_light(light, p);
        let n_raw = textureLoad(recv_nrm, t, f, 0).xyz;
        if (dot(n_raw, n_raw) <= 1e-20) { continue; }
        var n = normalize(n_raw);
        if (dot(n, l.xyz) < 0.0) { n = -n; }
        let cos_t = max(dot(n, l.xyz), 0.0);
        var e_direct: vec3f;
        if (light.info.y == LIGHT_DIRECTIONAL) {
            e_direct = light.power.rgb * cos_t;
        } else {
            e_direct = intensity_toward(light, -l.xyz) * cos_t / (l.w * l.w);
        }
        if (any(e_direct > vec3f(0.0))) { e_direct *= shadow(p, n); }
        let ec = irradiance[(f * m + u32(t.y)) * m + u32(t.x)].rgb;
        var tr = vec3f(1.0);
        if (bp.lo.w > 0.5) {
            let lp = light_path_start(light, p, bp.lo.xyz, bp.hi.xyz);
            if (bp.heterogeneous == 0u) {
                tr = exp(-bp.sigma_t.rgb * box_length(lp, p, bp.lo.xyz, bp.hi.xyz));
            } else {
                tr = exp(-bp.sigma_t.rgb * grid_optical_depth(density_grid, lp, p, bp.lo.xyz, bp.hi.xyz, bp.light_steps));
            }
        }
        let area = texel_area(light.faces[f], p, n, f32(m));
        let rho = materials[u32(r.w)].a.rgb;
        // The caustic map holds the light that arrives: the photons carried their path's
        // transmittance (shared/trace.wgsl).
        let full = rho * (e_direct * tr + ec) * area;
        let caus = rho * ec * area;
        let w = full.r + full.g + full.b;
        if (w <= 0.0) { continue; }
        let d = p - c;
        a_full += vec4f(full, w);
        a_caus += vec4f(caus, w * area);
        a_pos += vec4f(w * d, w * dot(d, d));
        a_nrm += vec4f(w * n, 0.0);
    }
    s_full[i] = a_full;
    s_caus[i] = a_caus;
    s_pos[i] = a_pos;
    s_nrm[i] = a_nrm;
    workgroupBarrier();
    reduce(i);
    if (i != 0u) { return; }
    let out = bp.offset + (f * grid + wid.y) * grid + wid.x;
    let wsum = s_full[0].w;
    if (wsum <= 0.0) {
        vpls[out] = Vpl(vec4f(c, 0.0), vec4f(0.0), vec4f(0.0), vec4f(0.0));
        return;
    }
    let mean = s_pos[0].xyz / wsum;
    let var_p = max(s_pos[0].w / wsum - dot(mean, mean), 0.0);
    let r2 = 2.0 * var_p + s_caus[0].w / wsum / PI;
    var n = s_nrm[0].xyz;
    let nl = length(n);
    n = select(to_light(light, c + mean).xyz, n / nl, nl > 1e-20);
    vpls[out] = Vpl(vec4f(c + mean, r2), vec4f(n, 0.0), vec4f(s_full[0].rgb, 0.0), vec4f(s_caus[0].rgb, 0.0));
}
