// Stage: composite. The final image: shaded diffuse surfaces where the camera sees them, and
// for specular surfaces image-space reflection and refraction (Wyman 2005; Wyman & Nichols 2009
// section 3.1): the camera ray refracts at the front surface (camera front buffer), exits at the
// back surface found in the camera back buffer (tangent-plane intersection, re-projected a few
// times), and the exit ray and the reflected ray find the diffuse surface they hit by an
// iterative screen-space search in the camera receiver buffer; what they find is weighted by the
// Fresnel terms. Rays that leave the screen see the black background.

struct CompositeParams {
    world_to_clip: mat4x4f,
    camera: vec4f,
    width: u32,
    height: u32,
    _pad0: u32,
    _pad1: u32,
}

@group(0) @binding(0) var<uniform> cp: CompositeParams;
@group(0) @binding(1) var recv_pos: texture_2d<f32>;
@group(0) @binding(2) var recv_nrm: texture_2d<f32>;
@group(0) @binding(3) var spec_pos: texture_2d<f32>;
@group(0) @binding(4) var spec_nrm: texture_2d<f32>;
@group(0) @binding(5) var back_pos: texture_2d<f32>;
@group(0) @binding(6) var back_nrm: texture_2d<f32>;
@group(0) @binding(7) var<storage, read> materials: array<MaterialGpu>;
@group(0) @binding(8) var<storage, read> radiance: array<vec4f>;
@group(0) @binding(9) var<storage, read> caustic_in: array<vec4f>;
@group(0) @binding(10) var<storage, read_write> out_full: array<vec4f>;
@group(0) @binding(11) var<storage, read_write> out_caustic: array<vec4f>;

fn to_pixel(p: vec3f) -> vec3f {
    let c = cp.world_to_clip * vec4f(p, 1.0);
    if (c.w <= 0.0) { return vec3f(-1.0); }
    let ndc = c.xyz / c.w;
    if (abs(ndc.x) > 1.0 || abs(ndc.y) > 1.0) { return vec3f(-1.0); }
    return vec3f((ndc.x * 0.5 + 0.5) * f32(cp.width), (0.5 - ndc.y * 0.5) * f32(cp.height), 1.0);
}

fn pix(q: vec2f) -> vec2i {
    return clamp(vec2i(floor(q)), vec2i(0), vec2i(i32(cp.width) - 1, i32(cp.height) - 1));
}

// Radiance of the diffuse surface hit by the ray o + t d, by screen-space search.
fn trace_receivers(o: vec3f, d: vec3f) -> vec3f {
    var t = -1.0;
    var p = o + d * 0.05;
    for (var it = 0u; it < 16u; it++) {
        let q = to_pixel(p);
        if (q.z < 0.0) { return vec3f(0.0); }
        let px = pix(q.xy);
        let r = textureLoad(recv_pos, px, 0);
        if (r.w < 0.0) { return vec3f(0.0); }
        let n = textureLoad(recv_nrm, px, 0).xyz;
        let dn = dot(d, n);
        var t_new = length(r.xyz - o);
        if (abs(dn) > 1e-3) { t_new = dot(r.xyz - o, n) / dn; }
        if (t_new <= 0.0) { return vec3f(0.0); }
        if (abs(t_new - t) <= 1e-4 * t_new) {
            return radiance[u32(px.y) * cp.width + u32(px.x)].rgb;
        }
        t = t_new;
        p = o + t * d;
    }
    let q = to_pixel(p);
    if (q.z < 0.0) { return vec3f(0.0); }
    let px = pix(q.xy);
    return radiance[u32(px.y) * cp.width + u32(px.x)].rgb;
}

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (gid.x >= cp.width || gid.y >= cp.height) { return; }
    let idx = gid.y * cp.width + gid.x;
    let px = vec2i(gid.xy);
    let r = textureLoad(recv_pos, px, 0);
    let s = textureLoad(spec_pos, px, 0);
    let cam = cp.camera.xyz;
    let spec_in_front = s.w >= 0.0 && (r.w < 0.0 || length(s.xyz - cam) < length(r.xyz - cam));
    if (!spec_in_front) {
        out_full[idx] = radiance[idx];
        out_caustic[idx] = caustic_in[idx];
        return;
    }
    out_caustic[idx] = vec4f(0.0);
    let mat = materials[u32(s.w)];
    let p = s.xyz;
    let d = normalize(p - cam);
    var n = normalize(textureLoad(spec_nrm, px, 0).xyz);
    if (dot(n, d) > 0.0) { n = -n; }
    let cos1 = -dot(d, n);
    let refl = reflect(d, n);
    var l = vec3f(0.0);
    if (mat.kind.x == KIND_MIRROR) {
        l = mat.a.rgb * trace_receivers(p, refl);
    } else if (mat.kind.x == KIND_CONDUCTOR) {
        l = fresnel_conductor(cos1, mat.a.rgb, mat.b.rgb) * trace_receivers(p, refl);
    } else if (mat.kind.x == KIND_DIELECTRIC) {
        let ior = mat.a.x;
        let ext = mat.a.y;
        let f1 = fresnel_dielectric(cos1, ior / ext);
        l = f1 * trace_receivers(p, refl);
        let t1 = refract_dir(d, n, ext / ior);
        // Exit point: the refracted ray against the back buffer's tangent planes.
        var q = vec2f(gid.xy) + 0.5;
        var exit = vec4f(0.0);
        for (var k = 0u; k < 4u; k++) {
            let bp = textureLoad(back_pos, pix(q), 0);
            if (bp.w < 0.0) { break; }
            let bn = normalize(textureLoad(back_nrm, pix(q), 0).xyz);
            let dn = dot(t1.xyz, bn);
            if (abs(dn) < 1e-4) { break; }
            let tt = dot(bp.xyz - p, bn) / dn;
            if (tt <= 0.0) { break; }
            exit = vec4f(p + tt * t1.xyz, 1.0);
            let qq = to_pixel(exit.xyz);
            if (qq.z < 0.0) { break; }
            q = qq.xy;
        }
        if (exit.w > 0.5) {
            var n2 = normalize(textureLoad(back_nrm, pix(q), 0).xyz);
            if (dot(n2, t1.xyz) < 0.0) { n2 = -n2; }
            let cos2 = dot(t1.xyz, n2);
            let t2 = refract_dir(t1.xyz, -n2, ior / ext);
            if (t2.w > 0.5) {
                let f2 = fresnel_dielectric(cos2, ext / ior);
                l += (1.0 - f1) * (1.0 - f2) * trace_receivers(exit.xyz, t2.xyz);
            }
        }
    }
    out_full[idx] = vec4f(l, 0.0);
}
