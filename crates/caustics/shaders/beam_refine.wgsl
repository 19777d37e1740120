// Stage: beam_refine. One level of the adaptive projected grid of beams (Liktor & Dachsbacher
// 2011, section 4.2), one thread per triangle: level 0 from the thread index (the B x B grid
// over each light face, two triangles per cell), later levels from the work list the level
// before appended (indirect dispatch). The triangle's three edge rays are traced exactly
// (shared/raytrace.wgsl: refraction with Fresnel, total internal reflection, mirrors) from
// the light to the first diffuse surface; then the triangle is
//   - discarded: no edge meets a specular caster first (no caustic light);
//   - split 1 -> 4 (edge midpoints; appended to the next level's list, its indirect dispatch
//     size raised by atomicMax) while levels remain, when: the edges meet a caster's silhouette
//     (some meet the caster, some not), a different object, or their first-surface normals
//     differ by more than the normal threshold or their distances from the light by more than
//     the depth threshold (discontinuities); the edges took different paths or land on
//     different objects (on any traced branch); the beam's flux relative to the face's flux, times its convergence
//     (base area over its smallest cross-section before the receiver), exceeds the energy
//     threshold; the beam's width over its distance from the camera exceeds the camera
//     threshold; or (ours) a beam it would keep departs from the light of the triangle's
//     centroid by more than the linearity threshold of its width, weighted by the share of the
//     triangle's light it carries (`nonlinearity`);
//   - kept: one beam per traced branch whose three edges took the same path (the transmitted
//     branch; with flags bit 0 also the branch reflected at the first dielectric surface and
//     the branch reflected once inside it, the two at a second dielectric, and the residual
//     branch, whose Fresnel choices are drawn at random per triangle: beam_trace's `trace_edge`),
//     appended to the beam buffer (overflow counted, never written out of bounds) and entered
//     in its slot of the hierarchy (beam_order lists the slots in order, so the image does not
//     depend on the order of the atomics). At the last level, a triangle whose edges still
//     disagree (a silhouette) is split into the parts on its corners' paths, one beam each, on
//     every branch and layer: each part is queued (`parts`, its count and indirect dispatch
//     size in args' entry PARTS_ARGS) for beam_shrink, which finds it by bisection along the
//     triangle's sides; those none of whose corners takes a caustic path are counted (their
//     light is lost). The reflected branches' flux is a quadrature over the triangle exact for
//     quadratics (`part_weight`).
//     Each branch's path gives a beam on each of its layers (`at_layer`): its last segment, and
//     where its light crossed the medium from one specular object to another (a lens focusing
//     onto a second lens, a mirror onto glass), that segment too (the second caster layer),
//     ending on the next object's surface.

#import raytrace
#import beams
#import medium
#import beam_medium
#import beam_trace
#import scene

@group(0) @binding(0) var<uniform> light: LightGpu;
@group(0) @binding(1) var<uniform> bp: BeamParams;
@group(0) @binding(2) var<uniform> lv: BeamLevel;
@group(0) @binding(3) var<storage, read_write> work: array<BeamTri>;
// Per level l: (workgroups x, 1, 1, triangles appended) at words 4l..4l+3; at entry PARTS_ARGS
// beam_shrink's (workgroups x, 1, 1, parts queued).
@group(0) @binding(4) var<storage, read_write> args: array<atomic<u32>>;
// Per slot, branch and layer (BEAM_KINDS per slot): beam index + 1 (0: none).
@group(0) @binding(5) var<storage, read_write> slots: array<u32>;
@group(0) @binding(6) var<storage, read_write> beams: array<BeamGpu>;
// Word 0: beams appended; BS_WORDS statistics words follow at 1.
@group(0) @binding(7) var<storage, read_write> stats: array<atomic<u32>>;
// The parts of triangles whose corners' edges take different paths, for beam_shrink (their
// count and dispatch size in args' entry PARTS_ARGS).
@group(0) @binding(8) var<storage, read_write> parts: array<BeamPart>;

