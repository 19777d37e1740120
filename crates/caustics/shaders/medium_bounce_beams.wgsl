// Stage: medium_bounce_beams. The light one light's beams (the volume caustic, `beam_refine`)
// scatter in the medium, gathered into point emitters ("beam VPLs") for
// `medium_bounce_surfaces`, which lights the diffuse surfaces the camera sees with it
// (light -> glass -> fog -> floor -> camera: the floor around a volume caustic glows with it).
//
// Each listed beam is sampled at BEAM_EMIT_SAMPLES midpoints of equal height along the line of
// its barycentre (base c = the corners' mean, travel s = the mean of the edges' directions
// scaled to unit height, to the mean of the edges' end heights). A sample x inside the medium's
// box scatters
//   flux = sigma_s(x) * F * exp(-sigma_t * (tau_pre + tau(c -> x))) * dl
// (F the beam's flux, tau_pre the mean optical depth from the light to its base, dl the
// sample's length along the line), leaving by the phase function about the line's direction.
// Samples are binned into point emitters (shared/medium_emit.wgsl: the
// `medium_bounce_grid`^2 blocks of each light face, 16 slices of distance from the light).
// `emit_pass` 0, per beam: the samples' range of distances; 1, per beam: the sums; 2, per bin:
// the emitters.

#import beams
#import medium
#import beam_medium
#import medium_bounce
#import medium_emit
#import scene

@group(0) @binding(0) var<storage, read> bp: BeamParams;
@group(0) @binding(1) var<uniform> light: LightGpu;
@group(0) @binding(2) var<uniform> ep: EmitParams;
@group(0) @binding(3) var<storage, read> beams: array<BeamGpu>;
@group(0) @binding(4) var<storage, read> order: array<u32>;
@group(0) @binding(5) var<storage, read> stats: array<u32>;
// Per bin EMIT_WORDS words; then the range's two words.
@group(0) @binding(6) var<storage, read_write> sums: array<atomic<u32>>;
@group(0) @binding(7) var<storage, read_write> vpls: array<Vpl>;

override emit_pass: u32 = 0u;
// The beams' landing emitters instead (`emit_pass` 1 and 2, one slice per block; where the
// surface caustic is the beams', so the lights' caustic maps are empty): each beam's light where
// it lands on a diffuse surface, times the albedo, as a Lambertian emitter (the end triangle's
// three corners, a third of the flux each, so a bin's spread covers it), for the VPLs' passes
// (`medium_bounce`: the floor caustic's glow; `medium_bounce_glow`).
override emit_landing: bool = false;

const BEAM_EMIT_SAMPLES: u32 = 8u;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    if (emit_pass == 2u) {
        emit_resolve(gid.x);
        return;
    }
    let count = min(stats[1u + BS_ORDERED], bp.capacity);
    if (gid.x >= count) { return; }
    let b = beams[order[gid.x]];
    if (all(b.flux.rgb <= vec3f(0.0))) { return; }
    // The line of the beam's barycentre: base c, travel s (per unit height), samples dy apart
    // in height up to the mean of the edges' end heights.
    let bs = beam_space(b);
    let c = (bs.v[0] + bs.v[1] + bs.v[2]) / 3.0;
    let s = (bs.s[0] + bs.s[1] + bs.s[2]) / 3.0;
    let dy = max((bs.yend.x + bs.yend.y + bs.yend.z) / 3.0, 0.0) / f32(BEAM_EMIT_SAMPLES);
    if (!(dy > 0.0)) { return; }
    let pre = (b.v0.w + b.v1.w + b.v2.w) / 3.0;
    if (emit_landing) {
        land(b, bs, c, s, dy * f32(BEAM_EMIT_SAMPLES), pre);
        return;
    }
    let dl = dy * length(s);
    let dir = normalize(s);
    for (var i = 0u; i < BEAM_EMIT_SAMPLES; i++) {
        let x = c + s * ((f32(i) + 0.5) * dy);
        if (any(x < ep.lo.xyz) || any(x > ep.hi.xyz)) { continue; }
        if (emit_pass == 0u) {
            emit_range(x);
            continue;
        }
        let tr = exp(-bp.sigma_t.rgb * (pre + beam_depth(c, x)));
        emit_deposit(x, bp.sigma_s.rgb * beam_density(x) * b.flux.rgb * tr * dl, dir);
    }
}

// The light beam b reflects where it lands (end height y_end of the barycentre's line c + y s),
// deposited at its end triangle's corners.
fn land(b: BeamGpu, bs: BeamSpace, c: vec3f, s: vec3f, y_end: f32, pre: f32) {
    let obj = b.info.x;
    if (obj == INVALID) { return; }
    let m = materials[obj];
    if (m.kind.x != KIND_DIFFUSE || all(m.a.rgb <= vec3f(0.0))) { return; }
    let x = c + s * y_end;
    let e0 = bs.v[0] + b.d0.xyz * b.d0.w;
    let e1 = bs.v[1] + b.d1.xyz * b.d1.w;
    let e2 = bs.v[2] + b.d2.xyz * b.d2.w;
    var n = cross(e1 - e0, e2 - e0);
    if (!(dot(n, n) > 0.0)) { return; }
    n = normalize(n);
    if (dot(n, s) > 0.0) { n = -n; }
    let flux = m.a.rgb * b.flux.rgb * exp(-bp.sigma_t.rgb * (pre + beam_depth(c, x))) / 3.0;
    emit_deposit(e0, flux, n);
    emit_deposit(e1, flux, n);
    emit_deposit(e2, flux, n);
}
