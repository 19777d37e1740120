// Shared WGSL (`#import indirect`): the world-space cache of diffuse interreflection
// (src/indirect/, docs/indirect.md): a hash grid of surface cells, each keyed by its grid cell
// and the dominant axis of its surface normal (so a floor and a wall that meet in one cell
// stay apart), holding the flux of the photons that reached it after at least one diffuse
// bounce, with their flux-weighted mean position and normal.

// `gpu::types::IndirectParams`: one record for the three stages.
struct IndirectParams {
    // The grid's corner (xyz, m) and its cells' side (w, m).
    origin: vec4f,
    // A directional light's photons start on this disk (xyz centre, w radius, m).
    disk: vec4f,
    // The medium's box (w: 0 none, 1 homogeneous, 2 a density grid) and sigma_t (rgb, 1/m).
    lo: vec4f,
    hi: vec4f,
    sigma_t: vec4f,
    // The camera (`indirect_gather`: which side of a surface it sees).
    camera: vec4f,
    // Photons of this light and the seed of their random numbers.
    photons: u32,
    seed: u32,
    // Entries of the hash table (a power of two).
    capacity: u32,
    // Diffuse bounces per photon at most (orders 2 to bounces + 1).
    bounces: u32,
    // Events (surfaces) per photon path at most.
    max_events: u32,
    // `indirect_gather`: the image.
    width: u32,
    height: u32,
    // `indirect_trace`: the light's place in the frame's list (its words in `counters`).
    light_index: u32,
    // `indirect_blend`: the new batch's weight.
    alpha: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Words of one entry of `sums`: r, g, b, the weight (their sum), the weighted position in its
// cell (x, y, z in [0, 1]) and normal ((n + 1) / 2), each a 64-bit fixed-point (low, high) pair.
const IC_SUM_WORDS: u32 = 20u;
// Linear probes of the hash table before a key counts as lost (the table is too full).
const IC_PROBES: u32 = 64u;
// Grid cells per axis at most (9 bits of the key).
const IC_AXIS: i32 = 511;
const IC_NONE: u32 = 0xffffffffu;
// Bounce orders the statistics tell apart (2 to 9; the last holds 9 and up).
const IC_ORDERS: u32 = 8u;
// `counters`: word 0 the deposits lost to a full table, then per light `IC_LIGHT_WORDS` words
// from `IC_COUNTER_BASE`: per order r, g, b as 64-bit fixed-point pairs, then the light's
// fixed-point scale (f32 bits).
const IC_COUNTER_BASE: u32 = 4u;
const IC_LIGHT_WORDS: u32 = 52u;

// The cell that holds x, clamped to the grid.
fn ic_coord(x: vec3f) -> vec3i {
    return clamp(vec3i(floor((x - ip.origin.xyz) / ip.origin.w)), vec3i(0), vec3i(IC_AXIS));
}

// The dominant axis of n and its sign: 0..5 (+x, -x, +y, -y, +z, -z).
fn ic_bucket(n: vec3f) -> u32 {
    let a = abs(n);
    var axis = 2u;
    if (a.x >= a.y && a.x >= a.z) { axis = 0u; } else if (a.y >= a.z) { axis = 1u; }
    return axis * 2u + select(0u, 1u, n[axis] < 0.0);
}

// The unit axis of bucket b.
fn ic_axis(b: u32) -> vec3f {
    var v = vec3f(0.0);
    v[b / 2u] = select(1.0, -1.0, (b & 1u) == 1u);
    return v;
}

// A cell's key (never 0, the empty slot's).
fn ic_key(c: vec3i, bucket: u32) -> u32 {
    return 1u + (u32(c.x) | (u32(c.y) << 9u) | (u32(c.z) << 18u) | (bucket << 27u));
}

fn ic_key_coord(key: u32) -> vec3i {
    let k = key - 1u;
    return vec3i(i32(k & 511u), i32((k >> 9u) & 511u), i32((k >> 18u) & 511u));
}

// The key's first slot (a PCG hash).
fn ic_home(key: u32) -> u32 {
    var s = key * 747796405u + 2891336453u;
    s = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    s = (s >> 22u) ^ s;
    return s & (ip.capacity - 1u);
}

// Fixed-point units per watt of light l's sums: 2^20 per
// watt of its photons' largest nominal flux (intensity times the solid angle it fills, or
// irradiance times the disk, over the photon count), so a deposit keeps 20 bits and a cell
// sums 2^44 photons.
fn ic_scale(l: LightGpu) -> f32 {
    var spread = 4.0 * PI;
    if (l.info.y == LIGHT_SPOT) { spread = 2.0 * PI * (1.0 - cos(l.axis.w)); }
    if (l.info.y == LIGHT_DIRECTIONAL) { spread = PI * ip.disk.w * ip.disk.w; }
    let nominal = max(max(l.power.r, l.power.g), l.power.b) * spread / f32(max(ip.photons, 1u));
    return 1048576.0 / max(nominal, 1e-30);
}
