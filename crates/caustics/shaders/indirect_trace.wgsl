// Stage: indirect_trace. Diffuse interreflection, the photons' part (src/indirect/,
// docs/indirect.md): `ip.photons` photons of one light on random walks (shared/photon_walk.wgsl,
// emitted as the medium's multiple-scattering photons are), exact through every specular
// surface (dielectrics choose reflection or refraction by Fresnel, mirrors and conductors
// reflect with their colour) and bouncing off diffuse surfaces by the cosine with Russian
// roulette by albedo, up to `ip.bounces` diffuse bounces. At every diffuse hit after the
// first (the first is the direct light and the caustic maps' light, drawn exactly elsewhere)
// the photon's flux, position and normal (turned toward where it came from) are added to the
// cache cell that holds the point (shared/indirect.wgsl; 64-bit fixed point: the same sums in
// any order). Outside dielectrics a medium attenuates the photon (its transmittance: light it
// scatters is the medium features' own).

#import shapes
#import raytrace
#import medium
#import scene
#import photon_walk
#import indirect

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> ip: IndirectParams;
// Per slot, the key of the cell it holds (0: empty).
@group(0) @binding(2) var<storage, read_write> keys: array<atomic<u32>>;
// Per slot, `IC_SUM_WORDS` fixed-point words.
@group(0) @binding(3) var<storage, read_write> sums: array<atomic<u32>>;
// The statistics (`IC_COUNTER_BASE`, shared/indirect.wgsl): lost deposits, flux per order.
@group(0) @binding(4) var<storage, read_write> counters: array<atomic<u32>>;

// Steps of a density grid's transmittance march per path segment.
const IC_GRID_STEPS: u32 = 32u;

// The slot of `key`, claimed if new; IC_NONE when `IC_PROBES` slots are taken by others.
fn ic_insert(key: u32) -> u32 {
    var s = ic_home(key);
    var probes = 0u;
    var tries = 0u;
    loop {
        if (probes >= IC_PROBES || tries >= 4u * IC_PROBES) { return IC_NONE; }
        tries++;
        let r = atomicCompareExchangeWeak(&keys[s], 0u, key);
        if (r.exchanged || r.old_value == key) { return s; }
        // A weak exchange may fail spuriously on an empty slot: try it again.
        if (r.old_value == 0u) { continue; }
        probes++;
        s = (s + 1u) & (ip.capacity - 1u);
    }
    return IC_NONE;
}

fn add_fixed(word: u32, v: f32) {
    if (!(v > 0.0)) { return; }
    let w = fixed_words(v);
    let old = atomicAdd(&sums[word], w.x);
    let hi = w.y + fixed_carry(old, w.x);
    if (hi != 0u) { atomicAdd(&sums[word + 1u], hi); }
}

fn count_fixed(word: u32, v: f32) {
    if (!(v > 0.0)) { return; }
    let w = fixed_words(v);
    let old = atomicAdd(&counters[word], w.x);
    let hi = w.y + fixed_carry(old, w.x);
    if (hi != 0u) { atomicAdd(&counters[word + 1u], hi); }
}

// The photon's flux reaching a diffuse surface at bounce order `order` (2: after one diffuse
// bounce), for the statistics.
fn count_order(order: u32, flux: vec3f) {
    let base = IC_COUNTER_BASE + ip.light_index * IC_LIGHT_WORDS + (min(order, IC_ORDERS + 1u) - 2u) * 6u;
    let f = flux * ic_scale(light);
    for (var k = 0u; k < 3u; k++) { count_fixed(base + k * 2u, f[k]); }
}

fn deposit(x: vec3f, n: vec3f, flux: vec3f) {
    let c = ic_coord(x);
    let s = ic_insert(ic_key(c, ic_bucket(n)));
    if (s == IC_NONE) {
        atomicAdd(&counters[0], 1u);
        return;
    }
        let base = s * IC_SUM_WORDS;
    let f = flux * ic_scale(light);
    let w = f.r + f.g + f.b;
    let frac = clamp((x - ip.origin.xyz) / ip.origin.w - vec3f(c), vec3f(0.0), vec3f(1.0));
    let nn = n * 0.5 + 0.5;
    for (var k = 0u; k < 3u; k++) {
        add_fixed(base + k * 2u, f[k]);
        add_fixed(base + 8u + k * 2u, w * frac[k]);
        add_fixed(base + 14u + k * 2u, w * nn[k]);
    }
    add_fixed(base + 6u, w);
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u, @builtin(num_workgroups) nwg: vec3u) {
    let i = gid.y * nwg.x * 64u + gid.x;
    if (i == 0u) {
        atomicStore(&counters[IC_COUNTER_BASE + ip.light_index * IC_LIGHT_WORDS + IC_ORDERS * 6u], bitcast<u32>(ic_scale(light)));
    }
    if (i >= ip.photons) { return; }
    walk_seed(i, ip.seed);
    let start = walk_emit(ip.disk, ip.photons);
    var o = start.o;
    var d = start.d;
    var flux = start.flux;
    let lo = ip.lo.xyz;
    let hi = ip.hi.xyz;
    var in_medium = true;
    var diffuse = 0u;
    for (var ev = 0u; ev < ip.max_events; ev++) {
        if (!any(flux > vec3f(0.0))) { return; }
        let h = scene_hit(o, d, 1e30);
        if (in_medium && ip.lo.w > 0.0) {
            let seg = box_clip(o, d, h.t, lo, hi);
            if (seg.y > seg.x) {
                let a = o + d * seg.x;
                let b = o + d * seg.y;
                var od = ip.sigma_t.rgb * (seg.y - seg.x);
                if (ip.lo.w > 1.5) { od = ip.sigma_t.rgb * grid_optical_depth(density_grid, a, b, lo, hi, IC_GRID_STEPS); }
                flux *= exp(-od);
            }
        }
        if (h.object == INVALID) { return; }
        flux *= walk_absorbed(h.t);
        if (materials[h.object].kind.x == KIND_DIFFUSE) {
            if (diffuse >= 1u) {
                // The normal toward where the photon came from.
                let ns = select(-h.ns, h.ns, dot(d, h.ng) < 0.0);
                deposit(h.p, ns, flux);
                count_order(diffuse + 1u, flux);
            }
            if (diffuse >= ip.bounces) { return; }
            diffuse++;
        }
        if (!walk_surface(h, &o, &d, &flux, &in_medium)) { return; }
    }
}
