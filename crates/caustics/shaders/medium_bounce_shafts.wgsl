// Stage: medium_bounce_shafts. The light one light's shaft scatters in the medium, gathered into
// point emitters ("shaft VPLs") for `medium_bounce_surfaces`, which lights the diffuse surfaces
// the camera sees with it (light -> fog -> floor -> camera).
//
// One workgroup per block of a light face (the same grid x grid blocks as
// `medium_bounce_lights`): dispatch (grid, grid, faces). The block's 8 x 8 sub-rays from the
// light are cut into SHAFT_SLICES equal slices over [t0, t1]: the part inside the medium's box of
// the block's centre ray, ending at the farthest receiver point of the block's texels (the light
// goes no further there; the box's far side if it has none). Per sub-ray and slice, at the
// slice's midpoint x (skipped where an earlier face holds x: the first face owns a point):
//   scattered flux = e(x) * area * T(light -> x) * sigma_s(x) * dt * V(x)
// e(x) the light's I(w)/r^2 (directional: its irradiance E), area = the cross-section of the
// sub-ray there (`texel_area` of a face of 8 grid sub-texels, facing the light), V(x) the shadow
// map's visibility (as `medium_scatter`). It leaves x by the phase function about the light's
// direction. Per slice, the sums over the block's 64 sub-rays become one VPL:
//   full = the scattered flux (W, rgb), caustic = 0 (the shaft is direct light);
//   position = the flux-weighted mean point, r2 = 2 * (the points' weighted variance) + dt^2/4
//   (the cross-section's and the slice's extent: `medium_bounce_surfaces` adds it to the squared
//   distance, bounding the lookup near the shaft);
//   nrm = the block's centre direction of travel (for the phase function).
// Each thread (slice j, row g) sums its row of 8 sub-rays; the 8 rows of a slice are summed by a
// fixed tree: the same bits in every run. Writes vpls[offset + ((face grid + by) grid + bx)
// SHAFT_SLICES + j].

#import medium
#import medium_bounce
#import scene

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> bp: BounceLightParams;
@group(0) @binding(2) var recv_pos: texture_2d_array<f32>;
@group(0) @binding(3) var shadow_map: texture_depth_2d_array;
@group(0) @binding(4) var shadow_sampler: sampler_comparison;
@group(0) @binding(5) var<storage, read_write> vpls: array<Vpl>;

const SHAFT_SLICES: u32 = 8u;
const SUB: u32 = 8u;

var<workgroup> s_flux: array<vec4f, 64>;
var<workgroup> s_pos: array<vec4f, 64>;
var<workgroup> s_far: atomic<u32>;

// The ray through NDC point `ndc` of face f: (origin, unit direction of travel). An orthographic
// face's ray starts beyond the box, so its [0, inf) covers the whole box.
struct Ray { o: vec3f, d: vec3f }

fn face_ray(f: u32, ndc: vec2f) -> Ray {
    let face = light.faces[f];
    let a = face.clip_to_world * vec4f(ndc, 0.0, 1.0);
    let b = face.clip_to_world * vec4f(ndc, 1.0, 1.0);
    let pn = a.xyz / a.w;
    let d = normalize(b.xyz / b.w - pn);
    if (face.origin.w < 0.5) { return Ray(face.origin.xyz, d); }
    let back = length(bp.hi.xyz - bp.lo.xyz) + length(pn - clamp(pn, bp.lo.xyz, bp.hi.xyz)) + 1.0;
    return Ray(pn - d * back, d);
}

