// Shared WGSL: the environment light's radiance, read exactly as `docs/scene-format.md` and the
// CPU `scene::environment::Environment::lookup` read it. For a unit direction d toward the sky,
// the map is read at R_y(-angle) d, at u = 0.5 + atan2(x, -z) / 2pi, v = acos(y) / pi (texel
// (0, 0) top-left), bilinearly between texel centres, wrapping around in u and clamped in v.
// Reads the scene group's `env_map` (shared/scene.wgsl: linear radiance, Rgba32Float, loaded
// with textureLoad: no sampler, no filterable-float feature); `rot` is
// (cos angle, sin angle, 1 if the scene has an environment else 0, unused). Imported by
// composite.

fn env_radiance(d_world: vec3f, rot: vec4f) -> vec3f {
    if (rot.z <= 0.0) { return vec3f(0.0); }
    let d = normalize(d_world);
    let m = vec3f(rot.x * d.x - rot.y * d.z, d.y, rot.y * d.x + rot.x * d.z);
    let u = 0.5 + atan2(m.x, -m.z) / (2.0 * PI);
    let v = acos(clamp(m.y, -1.0, 1.0)) / PI;
    let size = vec2i(textureDimensions(env_map));
    let x = u * f32(size.x) - 0.5;
    let y = v * f32(size.y) - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xa = ((i32(x0) % size.x) + size.x) % size.x;
    let xb = (xa + 1) % size.x;
    let ya = clamp(i32(y0), 0, size.y - 1);
    let yb = clamp(i32(y0) + 1, 0, size.y - 1);
    let top = mix(textureLoad(env_map, vec2i(xa, ya), 0).rgb, textureLoad(env_map, vec2i(xb, ya), 0).rgb, fx);
    let bottom = mix(textureLoad(env_map, vec2i(xa, yb), 0).rgb, textureLoad(env_map, vec2i(xb, yb), 0).rgb, fx);
    return mix(top, bottom, fy);
}