// Signed twice-area of the beam's cross-section at height y over its base plane (normal nrm):
// a quadratic in y (Ernst et al. 2005): returns |2A(0)| and the smallest |2A(y)| over [0, ym]
// (0 where the section passes through a focal line), what the energy criterion's convergence
// uses.
fn min_area(e0: Edge, e1: Edge, e2: Edge, ym: f32) -> vec2f {
    var nrm = normalize(cross(e1.o - e0.o, e2.o - e0.o));
    if (dot(nrm, e0.d + e1.d + e2.d) < 0.0) { nrm = -nrm; }
    let s0 = e0.d / max(dot(nrm, e0.d), 1e-3);
    let s1 = e1.d / max(dot(nrm, e1.d), 1e-3);
    let s2 = e2.d / max(dot(nrm, e2.d), 1e-3);
    // 2A(y) = nrm . ((a + y b) x (c + y d)), a = v1 - v0, b = s1 - s0, c = v2 - v0, d = s2 - s0.
    let a = e1.o - e0.o;
    let bb = s1 - s0;
    let c = e2.o - e0.o;
    let dd = s2 - s0;
    let k0 = dot(nrm, cross(a, c));
    let k1 = dot(nrm, cross(a, dd) + cross(bb, c));
    let k2 = dot(nrm, cross(bb, dd));
    let a_end = k0 + k1 * ym + k2 * ym * ym;
    var m = min(abs(k0), abs(a_end));
    // A section that changes orientation between the base and the end passes through 0: a
    // focal line inside the beam (two where its foci differ, an astigmatic beam: there the
    // extremum between the roots can be as large as the base, so the ends and the extremum alone
    // would miss the focus).
    var crosses = sign(k0) != sign(a_end);
    if (abs(k2) > 0.0) {
        let yv = -k1 / (2.0 * k2);
        if (yv > 0.0 && yv < ym) {
            let av = k0 + k1 * yv + k2 * yv * yv;
            m = min(m, abs(av));
            crosses = crosses || sign(av) != sign(k0);
        }
    }
    return vec2f(abs(k0), select(m, 0.0, crosses));
}

// How far the beam over edges e0..e2 departs from the light it stands for (the linearity
// criterion, ours: the paper's criteria look at the corners only). A beam interpolates its
// edges linearly; the light of the triangle's centroid really runs along `ec` (traced). Both
// are cut by the planes across the edges' mean direction at the beam's start and at its
// farthest end; the larger distance between the centroid's true point and the beam's point
// of barycentrics (1/3, 1/3, 1/3), over the beam's widest section there (the sections'
// corners move linearly, so the width and that distance are largest at one of the two
// planes). A fraction of the beam's size, so it does not depend on the scene's scale: near
// a ball's rim, where refraction bends fast, coarse beams put their light up to a section's
// width off its true place. Returns 2 where the centroid takes another path, 0 where the
// planes cannot be built (edges nearly across the mean direction: left to the other criteria).
fn nonlinearity(e0: Edge, e1: Edge, e2: Edge, ec: Edge) -> f32 {
    if (!same_path(ec, e0)) { return 2.0; }
    let m = normalize(e0.d + e1.d + e2.d);
    let dm = vec4f(dot(e0.d, m), dot(e1.d, m), dot(e2.d, m), dot(ec.d, m));
    if (min(min(dm.x, dm.y), min(dm.z, dm.w)) < 1e-3) { return 0.0; }
    let z0 = max(max(dot(e0.o, m), dot(e1.o, m)), dot(e2.o, m));
    let z1 = max(max(dot(e0.o + e0.d * e0.t_end, m), dot(e1.o + e1.d * e1.t_end, m)), dot(e2.o + e2.d * e2.t_end, m));
    var dev = 0.0;
    var width = 0.0;
    for (var k = 0; k < 2; k++) {
        let z = select(z0, max(z1, z0), k == 1);
        let p0 = e0.o + e0.d * ((z - dot(e0.o, m)) / dm.x);
        let p1 = e1.o + e1.d * ((z - dot(e1.o, m)) / dm.y);
        let p2 = e2.o + e2.d * ((z - dot(e2.o, m)) / dm.z);
        let pc = ec.o + ec.d * ((z - dot(ec.o, m)) / dm.w);
        dev = max(dev, length(pc - (p0 + p1 + p2) / 3.0));
        width = max(width, max(max(length(p1 - p0), length(p2 - p1)), length(p0 - p2)));
    }
    return dev / max(width, 1e-30);
}

