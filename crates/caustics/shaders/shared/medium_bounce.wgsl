// Shared WGSL (`#import medium_bounce`): the virtual point lights of the `medium_bounce_*`
// stages (src/medium_bounce.rs): their parameters, their record, and the gathers' tiles.

// `medium_bounce_lights` and `medium_bounce_shafts` (`gpu::types::BounceLightParams`).
struct BounceLightParams {
    // The medium's box and sigma_t (1/m).
    lo: vec4f,
    hi: vec4f,
    sigma_t: vec4f,
    // VPL blocks per side of a face.
    grid: u32,
    shadow_size: u32,
    // 1: heterogeneous (density grid), 0: homogeneous.
    heterogeneous: u32,
    // Heterogeneous: ray-march steps of the transmittance toward the light.
    light_steps: u32,
    // This light's first VPL.
    offset: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
    // rgb = sigma_s (1/m; read by `medium_bounce_shafts`)
    sigma_s: vec4f,
}

// A virtual point light (`gpu::types::VplGpu`).
struct Vpl {
    // xyz = position, w = squared radius (m^2)
    pos: vec4f,
    // xyz = unit normal of the emitting side (shaft VPLs: the light's direction of travel)
    nrm: vec4f,
    // rgb = flux (W)
    full: vec4f,
    // rgb = the part of it that arrived as caustic light (W)
    caustic: vec4f,
}

// Steps of the optical-depth march from a VPL to a point of a heterogeneous medium.
const BOUNCE_GRID_STEPS: u32 = 4u;

// The gathers (`medium_bounce`, `medium_bounce_surfaces`) read the VPLs 64 at a time.
var<workgroup> tile: array<Vpl, 64>;
var<workgroup> scan: array<u32, 64>;

// Loads VPLs [base, base + 64) of the stage's `vpls` (a storage array<Vpl> each gather declares)
// into `tile`, the lit ones packed to the front in index order (an inclusive prefix sum over
// the 64: the loops skip the dark ones, a spot's spill face, blocks outside its cone), and
// returns how many are lit. Every invocation of the workgroup calls it (it has barriers).
fn load_tile(base: u32, count: u32, li: u32) -> u32 {
    workgroupBarrier();
    var mine = Vpl(vec4f(0.0), vec4f(0.0), vec4f(0.0), vec4f(0.0));
    if (base + li < count) { mine = vpls[base + li]; }
    let lit = any(mine.full.rgb > vec3f(0.0));
    scan[li] = u32(lit);
    workgroupBarrier();
    for (var o = 1u; o < 64u; o = o * 2u) {
        var v = scan[li];
        if (li >= o) { v += scan[li - o]; }
        workgroupBarrier();
        scan[li] = v;
        workgroupBarrier();
    }
    if (lit) { tile[scan[li] - 1u] = mine; }
    let n = scan[63];
    workgroupBarrier();
    return n;
}

// Whether p lies in the box lo..hi.
fn in_box(p: vec3f, lo: vec3f, hi: vec3f) -> bool {
    return all(p >= lo) && all(p <= hi);
}

// The near field of an emitters' sum: the gain by which an emitter's regularized kernel is
// divided at height h above the plane of what it lights (`medium_bounce_surfaces`: the
// surface's plane; `medium_bounce`: a surface VPL's own plane, for the fog above it). A layer of
// emitters parallel to that plane at height h, each spread over r2 (the VPL's `pos.w`), summed
// with the kernel cos / (d^2 + r2) (cos at the plane, unregularized), gives g(h / r) =
// (h / r) atan(r / h) of what the continuous layer it stands for gives (integrate
// h / (sqrt(s^2 + h^2) (s^2 + h^2 + r^2)) over the layer, s the distance in it): 0.65 at
// h = 0.67 r (the slice of a shaft just above the floor), 0.93 at h = 2 r, 1 far away. A lit
// floor is such a layer of surface VPLs, and fog fills the space around a surface with layers
// of emitters (binned by light-face block and slice), so each emitter's light is divided by g
// of its own height (1 / g also restores the total a single emitter sends onto an unbounded
// plane). Bounded at 1 / LAYER_G_MIN for emitters nearly in the plane. Measured
// (docs/benchmarks.md, "The emitters' near field"): the lit-floor test's floor 0.978 -> 0.996
// of the reference's, the sun over a fog floor 0.955 -> 0.99.
const LAYER_G_MIN: f32 = 0.1;
fn layer_gain(h: f32, r2: f32) -> f32 {
    if (r2 <= 0.0) { return 1.0; }
    let t = h / sqrt(r2);
    return 1.0 / max(t * atan(1.0 / max(t, 1e-6)), LAYER_G_MIN);
}
