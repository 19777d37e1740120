// Stage: sphere_compile. The compiled variant of caustic spheres (Tandianus et al. 2010,
// section 6), one dispatch per caustic object: at every cell centre of the object's compiled
// table (its own spheres and cells, in a fixed frame of the object), every record of that
// object (directional lights x blended stored directions) is looked up and summed into one
// vector per colour, V_c = sum E_c C d (W/m^2 times the light's travel direction, object
// frame). sphere_gather then does one lookup per object instead of one per record and takes
// E_c = max(0, -V_c . n): exact where every light reaching the receiver comes from its front
// (then the sum of the cosines is the cosine of the sum), and the table is resampled once at
// its own resolution.

#import sphere_table

struct SphereCompileParams {
    // The object's records: records[first .. first + count].
    first: u32,
    count: u32,
    // Cells of the compiled table (spheres x latitudes x longitudes) and its first vec4.
    cells: u32,
    out_base: u32,
}

@group(0) @binding(0) var<uniform> cp: SphereCompileParams;
// [0]: the object's compiled record: its frame (axes), spheres and cells.
@group(0) @binding(1) var<storage, read> object: array<SphereRecord>;
@group(0) @binding(2) var<storage, read> records: array<SphereRecord>;
@group(0) @binding(3) var<storage, read> table: array<vec4u>;
@group(0) @binding(4) var<storage, read_write> compiled: array<vec4f>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3u) {
    let cell = gid.x;
    if (cell >= cp.cells) { return; }
    let o = object[0];
    let s = u32(o.shape.y);
    let w = u32(o.shape.z);
    let h = u32(o.shape.w);
    let col = cell % w;
    let row = (cell / w) % h;
    let sph = cell / (w * h);
    // The cell's centre: equation (1) radius, warped latitude theta = pi t^2.
    let f = f32(sph) / f32(s - 1u);
    let radius = o.center.w + (o.shape.x - o.center.w) * f * f;
    let t = (f32(row) + 0.5) / f32(h);
    let th = PI * t * t;
    let ph = 2.0 * PI * (f32(col) + 0.5) / f32(w);
    let dir = sin(th) * (cos(ph) * o.axes[0].xyz + sin(ph) * o.axes[1].xyz) + cos(th) * o.axes[2].xyz;
    let po = o.center.xyz + radius * dir;
    var v0 = vec3f(0.0);
    var v1 = vec3f(0.0);
    var v2 = vec3f(0.0);
    for (var i = cp.first; i < cp.first + cp.count; i++) {
        let r = records[i];
        let sm = sphere_lookup(r, po);
        let e = r.irradiance.rgb * sm.c;
        v0 += e.r * sm.d;
        v1 += e.g * sm.d;
        v2 += e.b * sm.d;
    }
    let at = cp.out_base + cell * 3u;
    compiled[at] = vec4f(v0, 0.0);
    compiled[at + 1u] = vec4f(v1, 0.0);
    compiled[at + 2u] = vec4f(v2, 0.0);
}