// The mean weight over a triangle (light NDC) from its corners' mean `wc` and its centre's
// weight, by the rule exact for quadratics: corners 1/12 each and centroid 3/4, i.e.
// (wc + 3 centre) / 4. The Fresnel factors change steeply near a silhouette (the corners' mean
// alone overestimates them there: F is convex toward grazing). The centre's edge is traced once
// more; where it takes another path, the corners' mean.
fn part_weight(f: u32, centre: vec2f, br: u32, layer: u32, r: Edge, wc: vec3f) -> vec3f {
    let e = at_layer(trace_edge(f, centre, br), layer);
    if (!same_path(e, r)) { return wc; }
    return (wc + 3.0 * e.weight) / 4.0;
}

// Appends a part for beam_shrink (overflow counted: more parts than beams the buffer holds
// would overflow it anyway) and raises its indirect dispatch size.
fn queue_part(p: BeamPart) {
    let k = atomicAdd(&args[4u * PARTS_ARGS + 3u], 1u);
    if (k >= min(bp.capacity, 65535u * 64u)) {
        atomicAdd(&stats[1u + BS_OVERFLOW], 1u);
        return;
    }
    // (beam_shrink: SHRINK_GROUP_PARTS parts per workgroup, 65535 workgroups per row)
    let groups = (k + SHRINK_GROUP_PARTS) / SHRINK_GROUP_PARTS;
    atomicMax(&args[4u * PARTS_ARGS], min(groups, 65535u));
    atomicMax(&args[4u * PARTS_ARGS + 1u], (groups + 65534u) / 65535u);
    parts[k] = p;
}

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let i = gid.x + gid.y * 65535u * 64u;
    let level = lv.level;
    var tri: BeamTri;
    if (level == 0u) {
        if (i >= lv.base_count) { return; }
        if (i == 0u) {
            for (var l = 0u; l < 8u; l++) {
                atomicStore(&args[4u * l + 1u], 1u);
                atomicStore(&args[4u * l + 2u], 1u);
            }
        }
        let per_face = 2u * bp.grid * bp.grid;
        let f = i / per_face;
        let r = i % per_face;
        let cell = r / 2u;
        let s = 2.0 / f32(bp.grid);
        let x0 = -1.0 + s * f32(cell % bp.grid);
        let y0 = -1.0 + s * f32(cell / bp.grid);
        tri.face = f;
        tri.id = i;
        tri.a = vec2f(x0, y0);
        if ((r & 1u) == 0u) {
            tri.b = vec2f(x0 + s, y0);
            tri.c = vec2f(x0 + s, y0 + s);
        } else {
            tri.b = vec2f(x0 + s, y0 + s);
            tri.c = vec2f(x0, y0 + s);
        }
    } else {
        if (i >= atomicLoad(&args[4u * level + 3u])) { return; }
        tri = work[lv.offset + i];
    }
    atomicAdd(&stats[1u + BS_VISITED + min(level, 7u)], 1u);
    let slot = lv.offset + tri.id;
    beam_key = slot;
    // The fixed branches (3 and 4, at a second dielectric, where light can meet one:
    // BEAM_FLAG_CHAINS), and after them the residual branch where it is on (its triangles are
    // kept or split by the fixed branches alone: its light is faint and its paths random).
    let branches = fixed_branches();
    let traced = traced_branches();
    // The corners' edges on every traced branch (es[3 j + corner], branch traced_branch(j)),
    // traced at one call site (a GPU's compiler inlines every call of `trace_edge` with the
    // whole BVH traversal in it: docs/benchmarks.md, the first NVIDIA figures); the reflected
    // branches only where a corner's light meets a caster.
    var es: array<Edge, 18>;
    for (var k = 0u; k < 3u * traced; k++) {
        let p = select(select(tri.c, tri.b, k % 3u == 1u), tri.a, k % 3u == 0u);
        es[k] = trace_edge(tri.face, p, traced_branch(k / 3u));
        if (k == 2u && u32(es[0].caster) + u32(es[1].caster) + u32(es[2].caster) == 0u) { return; }
    }
    let e0 = es[0];
    let e1 = es[1];
    let e2 = es[2];
    let casters = u32(e0.caster) + u32(e1.caster) + u32(e2.caster);
    let face = light.faces[tri.face];
    let omega = solid_angle(light_dir(face, tri.a), light_dir(face, tri.b), light_dir(face, tri.c));
    // A triangle whose corners all take one path that is not a caustic path of the transmitted
    // branch (light that leaves the scene where no medium lies along it) has no light of that
    // branch to refine: the other branches decide.
    let none0 = !e0.ok && !e1.ok && !e2.ok && !paths_differ(e0, e1, e2);
    var split = casters < 3u || (!consistent(e0, e1, e2) && !none0);
    if (!split && !none0) {
        // Discontinuities of the specular surface.
        let same_obj = e0.first_obj == e1.first_obj && e1.first_obj == e2.first_obj;
        let ncos = min(min(dot(e0.first_n, e1.first_n), dot(e1.first_n, e2.first_n)), dot(e2.first_n, e0.first_n));
        let tm = (e0.first_t + e1.first_t + e2.first_t) / 3.0;
        let dt = max(max(e0.first_t, e1.first_t), e2.first_t) - min(min(e0.first_t, e1.first_t), e2.first_t);
        split = !same_obj || ncos < bp.normal_cos || dt > bp.depth_rel * tm;
    }
    if (!split && !none0) {
        // Energy and convergence.
        let w = (e0.weight + e1.weight + e2.weight) / 3.0;
        let phi = omega * (w.r + w.g + w.b) / 3.0;
        // (the longest edge: at least the end height over the base)
        let ym = max(max(e0.t_end, e1.t_end), e2.t_end);
        let ar = min_area(e0, e1, e2, ym);
        // (capped at 100: a ball lens's beams all but vanish at their focus)
        var conv = ar.x / max(ar.y, 1e-2 * ar.x);
        // Light between two casters (layer 1) converges too (a lens focusing onto the next):
        // the larger convergence of the two layers.
        let l0 = at_layer(e0, 1u);
        let l1 = at_layer(e1, 1u);
        let l2 = at_layer(e2, 1u);
        if (consistent(l0, l1, l2) && length(cross(l1.o - l0.o, l2.o - l0.o)) > 0.0) {
            let a1 = min_area(l0, l1, l2, max(max(l0.t_end, l1.t_end), l2.t_end));
            conv = max(conv, a1.x / max(a1.y, 1e-2 * a1.x));
        }
        let face_omega = solid_angle(light_dir(face, vec2f(-1.0, -1.0)), light_dir(face, vec2f(1.0, -1.0)), light_dir(face, vec2f(1.0, 1.0)))
            + solid_angle(light_dir(face, vec2f(-1.0, -1.0)), light_dir(face, vec2f(1.0, 1.0)), light_dir(face, vec2f(-1.0, 1.0)));
        let peak = max(max(light.power.r, light.power.g), light.power.b);
        split = phi / max(face_omega * peak, 1e-30) * max(conv, 1.0) > bp.energy;
        // Distance to the camera: the closest point of the central ray to the camera.
        let co = (e0.o + e1.o + e2.o) / 3.0;
        let cd = normalize(e0.d + e1.d + e2.d);
        let tc = clamp(dot(bp.camera.xyz - co, cd), 0.0, ym);
        let dist = max(length(co + cd * tc - bp.camera.xyz), 1e-6);
        split = split || sqrt(0.5 * ar.x) / dist > bp.camera_size;
    }
    // The reflected branches (flags bit 0) split where their edges disagree too (their light
    // would be lost otherwise: reflected edges that land on different objects, or leave the
    // scene, near the silhouette).
    for (var br = 1u; br < branches; br++) {
        let r0 = es[3u * br];
        let r1 = es[3u * br + 1u];
        let r2 = es[3u * br + 2u];
        split = split || ((r0.ok || r1.ok || r2.ok) && !consistent(r0, r1, r2));
    }
    if (!split && level < bp.levels && bp.linearity > 0.0) {
        // Linearity: the centroid's edge on every branch and layer a beam would be kept on,
        // its departure weighted by the share of the light toward the triangle the beam
        // carries (its corners' weights over the light's intensity toward them: about 0.9 on
        // the transmitted branch, the Fresnel factor on a reflected one), so a beam is split
        // for the fraction of the triangle's light it misplaces.
        let centre = (tri.a + tri.b + tri.c) / 3.0;
        let inc = intensity_toward(light, light_dir(face, tri.a)) + intensity_toward(light, light_dir(face, tri.b))
            + intensity_toward(light, light_dir(face, tri.c));
        for (var br = 0u; br < branches && !split; br++) {
            let c0 = es[3u * br];
            let c1 = es[3u * br + 1u];
            let c2 = es[3u * br + 2u];
            if (!consistent(c0, c1, c2)) { continue; }
            let ec = trace_edge(tri.face, centre, br);
            for (var layer = 0u; layer < BEAM_LAYERS; layer++) {
                let a0 = at_layer(c0, layer);
                let a1 = at_layer(c1, layer);
                let a2 = at_layer(c2, layer);
                if (consistent(a0, a1, a2)) {
                    let share = dot(a0.weight + a1.weight + a2.weight, vec3f(1.0)) / max(dot(inc, vec3f(1.0)), 1e-30);
                    split = split || nonlinearity(a0, a1, a2, at_layer(ec, layer)) * share > bp.linearity;
                }
            }
        }
    }
    if (split && level < bp.levels) {
        let k = atomicAdd(&args[4u * (level + 1u) + 3u], 4u);
        atomicMax(&args[4u * (level + 1u)], (k + 4u + 63u) / 64u);
        let ab = 0.5 * (tri.a + tri.b);
        let bc = 0.5 * (tri.b + tri.c);
        let ca = 0.5 * (tri.c + tri.a);
        let base = lv.next_offset + k;
        work[base] = BeamTri(tri.a, ab, ca, tri.id * 4u, tri.face);
        work[base + 1u] = BeamTri(ab, tri.b, bc, tri.id * 4u + 1u, tri.face);
        work[base + 2u] = BeamTri(ca, bc, tri.c, tri.id * 4u + 2u, tri.face);
        work[base + 3u] = BeamTri(bc, ca, ab, tri.id * 4u + 3u, tri.face);
        return;
    }
    // Branch 1: reflected at the first surface; branch 2: refracted in, reflected once inside,
    // then refracted out (the light a sphere sends back toward the light's side); 3 and 4 the
    // same at a second dielectric (trace_edge). Their Fresnel
    // factors change fast across a triangle near the silhouette (where F is largest): the
    // beam's flux is the quadrature exact for quadratics (corners 1/12 each, centroid 3/4; one
    // more edge traced), not the corners' mean. At the last level, triangles whose edges
    // disagree are split into their corners' paths' parts as the transmitted branch's. Each branch
    // gives a beam on each layer its path has (at_layer: its last segment, and the one between
    // its last two specular objects).
    // The residual branch's triangles whose corners disagree are split into parts at whatever
    // level the fixed branches keep them.
    let centroid = (tri.a + tri.b + tri.c) / 3.0;
    for (var layer = 0u; layer < BEAM_LAYERS; layer++) {
        for (var j = 0u; j < traced; j++) {
            let br = traced_branch(j);
            let r0 = at_layer(es[3u * j], layer);
            let r1 = at_layer(es[3u * j + 1u], layer);
            let r2 = at_layer(es[3u * j + 2u], layer);
            if (consistent(r0, r1, r2)) {
                var b = make_beam(r0, r1, r2, omega, level);
                if (br > 0u) {
                    let wc = (r0.weight + r1.weight + r2.weight) / 3.0;
                    b.flux = vec4f(omega * part_weight(tri.face, centroid, br, layer, r0, wc), b.flux.w);
                }
                emit(b, slot, br, layer, 0u);
            } else {
                // The last level (the residual branch, and a branch none of whose corners is on
                // a caustic path: any level): the parts of the triangle on its corners' paths,
                // queued for beam_shrink (parts 0, 1, 2 of its place, in the order of their
                // cases). Where no corner is on one but their paths differ (the deeper branches
                // on a mesh caster: light that crosses it more often inside the triangle than at
                // its corners), the triangle's orphans' beam alone (PART_ORPHANS; on the glass
                // dragon 10 to 25 % of the light of the branches reflected at the third and
                // fourth interactions and of the residual branch was lost without it). On both
                // layers: on layer 1 (light crossing the fog between two parts of the dragon) the
                // transmitted beams carried 0.88 of the light without it.
                let es3 = array<Edge, 3>(r0, r1, r2);
                var part = 0u;
                for (var c = 0u; c < 6u; c++) {
                    if (part_applies(es3, c)) {
                        queue_part(BeamPart(tri.a, tri.b, tri.c, tri.face, slot, level, br | (layer << 4u) | (c << 8u) | (part << 12u)));
                        part++;
                    }
                }
                let orphans_only = part == 0u && paths_differ(r0, r1, r2);
                if (orphans_only && br == 0u && layer == 0u) {
                    atomicAdd(&stats[1u + BS_INCONSISTENT], 1u);
                }
                if (orphans_only) {
                    queue_part(BeamPart(tri.a, tri.b, tri.c, tri.face, slot, level, br | (layer << 4u) | (PART_ORPHANS << 8u)));
                }
            }
        }
    }
}
