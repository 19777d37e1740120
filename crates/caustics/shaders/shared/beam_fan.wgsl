// Shared WGSL (`#import beam_fan`, after `#import beams`): the vertex stage (`vs_main`) of the
// beams' hull draws (beam_raster, beam_surface_raster). Instance k is part k % BEAM_HULL_PARTS
// of the ordered list's (k / BEAM_HULL_PARTS)-th beam, its vertices a triangle fan over the hull
// polygon beam_hull made for that part (BEAM_HULL_VERTICES per instance: the triangles past the
// hull's vertex count are degenerate and draw nothing; an empty part draws none). A stage
// importing it declares `bp` (BeamParams) and `hulls` (array<BeamHull>).

struct HullVertex {
    @builtin(position) pos: vec4f,
    @location(0) @interpolate(flat) beam: u32,
    // The heights over the beam's base the part holds (beam_hull: split at foci).
    @location(1) @interpolate(flat) heights: vec2f,
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) k: u32) -> HullVertex {
    let h = hulls[k];
    let tri = vi / 3u;
    let corner = vi % 3u;
    var i = select(tri + corner, 0u, corner == 0u);
    if (tri + 2u >= h.info.x) { i = 0u; }
    let q = h.p[i / 2u];
    let p = select(q.xy, q.zw, (i & 1u) != 0u);
    var out: HullVertex;
    out.pos = vec4f(p.x / f32(bp.width) * 2.0 - 1.0, 1.0 - p.y / f32(bp.height) * 2.0, 0.0, 1.0);
    out.beam = h.info.y;
    out.heights = bitcast<vec2f>(h.info.zw);
    return out;
}
