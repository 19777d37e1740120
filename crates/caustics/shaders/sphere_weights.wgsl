// Stage: sphere_weights. Caustic spheres under an environment: the records of a frame weighted
// by the environment regions' visibility from their object (`sphere_visibility_sum`'s buffer),
// on the GPU so that the frame never waits for it. A record whose base.w indexes `visibility`
// carries the light's irradiance E (rgb) and its blend weight w (irradiance.w); it becomes
// ((E v) w) as `CausticSpheres`' CPU records computed it (`GpuSpheres::records`), and is dropped
// where E v is black, as the CPU dropped it. Other records pass through. One invocation, in
// order: `weighted` keeps every record (dropped ones black: they add nothing to
// `sphere_compile`'s sums), `compact` only the kept ones, and `weight_counts` their number and
// the gather's full-filter threshold (a 32nd of their irradiance luminance, as
// `record_gather` computes it on the CPU), copied into the passes' parameters.

#import sphere_table

@group(0) @binding(0) var<storage, read> candidates: array<SphereRecord>;
@group(0) @binding(1) var<storage, read> visibility: array<f32>;
@group(0) @binding(2) var<storage, read_write> weighted: array<SphereRecord>;
@group(0) @binding(3) var<storage, read_write> compact: array<SphereRecord>;
// [0]: records kept, [1]: the f32 bits of the full-filter threshold.
@group(0) @binding(4) var<storage, read_write> weight_counts: array<u32>;
// Declared for sphere_table's lookup (not used here).
@group(0) @binding(5) var<storage, read> table: array<vec4u>;

@compute @workgroup_size(1)
fn main() {
    var kept = 0u;
    var lum = 0.0;
    let n = arrayLength(&candidates);
    for (var i = 0u; i < n; i++) {
        var r = candidates[i];
        var keep = true;
        if (r.base.w != INVALID) {
            let e = r.irradiance.rgb * visibility[r.base.w];
            keep = max(max(e.r, e.g), e.b) > 0.0;
            r.irradiance = vec4f(select(vec3f(0.0), e * r.irradiance.w, keep), 0.0);
        }
        r.base.w = 0u;
        weighted[i] = r;
        if (keep) {
            compact[kept] = r;
            kept += 1u;
            lum += r.irradiance.r + r.irradiance.g + r.irradiance.b;
        }
    }
    weight_counts[0] = kept;
    weight_counts[1] = bitcast<u32>(lum / 32.0);
}
