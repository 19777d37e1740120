// Stage: medium_bounce. Light that diffuse surfaces reflect into the medium, scattered toward
// the camera: light -> surface -> medium -> camera (full image) and light -> casters -> surface
// -> medium -> camera (the caustic part, into both images), from every light's virtual point
// lights (`medium_bounce_lights`: one per block of a light's receiver map, Lambertian, of
// squared radius r2).
// Per pixel, the camera ray's segment in the medium (as `medium_scatter`: from the camera to the
// first surface it sees, clipped to the box), a midpoint rule in `bp.steps` equal steps of
//   sigma_s(x) sum_v phase(cos) F_v cos_v / (pi (d^2 + r2_v)) G_v T(v -> x) T(camera -> x),
// G_v the near-field layer gain at x's height above the VPL's plane (`layer_gain`,
// shared/medium_bounce.wgsl), with d the distance from the VPL to x, cos_v the cosine at the VPL (zero behind it) and
// cos the scattering angle's (between the VPL-to-x direction and the direction to the camera).
// T in a homogeneous medium: exp(-sigma_t * length in the box); heterogeneous: the camera's
// optical depth by the same midpoint rule, the VPL's by a `BOUNCE_GRID_STEPS`-step march.
// Not modelled: visibility between the VPL and x (objects between a lit surface and the fog it
// lights do not shadow it), light reflected by more than one diffuse surface.
// The VPLs are read in tiles of 64 through workgroup memory; the sums run in a fixed order.
// With `bounce_segments` (a second dispatch, indirect over `composite`'s list of specular
// pixels) the same gather runs along the segments `composite` kept of the paths beyond each
// pixel's specular surface (`EyeSegment`, shared/medium.wgsl), weighted by the path's weight,
// into the full image only (the caustic-only image is zero where the camera sees glass).

#import medium
#import medium_bounce
#import scene

