// Shared WGSL (`#import beams`): volume caustics by adaptive beam tracing (Liktor & Dachsbacher
// 2011; docs/beams.md, "Volume caustics from beams"). The records the beam stages share
// (src/gpu/types.rs mirrors them) and the exact trace of one beam edge.

struct BeamParams {
    // The camera (pixel rays) and the medium (box, coefficients).
    clip_to_world: mat4x4f,
    camera: vec4f,
    lo: vec4f,
    hi: vec4f,
    // rgb = sigma_s (1/m), w = Henyey-Greenstein g
    sigma_s: vec4f,
    // rgb = sigma_t (1/m)
    sigma_t: vec4f,
    // Base grid B (cells per face side), refinement levels L, light faces, specular interactions
    // followed per edge.
    grid: u32,
    levels: u32,
    faces: u32,
    max_depth: u32,
    // Split thresholds (BeamSettings): cos of the normal angle, relative depth difference,
    // energy (beam flux over the face's flux at the light's peak intensity, times convergence), camera (beam width / distance, radians).
    normal_cos: f32,
    depth_rel: f32,
    energy: f32,
    camera_size: f32,
    // Points per pixel side on the surface's tangent plane (beam_surface: the box pixel filter).
    surface_samples: u32,
    // Beam records the beam buffer holds; slots of the hierarchy (all levels, one branch).
    capacity: u32,
    slots: u32,
    // Quadrature points per piece of a camera ray inside a beam.
    samples: u32,
    width: u32,
    height: u32,
    // bit 0: trace the branches reflected at the first dielectric surface and inside it too.
    flags: u32,
    // Camera rays per pixel side (beam_gather: the box pixel filter).
    pixel_samples: u32,
    // Split threshold (BeamSettings::linearity_threshold): the centroid's light off the beam's
    // line, over the beam's width (beam_refine's nonlinearity); 0: off.
    linearity: f32,
    // The residual branch's least probability of reflecting at a dielectric interface (it
    // reflects with max(F, residual): BeamSettings::residual; 0: no residual branch).
    residual: f32,
    // The energy cutoff (BeamSettings::cutoff): σs · the phase function's largest value / the
    // cutoff radiance (m/W); a diverging beam's tail is dropped where its light, seen along
    // it, is at most the cutoff (beam_trace's `cut_tail`); 0: off.
    cut: f32,
    _pad2: u32,
    // The inverse of clip_to_world (beam_surface: a beam's end in the image).
    world_to_clip: mat4x4f,
}

// Beams per slot of the hierarchy: transmitted, reflected at the first surface, reflected once
// inside, reflected at the second dielectric's surface, reflected once inside it, and the
// residual branch (beam_trace.wgsl, `trace_edge`).
const BEAM_BRANCHES: u32 = 6u;
// The residual branch: the light reflected partially at an interface no other branch reflects
// at (the fifth or later, or at two or more), its Fresnel choices drawn at random per triangle
// of the grid (beam_trace.wgsl, `trace_edge`).
const BEAM_RESIDUAL: u32 = 5u;
// Beams per branch: layer 0 the path's last segment, layer 1 the segment before it where the
// light crossed the medium between two specular objects (beam_refine.wgsl, `at_layer`).
const BEAM_LAYERS: u32 = 2u;
// Beams per branch and layer: a last-level triangle whose corners take different paths gives
// one beam per path, and one more for the light on paths none of its corners takes (its
// orphans: beam_shrink.wgsl).
const BEAM_PARTS: u32 = 4u;
// Beams per slot (their places: slot x BEAM_KINDS + (branch x BEAM_LAYERS + layer) x
// BEAM_PARTS + part).
const BEAM_KINDS: u32 = 48u;
// Slot entries per thread of beam_order_runs (the beams' list in slot order).
const BEAM_ORDER_RUN: u32 = 4096u;

// A beam's hull on the image (beam_hull, drawn by beam_raster and beam_surface_raster), one of
// BEAM_HULL_PARTS per beam (the beam split at the foci between its ends): info.x its vertices
// (a convex polygon, 3 to BEAM_HULL_MAX; 0: nothing to draw), info.y the beam's index in the
// beam buffer, info.zw the part's heights over the beam's base (f32 bits, from and to); p the
// vertices in pixels (two per vec4: p[i / 2].xy, .zw).
struct BeamHull {
    info: vec4u,
    p: array<vec4f, 6>,
}
const BEAM_HULL_MAX: u32 = 12u;
const BEAM_HULL_PARTS: u32 = 3u;
// Vertices per instance of beam_raster's draw: a fan of BEAM_HULL_MAX - 2 triangles (those past
// a hull's vertex count are degenerate and draw nothing).
const BEAM_HULL_VERTICES: u32 = 3u * (BEAM_HULL_MAX - 2u);

