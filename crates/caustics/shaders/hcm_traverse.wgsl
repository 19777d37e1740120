// Stage: hcm_traverse. One level of the top-down traversal of hierarchical caustic maps
// (Wyman 2008, as the baseline of Wyman & Nichols 2009): a dense tile of photons was traced
// (photon_trace) and a mip chain of valid-photon counts built over it (coverage_mip, source 1).
// Each thread takes one cell (of the grid lp.grid over the tile) that holds valid photons and
// keeps its children that hold some: appended to the cell list, or, at the finest level
// (FLAG_LAST), the photon itself is copied to the compact photon buffer that is splatted.
// FLAG_QUADS (caustic triangles): the photon also gets its *dual quad* for splat_quads: its
// corners are the mean landing points of the 2 x 2 photon groups around it in the dense tile
// (the bilinear estimate of where the light through the cell's corners lands; no extra
// tracing; a neighbour beyond the tile's edge, not traced with this tile, is estimated as the
// point reflection of the opposite neighbour through the photon). It is used (Photon._pad bit
// 0, corners stored) only if those eight neighbours are valid, on the photon's face (or across a
// seam of a point light's cube: `in_face_of`) and path
// (signature flux.w) and no quad edge is longer than max(32, 8 M / N) texels; otherwise the
// photon is a Gaussian (splat_quads) as wide as its cell's image where the neighbours on its
// path tell it (light spreading thin; fallback_sigma_bits), else of the fixed sigma.

#import hierarchy
#import coverage

@group(0) @binding(0) var<uniform> lp: LevelParams;
@group(0) @binding(1) var<storage, read> cover: array<u32>;
@group(0) @binding(2) var<storage, read_write> cells: array<u32>;
@group(0) @binding(3) var<storage, read> tile: array<Photon>;
@group(0) @binding(4) var<storage, read_write> photons: array<Photon>;
@group(0) @binding(5) var<storage, read_write> ctrl: array<atomic<u32>>;
@group(0) @binding(6) var<storage, read_write> corners: array<vec4f>;
@group(0) @binding(7) var<uniform> light: LightGpu;

// The photon at (x, y) of the tile, or an invalid one outside it.
fn at(x: i32, y: i32) -> Photon {
    var p: Photon;
    p.face = INVALID;
    let t = i32(lp.finest);
    if (x < 0 || y < 0 || x >= t || y >= t) { return p; }
    return tile[u32(y) * lp.finest + u32(x)];
}

// Neighbour n of photon p, for p's dual quad: where n landed across a seam of a point light's
// cube on p's path, its landing point in p's face's coordinates (past its map; splat_quads
// spreads the quad over the faces it covers), else n as it is.
fn in_face_of(p: Photon, n: Photon) -> Photon {
    var m = n;
    if (light.info.x == 6u && n.face != INVALID && n.face != p.face && n.flux.w == p.flux.w) {
        let t = texel_in_face(light.faces[n.face], light.faces[p.face], n.pos, f32(light.info.w));
        if (t.z != 0.0) {
            m.pos = t.xy;
            m.face = p.face;
        }
    }
    return m;
}

// Copy photon c of the tile to slot k, with its dual quad when FLAG_QUADS asks for one.
fn store(k: u32, c: vec2u) {
    var p = tile[c.y * lp.finest + c.x];
    if ((lp.flags & FLAG_QUADS) == 0u || p.face == INVALID) {
        photons[k] = p;
        return;
    }
    var ok = true;
    var sum_a = vec4f(0.0);
    var sum_m = vec3f(0.0);
    var sum: array<vec2f, 4>;
    for (var q = 0u; q < 4u; q++) { sum[q] = vec2f(0.0); }
    for (var dy = -1; dy <= 1; dy++) {
        for (var dx = -1; dx <= 1; dx++) {
            var n = in_face_of(p, at(i32(c.x) + dx, i32(c.y) + dy));
            let t = i32(lp.finest);
            let ox = i32(c.x) + dx;
            let oy = i32(c.y) + dy;
            if (ox < 0 || oy < 0 || ox >= t || oy >= t) {
                // Across the tile's edge (not traced with this tile): the point reflection of
                // the opposite neighbour through the photon, exact for a locally affine map, so
                // that the quads of neighbouring tiles meet.
                n = in_face_of(p, at(i32(c.x) - dx, i32(c.y) - dy));
                n.pos = 2.0 * p.pos - n.pos;
            }
            let same = n.face == p.face && n.flux.w == p.flux.w;
            ok = ok && same;
            if (same && (dx != 0 || dy != 0)) {
                let d = vec2f(f32(dx), f32(dy));
                let r = n.pos - p.pos;
                sum_a += vec4f(r.x * d.x, r.x * d.y, r.y * d.x, r.y * d.y);
                sum_m += vec3f(d.x * d.x, d.x * d.y, d.y * d.y);
            }
            // Neighbour (dx, dy) belongs to the corners it touches: (0, 0) top-left .. (1, 1).
            for (var q = 0u; q < 4u; q++) {
                let cx = i32(q & 1u);
                let cy = i32(q >> 1u);
                if ((dx == cx - 1 || dx == cx) && (dy == cy - 1 || dy == cy)) { sum[q] += n.pos; }
            }
        }
    }
    var quad = false;
    var c0 = vec2f(0.0);
    var c1 = vec2f(0.0);
    var c2 = vec2f(0.0);
    var c3 = vec2f(0.0);
    if (ok) {
        c0 = 0.25 * sum[0];
        c1 = 0.25 * sum[1];
        c2 = 0.25 * sum[2];
        c3 = 0.25 * sum[3];
        let e = max(max(distance(c0, c1), distance(c0, c2)), max(max(distance(c1, c3), distance(c2, c3)), distance(c0, c3)));
        quad = e <= max(32.0, 8.0 * f32(light.info.w) / f32(lp.grid_n));
    }
    var fallback = 0u;
    if (!quad) { fallback = fallback_sigma_bits(sum_a, sum_m, light.params.z); }
    p._pad = select(fallback, 1u, quad);
    if (quad) {
        corners[2u * k] = vec4f(c0, c1);
        corners[2u * k + 1u] = vec4f(c2, c3);
    }
    photons[k] = p;
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) wg: vec3u, @builtin(num_workgroups) nwg: vec3u, @builtin(local_invocation_index) lid: u32) {
    let t = thread_index(wg, nwg, lid);
    if (t >= atomicLoad(&ctrl[C_READ_COUNT])) { return; }
    let parent = unpack_cell(cells[atomicLoad(&ctrl[C_READ_OFF]) + t]);
    let s = 2u * lp.grid;
    for (var q = 0u; q < 4u; q++) {
        let c = 2u * parent + vec2u(q & 1u, q >> 1u);
        if (covered_count(c.x, c.y, s) == 0u) { continue; }
        if ((lp.flags & FLAG_LAST) != 0u) {
            let k = atomicAdd(&ctrl[C_PHOTONS], 1u);
            atomicAdd(&ctrl[C_EMITTED + lp.level + 1u], 1u);
            if (k >= lp.photon_capacity) { atomicOr(&ctrl[C_OVERFLOW], 2u); continue; }
            store(k, c);
        } else {
            let k = atomicAdd(&ctrl[C_WRITE_COUNT], 1u);
            if (k >= lp.cell_capacity) { atomicOr(&ctrl[C_OVERFLOW], 1u); continue; }
            cells[atomicLoad(&ctrl[C_WRITE_OFF]) + k] = pack_cell(c.x, c.y);
        }
    }
}
