// Stage: medium_ms_view. The medium's multiply scattered light seen by the camera: per pixel,
// along the camera ray's segment in the box up to the first surface it sees (as
// `medium_scatter`), a midpoint rule in `mp.steps` steps of T(camera -> x) j(x), j the grid's
// emission (W / (m^3 sr): the cells' scattered power, trilinear between cell centres, over the
// cell volume and 4 pi: isotropic; orders two and up lose most of a Henyey-Greenstein lobe's
// direction), added to the full image after `medium_scatter` attenuated it. With
// `ms_segments` (indirect over `composite`'s list of specular pixels) the same march runs along
// the segments `composite` kept of the paths beyond each pixel's specular surface (the fog seen
// through glass and in mirrors), weighted by the path's weight.

#import medium
#import scene
#import medium_multiple

@group(0) @binding(0) var<uniform> mp: MsParams;
@group(0) @binding(1) var<storage, read> cells: array<vec4f>;
@group(0) @binding(2) var recv_pos: texture_2d<f32>;
@group(0) @binding(3) var spec_pos: texture_2d<f32>;
@group(0) @binding(4) var<storage, read_write> out_full: array<vec4f>;
// `composite`'s list of specular pixels, its length (count[3]) and the segments it kept.
@group(0) @binding(5) var<storage, read> spec_list: array<u32>;
@group(0) @binding(6) var<storage, read> spec_count: array<u32, 4>;
@group(0) @binding(7) var<storage, read> segments: array<EyeSegment>;
override ms_segments: bool = false;

fn cell_at(c: vec3i) -> vec3f {
    let d = vec3i(mp.dims.xyz);
    return cells[u32(c.x + d.x * (c.y + d.y * c.z))].rgb;
}

// The cells' power at x, trilinear between their centres, clamped to the outermost ones.
fn power_at(x: vec3f) -> vec3f {
    let dims = vec3i(mp.dims.xyz);
    let p = (x - mp.lo.xyz) / (mp.hi.xyz - mp.lo.xyz) * vec3f(dims) - 0.5;
    let f = floor(p);
    let t = p - f;
    let m = dims - 1;
    let a = clamp(vec3i(f), vec3i(0), m);
    let b = clamp(vec3i(f) + 1, vec3i(0), m);
    let c00 = mix(cell_at(vec3i(a.x, a.y, a.z)), cell_at(vec3i(b.x, a.y, a.z)), t.x);
    let c10 = mix(cell_at(vec3i(a.x, b.y, a.z)), cell_at(vec3i(b.x, b.y, a.z)), t.x);
    let c01 = mix(cell_at(vec3i(a.x, a.y, b.z)), cell_at(vec3i(b.x, a.y, b.z)), t.x);
    let c11 = mix(cell_at(vec3i(a.x, b.y, b.z)), cell_at(vec3i(b.x, b.y, b.z)), t.x);
    return mix(mix(c00, c10, t.y), mix(c01, c11, t.y), t.z);
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(workgroup_id) wg: vec3u, @builtin(local_invocation_index) li: u32) {
    if (ms_segments) {
        along_segments(wg.x * 64u + li);
        return;
    }
    if (gid.x >= mp.width || gid.y >= mp.height) { return; }
    let cam = mp.camera.xyz;
    let d = pixel_ray(mp.clip_to_world, cam, gid.xy, mp.width, mp.height);
    let t_max = first_surface(recv_pos, spec_pos, vec2i(gid.xy), cam);
    let seg = box_clip(cam, d, t_max, mp.lo.xyz, mp.hi.xyz);
    if (seg.y <= seg.x) { return; }
    let idx = gid.y * mp.width + gid.x;
    out_full[idx] += vec4f(march(cam, d, seg), 0.0);
}

fn along_segments(i: u32) {
    if (i >= spec_count[3]) { return; }
    var add = vec3f(0.0);
    for (var k = 0u; k < EYE_SEGMENTS; k++) {
        let e = segments[i * EYE_SEGMENTS + k];
        if (!(e.o.w > 0.0)) { continue; }
        let d = segment_dir(e);
        let seg = box_clip(e.o.xyz, d, e.o.w, mp.lo.xyz, mp.hi.xyz);
        if (seg.y <= seg.x) { continue; }
        add += e.w * march(e.o.xyz, d, seg);
    }
    let idx = spec_list[i];
    out_full[idx] += vec4f(add, 0.0);
}

// The grid's light scattered toward o along o + t d over `seg` (its part in the box).
fn march(cam: vec3f, d: vec3f, seg: vec2f) -> vec3f {
    let n = max(mp.steps, 1u);
    let dt = (seg.y - seg.x) / f32(n);
    let to_j = 1.0 / (ms_cell_volume() * 4.0 * PI);
    var tau = vec3f(0.0);
    var l = vec3f(0.0);
    for (var i = 0u; i < n; i++) {
        let x = cam + d * (seg.x + (f32(i) + 0.5) * dt);
        var rho = 1.0;
        if (mp.dims.w != 0u) { rho = grid_density(density_grid, x, mp.lo.xyz, mp.hi.xyz); }
        // The optical depth to the step's midpoint: the steps before, and half of this one.
        let half = 0.5 * rho * mp.sigma_t.rgb * dt;
        l += exp(-(tau + half)) * power_at(x) * (to_j * dt);
        tau += 2.0 * half;
    }
    return l;
}