// One refinement level's dispatch.
struct BeamLevel {
    level: u32,
    // Slot offset of this level (and its work list) in the hierarchy.
    offset: u32,
    // Slot offset of the next level.
    next_offset: u32,
    // Level-0 triangles (faces x 2 B^2).
    base_count: u32,
}

// A triangle of the projected grid (light NDC of its vertices), its id within its level
// (level 0: face x 2B^2 + cell x 2 + half; a child: parent x 4 + k) and face.
struct BeamTri {
    a: vec2f,
    b: vec2f,
    c: vec2f,
    id: u32,
    face: u32,
}

// A part of a last-level triangle whose corners' edges take different paths on one branch and
// layer (beam_refine queues it, beam_shrink makes its beam): the triangle's corners a, b, c
// (light NDC on light face `face`), its slot of the hierarchy and its level, and
// kind = branch | layer << 4 | case << 8 | part << 12 (beam_refine's `part_applies`; case
// PART_ORPHANS: a triangle none of whose corners takes a caustic path on the branch while
// their paths differ, whose light inside, if any, goes to its orphans' beam alone).
struct BeamPart {
    a: vec2f,
    b: vec2f,
    c: vec2f,
    face: u32,
    slot: u32,
    level: u32,
    kind: u32,
}

const PART_ORPHANS: u32 = 6u;

// The entry of beam_refine's indirect arguments (4 words each; entries 0..6 the levels) that
// holds beam_shrink's dispatch size (words 0 and 1) and the parts queued (word 3).
const PARTS_ARGS: u32 = 7u;
// Parts per workgroup of beam_shrink (its dispatch size in PARTS_ARGS: workgroups x, rows y).
const SHRINK_GROUP_PARTS: u32 = 4u;

// A beam: base vertices v_i (w: the in-medium length of the light's path before v_i), unit
// edge directions d_i (w: distance from v_i to the edge's end on a surface), flux (W, rgb;
// w: the hierarchy level), a bounding sphere of the beam (centre, radius), and info.x the
// object its three edges land on (INVALID: they leave the scene or, on layer 1, end on a
// specular surface; beam_surface lights only that object's points), info.y its branch (bits
// 0-3: 0 transmitted, 1 reflected at the first surface, 2 reflected once inside, 3 and 4 the
// same at a second dielectric, 5 the residual branch: beam_trace), its layer (bits 4-7) and its
// part (beam_shrink; bits 8 up), info.z and info.w the clip heights of edges 1 and 2 (f32 bits;
// edge 0's is 0: `beam_clip`).
struct BeamGpu {
    v0: vec4f,
    v1: vec4f,
    v2: vec4f,
    d0: vec4f,
    d1: vec4f,
    d2: vec4f,
    flux: vec4f,
    bound: vec4f,
    info: vec4u,
}

// Statistics words (u32): 0..7 beams kept per level, 8..15 triangles visited per level,
// 16 beams over the capacity (dropped: an overflow, reported), 17 triangles at the last level
// whose edges disagree and none of whose corners takes a caustic path of the transmitted branch
// (only an orphans-only part's samples find their light),
// 18 beams in the ordered list, 19 beams discarded for grazing bases, 20 beams kept on layer 1
// (between two specular objects), 21 fragments beam_raster shaded, 22 beams kept on the
// residual branch, 23 fragments that added light (the hulls' fill that was needed), 24 beams
// whose diverging tail the energy cutoff dropped, 25 beams dropped for carrying no light.
const BS_KEPT: u32 = 0u;
const BS_VISITED: u32 = 8u;
const BS_OVERFLOW: u32 = 16u;
const BS_INCONSISTENT: u32 = 17u;
const BS_ORDERED: u32 = 18u;
const BS_GRAZING: u32 = 19u;
const BS_LAYER1: u32 = 20u;
const BS_FRAGMENTS: u32 = 21u;
const BS_RESIDUAL: u32 = 22u;
const BS_LIT: u32 = 23u;
const BS_CUT: u32 = 24u;
const BS_DARK: u32 = 25u;
const BS_WORDS: u32 = 32u;

// Twice the signed area of a beam's section at height y over its base, S(y) = q.x + y q.y +
// y^2 q.z (Ernst et al. 2005), from its base vertices v, its edges scaled to unit height s and
// the base's normal.
fn section_area(v: array<vec3f, 3>, s: array<vec3f, 3>, nrm: vec3f) -> vec3f {
    let ka = v[1] - v[0];
    let kb = s[1] - s[0];
    let kc = v[2] - v[0];
    let kd = s[2] - s[0];
    return vec3f(dot(nrm, cross(ka, kc)), dot(nrm, cross(ka, kd) + cross(kb, kc)), dot(nrm, cross(kb, kd)));
}

