// Stage: medium_bounce_surfaces. The diffuse surfaces the camera sees, lit by the light the
// medium scatters out of every light's shaft (light -> fog -> floor -> camera), from the shaft
// VPLs of `medium_bounce_shafts`, and (one more dispatch per list) out of the lit surfaces'
// glow (light -> floor -> fog -> floor -> camera), from the glow VPLs of `medium_bounce_glow`,
// and out of the volume caustic (light -> glass -> fog -> floor -> camera), from the beam VPLs
// of `medium_bounce_beams`. Per pixel whose first surface is diffuse (point y, normal n
// turned toward the camera, albedo rho), added into the eye's radiance (not the caustic-only
// image: the shaft is direct light):
//   rho / pi * sum_v F_v phase(w_v . u) max(n . -u, 0) / (d^2 + r2_v) G_v T(v -> y),
// G_v the near-field layer gain of the shaft and glow emitters (`layer_gain`,
// shared/medium_bounce.wgsl; 1 for the beams': they bin a focused cone's light whose spread r2
// is much wider than the light near the floor, and the gain spread it too far: the volume
// caustic's floor light 1.03 -> 1.15 of the reference's in `gpu_medium`),
// u the unit direction from the VPL to y, d the distance, w_v the light's direction of travel
// there, T the transmittance (homogeneous: exp(-sigma_t * length in the box); heterogeneous: a
// `BOUNCE_GRID_STEPS`-step march). Runs before `composite`, so surfaces seen through glass and
// in mirrors show it and `medium_scatter` attenuates it toward the camera.
// Not modelled: visibility between the VPL and y (an object between the shaft and a surface
// does not shadow it).
// The VPLs are read in tiles of 64 through workgroup memory; the sums run in a fixed order.

#import medium
#import medium_bounce
#import scene

struct SurfaceBounceParams {
    lo: vec4f,
    hi: vec4f,
    // rgb = sigma_t (1/m), w = Henyey-Greenstein g
    sigma_t: vec4f,
    camera: vec4f,
    width: u32,
    height: u32,
    // VPLs in `vpls`.
    count: u32,
    // 1: heterogeneous (density grid), 0: homogeneous.
    heterogeneous: u32,
    // 1: the emitters stand for fog filling the space (shafts, glow): `layer_gain` applies;
    // 0: the beams' emitters, the volume caustic's light.
    layers: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> sp: SurfaceBounceParams;
@group(0) @binding(1) var<storage, read> vpls: array<Vpl>;
@group(0) @binding(2) var eye_pos: texture_2d<f32>;
@group(0) @binding(3) var eye_nrm: texture_2d<f32>;
@group(0) @binding(4) var<storage, read_write> radiance: array<vec4f>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(local_invocation_index) li: u32) {
    let lo = sp.lo.xyz;
    let hi = sp.hi.xyz;
    var lit = false;
    var y = vec3f(0.0);
    var n = vec3f(0.0);
    var rho = vec3f(0.0);
    if (gid.x < sp.width && gid.y < sp.height) {
        let pw = textureLoad(eye_pos, vec2i(gid.xy), 0);
        if (pw.w >= 0.0) {
            let mat = materials[u32(pw.w)];
            if (mat.kind.x == KIND_DIFFUSE && any(mat.a.rgb > vec3f(0.0))) {
                lit = true;
                y = pw.xyz;
                rho = mat.a.rgb;
                n = normalize(textureLoad(eye_nrm, vec2i(gid.xy), 0).xyz);
                if (dot(n, sp.camera.xyz - y) < 0.0) { n = -n; }
            }
        }
    }
    let y_in = in_box(y, lo, hi);
    var e = vec3f(0.0);
    for (var base = 0u; base < sp.count; base += 64u) {
        let in_tile = load_tile(base, sp.count, li);
        if (lit) {
            for (var k = 0u; k < in_tile; k++) {
                let v = tile[k];
                let dv = y - v.pos.xyz;
                let d2 = dot(dv, dv);
                let dist = sqrt(d2);
                if (dist <= 0.0) { continue; }
                let u = dv / dist;
                let cos_y = -dot(n, u);
                if (cos_y <= 0.0) { continue; }
                var od: vec3f;
                if (sp.heterogeneous != 0u) {
                    od = sp.sigma_t.rgb * grid_optical_depth(density_grid, v.pos.xyz, y, lo, hi, BOUNCE_GRID_STEPS);
                } else {
                    // The whole segment is inside the box when both ends are.
                    var len = dist;
                    if (!y_in || !in_box(v.pos.xyz, lo, hi)) { len = box_length(v.pos.xyz, y, lo, hi); }
                    od = sp.sigma_t.rgb * len;
                }
                e += v.full.rgb * (hg_phase(dot(v.nrm.xyz, u), sp.sigma_t.w) * cos_y / (d2 + v.pos.w) * layer_gain(cos_y * dist, v.pos.w * f32(sp.layers))) * exp(-od);
            }
        }
    }
    if (!lit) { return; }
    let idx = gid.y * sp.width + gid.x;
    radiance[idx] += vec4f(rho / PI * e, 0.0);
}