struct BounceParams {
    clip_to_world: mat4x4f,
    camera: vec4f,
    lo: vec4f,
    hi: vec4f,
    // rgb = sigma_s (1/m), w = Henyey-Greenstein g (0: isotropic)
    sigma_s: vec4f,
    // rgb = sigma_t (1/m)
    sigma_t: vec4f,
    width: u32,
    height: u32,
    steps: u32,
    // VPLs in `vpls`.
    count: u32,
    // 1: heterogeneous (density grid), 0: homogeneous.
    heterogeneous: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> bp: BounceParams;
@group(0) @binding(1) var<storage, read> vpls: array<Vpl>;
@group(0) @binding(2) var recv_pos: texture_2d<f32>;
@group(0) @binding(3) var spec_pos: texture_2d<f32>;
@group(0) @binding(4) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(5) var<storage, read_write> out_caustic: array<vec4f>;
// `composite`'s list of specular pixels, its length (count[3]) and the segments it kept.
@group(0) @binding(6) var<storage, read> spec_list: array<u32>;
@group(0) @binding(7) var<storage, read> spec_count: array<u32, 4>;
@group(0) @binding(8) var<storage, read> segments: array<EyeSegment>;
override bounce_segments: bool = false;

fn phase(cos_t: f32) -> f32 {
    return hg_phase(cos_t, bp.sigma_s.w);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) li: u32) {
    let lo = bp.lo.xyz;
    let hi = bp.hi.xyz;
    // This invocation's rays: the pixel's camera ray from the camera to the first surface it
    // sees, or the kept segments of a listed specular pixel; each clipped to the box.
    var ro: array<vec3f, EYE_SEGMENTS>;
    var rd: array<vec3f, EYE_SEGMENTS>;
    var rs: array<vec2f, EYE_SEGMENTS>;
    var rw: array<vec3f, EYE_SEGMENTS>;
    var rays = 0u;
    var idx = 0u;
    if (bounce_segments) {
        let i = wg.x * 64u + li;
        if (i < spec_count[3]) {
            idx = spec_list[i];
            for (var k = 0u; k < EYE_SEGMENTS; k++) {
                let e = segments[i * EYE_SEGMENTS + k];
                if (!(e.o.w > 0.0)) { continue; }
                let d = segment_dir(e);
                let seg = box_clip(e.o.xyz, d, e.o.w, lo, hi);
                if (seg.y <= seg.x) { continue; }
                ro[rays] = e.o.xyz;
                rd[rays] = d;
                rs[rays] = seg;
                rw[rays] = e.w;
                rays++;
            }
        }
    } else if (gid.x < bp.width && gid.y < bp.height) {
        idx = gid.y * bp.width + gid.x;
        let cam = bp.camera.xyz;
        let d = pixel_ray(bp.clip_to_world, cam, gid.xy, bp.width, bp.height);
        let t_max = first_surface(recv_pos, spec_pos, vec2i(gid.xy), cam);
        let seg = box_clip(cam, d, t_max, lo, hi);
        if (seg.y > seg.x) {
            ro[0] = cam;
            rd[0] = d;
            rs[0] = seg;
            rw[0] = vec3f(1.0);
            rays = 1u;
        }
    }
    let n = max(bp.steps, 1u);
    var acc_full = vec3f(0.0);
    var acc_caus = vec3f(0.0);
    for (var base = 0u; base < bp.count; base += 64u) {
        let in_tile = load_tile(base, bp.count, li);
        for (var r = 0u; r < rays; r++) {
            let o = ro[r];
            let d = rd[r];
            let seg = rs[r];
            let dt = (seg.y - seg.x) / f32(n);
            // (a segment's step length in its weight; the pixel's ray's at the end)
            let wr = select(rw[r], rw[r] * dt, bounce_segments);
            // Optical depth (density units) of the ray from the segment's start to the current
            // step's start (heterogeneous).
            var tau = 0.0;
            for (var s = 0u; s < n; s++) {
                let t = seg.x + (f32(s) + 0.5) * dt;
                let x = o + d * t;
                var rho = 1.0;
                var tr_cam: vec3f;
                if (bp.heterogeneous != 0u) {
                    rho = grid_density(density_grid, x, lo, hi);
                    tr_cam = exp(-bp.sigma_t.rgb * (tau + 0.5 * rho * dt));
                    tau += rho * dt;
                    if (rho <= 0.0) { continue; }
                } else {
                    tr_cam = exp(-bp.sigma_t.rgb * (t - seg.x));
                }
                var sf = vec3f(0.0);
                var sc = vec3f(0.0);
                for (var k = 0u; k < in_tile; k++) {
                    let v = tile[k];
                    let dv = x - v.pos.xyz;
                    let d2 = dot(dv, dv);
                    let dist = sqrt(d2);
                    if (dist <= 0.0) { continue; }
                    let u = dv / dist;
                    let cos_v = dot(v.nrm.xyz, u);
                    if (cos_v <= 0.0) { continue; }
                    var od: vec3f;
                    if (bp.heterogeneous != 0u) {
                        od = bp.sigma_t.rgb * grid_optical_depth(density_grid, v.pos.xyz, x, lo, hi, BOUNCE_GRID_STEPS);
                    } else {
                        // x is inside the box; so is the whole segment when the VPL is.
                        var len = dist;
                        if (!in_box(v.pos.xyz, lo, hi)) { len = box_length(v.pos.xyz, x, lo, hi); }
                        od = bp.sigma_t.rgb * len;
                    }
                    let g = phase(dot(u, -d)) * cos_v / (PI * (d2 + v.pos.w)) * layer_gain(cos_v * dist, v.pos.w) * exp(-od);
                    sf += v.full.rgb * g;
                    sc += v.caustic.rgb * g;
                }
                acc_full += wr * (rho * tr_cam * sf);
                acc_caus += rho * tr_cam * sc;
            }
        }
    }
    if (rays == 0u) { return; }
    if (bounce_segments) {
        out_full[idx] += vec4f(bp.sigma_s.rgb * acc_full, 0.0);
        return;
    }
    let dt = (rs[0].y - rs[0].x) / f32(n);
    out_full[idx] += vec4f(bp.sigma_s.rgb * acc_full * dt, 0.0);
    out_caustic[idx] += vec4f(bp.sigma_s.rgb * acc_caus * dt, 0.0);
}