// The heights of a beam's foci, where its section degenerates (S(y) = 0 for `q` of
// section_area: a beam has two focal lines at most), ascending; -1e30 where there is no root.
// One function for beam_hull, which splits a beam's hull at them, and the scattering integrals,
// which cut there: the same bits in both.
fn beam_foci(q: vec3f, ymax: f32) -> vec2f {
    var r = vec2f(-1e30);
    if (abs(q.z) * ymax * ymax <= 1e-6 * (abs(q.y) * ymax + abs(q.x))) {
        if (q.y != 0.0) { r.x = -q.x / q.y; }
    } else {
        let disc = q.y * q.y - 4.0 * q.z * q.x;
        if (disc >= 0.0) {
            let h = -0.5 * (q.y + select(-1.0, 1.0, q.y >= 0.0) * sqrt(disc));
            r.x = h / q.z;
            if (h != 0.0) { r.y = q.x / h; }
        }
    }
    return vec2f(min(r.x, r.y), max(r.x, r.y));
}

// The plane a beam's points lie beyond (normal, offset): the base's, or for a beam whose edges
// make_beam extended back behind the surface the light leaves (an oblique base, rebased), the
// plane through the surface points, at clip heights 0, info.z and info.w (f32 bits) along
// edges 0, 1 and 2. Between that plane and the base the edges run inside the object: no light.
fn beam_clip(b: BeamGpu, v: array<vec3f, 3>, s: array<vec3f, 3>, nrm: vec3f) -> vec4f {
    let h1 = bitcast<f32>(b.info.z);
    let h2 = bitcast<f32>(b.info.w);
    if (h1 > 0.0 || h2 > 0.0) {
        let q1 = v[1] + s[1] * h1 - v[0];
        let q2 = v[2] + s[2] * h2 - v[0];
        var cn = cross(q1, q2);
        let l = length(cn);
        if (l > 0.0) {
            cn /= l;
            if (dot(cn, s[0] + s[1] + s[2]) < 0.0) { cn = -cn; }
            return vec4f(cn, dot(cn, v[0]));
        }
    }
    return vec4f(nrm, dot(nrm, v[0]));
}

// The unit normal of a beam's base (vertices v), turned along its edges (directions d).
fn beam_normal(v: array<vec3f, 3>, d: array<vec3f, 3>) -> vec3f {
    var nrm = normalize(cross(v[1] - v[0], v[2] - v[0]));
    if (dot(nrm, d[0] + d[1] + d[2]) < 0.0) { nrm = -nrm; }
    return nrm;
}

// A beam in beam space: base vertices v, unit edge directions dir, the base's normal (along the
// edges), the edges scaled to unit height s_i = d_i / (n . d_i), and the heights of the edges'
// ends.
struct BeamSpace {
    v: array<vec3f, 3>,
    dir: array<vec3f, 3>,
    s: array<vec3f, 3>,
    nrm: vec3f,
    yend: vec3f,
    // The clip plane: points x with dot(cn, x) < cd are not in the beam (`beam_clip`).
    cn: vec3f,
    cd: f32,
    // Twice the signed section area as a quadratic in the height (section_area), and the
    // heights where it is zero (beam_foci).
    kq: vec3f,
    foci: vec2f,
}

fn beam_space(b: BeamGpu) -> BeamSpace {
    var r: BeamSpace;
    r.v = array<vec3f, 3>(b.v0.xyz, b.v1.xyz, b.v2.xyz);
    r.dir = array<vec3f, 3>(b.d0.xyz, b.d1.xyz, b.d2.xyz);
    let nrm = beam_normal(r.v, r.dir);
    r.nrm = nrm;
    for (var i = 0; i < 3; i++) {
        let c = dot(nrm, r.dir[i]);
        r.s[i] = r.dir[i] / c;
        r.yend[i] = select(b.d0.w, select(b.d1.w, b.d2.w, i == 2), i >= 1) * c;
    }
    let cp = beam_clip(b, r.v, r.s, nrm);
    r.cn = cp.xyz;
    r.cd = cp.w;
    r.kq = section_area(r.v, r.s, nrm);
    // (beam_hull's heights: the same bits)
    r.foci = beam_foci(r.kq, max(max(r.yend.x, r.yend.y), r.yend.z) * (1.0 + 1e-4));
    return r;
}