// Whether the light reaches x in face f (one bilinear comparison one texel toward the light, as
// `medium_scatter`'s `visibility`).
fn visible(f: u32, x: vec3f, to_l: vec3f) -> f32 {
    return shadow_point(shadow_map, shadow_sampler, light.faces[f], f, x, to_l, f32(bp.shadow_size));
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wid: vec3u, @builtin(local_invocation_index) i: u32) {
    let m = light.info.w;
    let f = wid.z;
    let grid = bp.grid;
    let lo = bp.lo.xyz;
    let hi = bp.hi.xyz;
    // The block's centre ray and its part in the box.
    let cells = f32(grid * SUB);
    let centre = vec2f(f32(wid.x) + 0.5, f32(wid.y) + 0.5) / f32(grid);
    let cr = face_ray(f, vec2f(centre.x * 2.0 - 1.0, 1.0 - centre.y * 2.0));
    let seg = box_clip(cr.o, cr.d, 1e30, lo, hi);
    // The farthest receiver point of the block's texels along the centre ray.
    if (i == 0u) { atomicStore(&s_far, 0u); }
    workgroupBarrier();
    let b = (m + grid - 1u) / grid;
    let x0 = wid.x * b;
    let y0 = wid.y * b;
    let bw = max(min(x0 + b, m), x0) - x0;
    let count = bw * (max(min(y0 + b, m), y0) - y0);
    var far = 0.0;
    for (var k = i; k < count; k += 64u) {
        let r = textureLoad(recv_pos, vec2i(i32(x0 + k % bw), i32(y0 + k / bw)), f, 0);
        if (r.w >= 0.0) { far = max(far, dot(r.xyz - cr.o, cr.d)); }
    }
    // Non-negative floats order as their bits.
    atomicMax(&s_far, bitcast<u32>(max(far, 0.0)));
    workgroupBarrier();
    let far_all = bitcast<f32>(atomicLoad(&s_far));
    var t1 = seg.y;
    if (far_all > 0.0) { t1 = min(t1, far_all); }
    let t0 = seg.x;
    let dt = max(t1 - t0, 0.0) / f32(SHAFT_SLICES);
    // This thread: slice j, sub-ray row g.
    let j = i / SUB;
    let g = i % SUB;
    let tj = t0 + (f32(j) + 0.5) * dt;
    let c = cr.o + cr.d * tj;
    var a_flux = vec4f(0.0);
    var a_pos = vec4f(0.0);
    if (dt > 0.0) {
        for (var a = 0u; a < SUB; a++) {
            let sub = (vec2f(f32(wid.x * SUB + a), f32(wid.y * SUB + g)) + 0.5) / cells;
            let r = face_ray(f, vec2f(sub.x * 2.0 - 1.0, 1.0 - sub.y * 2.0));
            let x = r.o + r.d * tj;
            var owned = true;
            for (var e = 0u; e < f; e++) {
                if (project_face(light.faces[e], x, 1.0).w > 0.5) { owned = false; }
            }
            if (!owned) { continue; }
            var e_in: vec3f;
            if (light.info.y == LIGHT_DIRECTIONAL) {
                e_in = light.power.rgb;
            } else {
                e_in = intensity_toward(light, r.d) / (tj * tj);
            }
            if (all(e_in <= vec3f(0.0))) { continue; }
            var rho = 1.0;
            var tr: vec3f;
            let lp = light_path_start(light, x, lo, hi);
            if (bp.heterogeneous == 0u) {
                tr = exp(-bp.sigma_t.rgb * box_length(lp, x, lo, hi));
            } else {
                rho = grid_density(density_grid, x, lo, hi);
                if (rho <= 0.0) { continue; }
                tr = exp(-bp.sigma_t.rgb * grid_optical_depth(density_grid, lp, x, lo, hi, bp.light_steps));
            }
            let vis = visible(f, x, -r.d);
            if (vis <= 0.0) { continue; }
            let area = texel_area(light.faces[f], x, -r.d, cells);
            let flux = e_in * area * tr * bp.sigma_s.rgb * rho * dt * vis;
            let w = flux.r + flux.g + flux.b;
            if (w <= 0.0) { continue; }
            let d = x - c;
            a_flux += vec4f(flux, w);
            a_pos += vec4f(w * d, w * dot(d, d));
        }
    }
    s_flux[i] = a_flux;
    s_pos[i] = a_pos;
    workgroupBarrier();
    for (var k = SUB / 2u; k > 0u; k = k / 2u) {
        if (g < k) {
            s_flux[i] += s_flux[i + k];
            s_pos[i] += s_pos[i + k];
        }
        workgroupBarrier();
    }
    if (g != 0u) { return; }
    let out = bp.offset + ((f * grid + wid.y) * grid + wid.x) * SHAFT_SLICES + j;
    let wsum = s_flux[i].w;
    if (wsum <= 0.0) {
        vpls[out] = Vpl(vec4f(c, 0.0), vec4f(cr.d, 0.0), vec4f(0.0), vec4f(0.0));
        return;
    }
    let mean = s_pos[i].xyz / wsum;
    let var_p = max(s_pos[i].w / wsum - dot(mean, mean), 0.0);
    let r2 = 2.0 * var_p + 0.25 * dt * dt;
    vpls[out] = Vpl(vec4f(c + mean, r2), vec4f(cr.d, 0.0), vec4f(s_flux[i].rgb, 0.0), vec4f(0.0));
}
