//! What `tests/cpu/shaders.rs` checks against the WGSL: [`CONSTANTS`], and [`LAYOUTS`], every
//! struct's fields as the `layouts!` macro lists them (`offset_of!` on each struct in scope).

use super::*;

/// (name, value) of the constants the WGSL declares under the same name: `tests/cpu/shaders.rs`
/// checks that at least one stage declares each, and that every stage that does has this value.
pub const CONSTANTS: &[(&str, u32)] = &[
    ("KIND_DIFFUSE", KIND_DIFFUSE),
    ("KIND_DIELECTRIC", KIND_DIELECTRIC),
    ("KIND_MIRROR", KIND_MIRROR),
    ("KIND_CONDUCTOR", KIND_CONDUCTOR),
    ("SHAPE_MESH", SHAPE_MESH),
    ("SHAPE_SPHERE", SHAPE_SPHERE),
    ("SHAPE_CYLINDER", SHAPE_CYLINDER),
    ("SHAPE_RECTANGLE", SHAPE_RECTANGLE),
    ("LIGHT_SPOT", LIGHT_SPOT),
    ("LIGHT_POINT", LIGHT_POINT),
    ("LIGHT_DIRECTIONAL", LIGHT_DIRECTIONAL),
    ("SHADE_TILE", SHADE_TILE),
    ("SPILL_FACE_PRESENT", SPILL_FACE_PRESENT),
    ("BEAM_FLAG_REFLECTION", BEAM_FLAG_REFLECTION),
    ("BEAM_FLAG_GRID", BEAM_FLAG_GRID),
    ("BEAM_FLAG_CHAINS", BEAM_FLAG_CHAINS),
    ("BEAM_FLAG_FRAGMENTS", BEAM_FLAG_FRAGMENTS),
    ("BEAM_FLAG_SURFACE", BEAM_FLAG_SURFACE),
    ("BEAM_BRANCHES", BEAM_BRANCHES),
    ("BEAM_RESIDUAL", BEAM_RESIDUAL),
    ("BEAM_LAYERS", BEAM_LAYERS),
    ("BEAM_PARTS", BEAM_PARTS),
    ("BEAM_KINDS", BEAM_KINDS),
    ("BEAM_ORDER_RUN", BEAM_ORDER_RUN),
    ("BEAM_HULL_MAX", BEAM_HULL_MAX),
    ("BEAM_HULL_PARTS", BEAM_HULL_PARTS),
    ("MS_BLOCK", MS_BLOCK),
];

/// One field of a Rust GPU struct as the layout test (`tests/cpu/shaders.rs`) compares it with the
/// WGSL member or members it mirrors.
#[derive(Debug, Clone, Copy)]
pub struct FieldLayout {
    /// The Rust field's name.
    pub name: &'static str,
    /// The WGSL members it mirrors, in order: one (of the same name, or renamed where the two
    /// differ), or one per element of a Rust array that WGSL spells as separate members
    /// (`_pad0`, `_pad1`, ...: a uniform buffer's arrays need a 16-byte stride, so WGSL writes
    /// such arrays of scalars out member by member).
    pub wgsl: &'static [&'static str],
    /// `offset_of!` the field, in bytes.
    pub offset: usize,
    /// `size_of` the field's type.
    pub size: usize,
    /// Bytes from one element to the next: an array's element, else the whole type.
    pub element: usize,
    /// The scalar under the field's arrays (`f32`, `u32`, `i32`), or the nested GPU struct's Rust
    /// name ([`GpuMember::LEAF`]).
    pub leaf: &'static str,
}

/// A Rust GPU struct and the WGSL struct it mirrors, field by field ([`LAYOUTS`]).
#[derive(Debug, Clone, Copy)]
pub struct StructLayout {
    /// The Rust struct's name.
    pub rust: &'static str,
    /// The WGSL struct's name (one Rust struct may mirror several: [`TileParams`]).
    pub wgsl: &'static str,
    /// `size_of` the Rust struct: the WGSL struct's span.
    pub size: usize,
    /// Every field, in declaration order.
    pub fields: &'static [FieldLayout],
}

/// A type a GPU struct's field may have, as the layout test sees it: the scalar under its
/// arrays and the size of one element. Implemented for the scalars, arrays of them, and the GPU
/// structs nested in others.
pub trait GpuMember {
    /// `f32`, `u32`, `i32`, or a nested struct's Rust name.
    const LEAF: &'static str;
    /// An array's element size; the type's own size otherwise.
    const ELEMENT: usize;
}

macro_rules! gpu_member {
    ($($t:ty),*) => {$(
        impl GpuMember for $t {
            const LEAF: &'static str = stringify!($t);
            const ELEMENT: usize = size_of::<$t>();
        }
    )*};
}
gpu_member!(f32, u32, i32, FaceGpu, EnvTap);

impl<T: GpuMember, const N: usize> GpuMember for [T; N] {
    const LEAF: &'static str = T::LEAF;
    const ELEMENT: usize = size_of::<T>();
}

/// The [`FieldLayout`] of a field of `T`, its type read off `get` (a closure `|s| &s.field`,
/// never called).
const fn field<T, M: GpuMember>(
    name: &'static str,
    wgsl: &'static [&'static str],
    offset: usize,
    _get: fn(&T) -> &M,
) -> FieldLayout {
    FieldLayout { name, wgsl, offset, size: size_of::<M>(), element: M::ELEMENT, leaf: M::LEAF }
}

/// `layouts! { Rust as Wgsl { field, field => wgsl_name, field => [wgsl0, wgsl1] } ... }`: the
/// [`LAYOUTS`] entry of each struct, one line each (`as Wgsl` where the names differ). Every
/// field must be listed, in order: a field left out fails to compile, one out of order fails
/// the layout test.
macro_rules! layouts {
    (@wgsl $rust:ident) => { stringify!($rust) };
    (@wgsl $rust:ident $wgsl:ident) => { stringify!($wgsl) };
    (@members $f:ident) => { &[stringify!($f)] };
    (@members $f:ident $to:ident) => { &[stringify!($to)] };
    (@members $f:ident [$($to:ident),+]) => { &[$(stringify!($to)),+] };
    ($($rust:ident $(as $wgsl:ident)? { $($f:ident $(=> $to:tt)?),* $(,)? })*) => {
        /// Every Rust struct the shaders read or write and the WGSL struct it mirrors, field by
        /// field. `tests/cpu/shaders.rs` checks each against naga's layout of the WGSL in every
        /// stage that declares it: the span, and every member's name, offset and size.
        pub const LAYOUTS: &[StructLayout] = &[$(StructLayout {
            rust: stringify!($rust),
            wgsl: layouts!(@wgsl $rust $($wgsl)?),
            size: size_of::<$rust>(),
            fields: &[$(field(
                stringify!($f),
                layouts!(@members $f $($to)?),
                std::mem::offset_of!($rust, $f),
                |s: &$rust| &s.$f,
            )),*],
        }),*];
        // `Pod` structs have no padding: the listed fields cover the struct only if none is
        // missing.
        $(const _: () = assert!(
            0 $(+ field(stringify!($f), &[], 0, |s: &$rust| &s.$f).size)* == size_of::<$rust>(),
            concat!("layouts!: a field of ", stringify!($rust), " is missing from its line"),
        );)*
    };
}

// Where a Rust field's name is not its WGSL member's: `=> name` renames it (the padding words'
// numbering), `=> [a, b, ...]` maps a Rust array to as many WGSL members, one per element (arrays
// of scalars in a uniform buffer need a 16-byte stride, so WGSL spells those out; the
// indirect-dispatch words `groups_x`..; rows of matrices the shaders index by name).
layouts! {
    FaceGpu as Face { world_to_clip, clip_to_world, origin }
    LightGpu { faces, info, power, axis, params, extra, splat, crop, medium_lo, medium_hi, medium_sigma_t }
    MaterialGpu { kind, a, b, shape => [s0, s1, s2, s3] }
    RasterView { world_to_clip }
    TraceParams { face, batch_offset, batch_count, tile }
    Photon { pos, face, _pad, flux }
    SplatParams { groups => [groups_x, groups_y, groups_z], count }
    CoverParams { face, level, size, src, dst, source, _pad => [_pad0, _pad1] }
    LevelParams { face, level, grid, finest, gbuffer, flags, cell_capacity, photon_capacity, tolerance, batch_grid, batch_leaves, max_batches, tile_x, tile_y, grid_n, linearity }
    CountParams as ResolveParams { count, _pad => [_pad0, _pad1, _pad2] }
    TemporalParams { size, faces, has_history, stage, alpha, threshold, flags, _pad }
    ShadeParams { width, height, shadow_size, tiles, camera, medium_lo, medium_hi, sigma_t, medium_grid }
    TileParams as MaskParams { size, tiles, faces, _pad }
    TileParams { size, tiles, faces, _pad }
    EnvTap { rows => [r0, r1, r2], weight }
    EnvTapsGpu as EnvTaps { centre, info, taps }
    SphereGatherParams { width, height, records, samples, camera, medium_lo, medium_hi, sigma_t }
    SphereRecord { to_obj, axes, rot, center, shape, irradiance, base }
    SphereCompileParams { first, count, cells, out_base }
    SphereVolumeParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, width, height, steps, records }
    CompositeParams { world_to_clip, clip_to_world, camera, env_rotation, width, height, layer2, camera_inside, medium_lo, medium_hi, medium_sigma_t }
    EyeSegmentGpu as EyeSegment { o, w, dir }
    EmitParams { lo, hi, sigma_s, sigma_t, grid, faces, bins, slices, scale, heterogeneous, vpl_offset, vpl_count, caustic, _pad => [_pad0, _pad1, _pad2] }
    MediumParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, width, height, steps, flags, shadow_size, grid, light_steps, _pad => _pad0 }
    BounceLightParams { lo, hi, sigma_t, grid, shadow_size, heterogeneous, light_steps, offset, _pad => [_pad0, _pad1, _pad2], sigma_s }
    VplGpu as Vpl { pos, nrm, full, caustic }
    BounceParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, width, height, steps, count, heterogeneous, _pad => [_pad0, _pad1, _pad2] }
    SurfaceBounceParams { lo, hi, sigma_t, camera, width, height, count, heterogeneous, layers, _pad => [_pad0, _pad1, _pad2] }
    IndirectParams { origin, disk, lo, hi, sigma_t, camera, photons, seed, capacity, bounces, max_events, width, height, light_index, alpha, _pad => [_pad0, _pad1, _pad2] }
    MsParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, disk, dims, photons, seed, _pad => [_pad0, _pad1], width, height, steps, max_events }
    BeamParams { clip_to_world, camera, lo, hi, sigma_s, sigma_t, grid, levels, faces, max_depth, normal_cos, depth_rel, energy, camera_size, surface_samples, capacity, slots, samples, width, height, flags, pixel_samples, linearity, residual, cut, _pad => _pad2, world_to_clip }
    BeamLevel { level, offset, next_offset, base_count }
    BeamTri { a, b, c, id, face }
    BeamPart { a, b, c, face, slot, level, kind }
    BeamGpu { v => [v0, v1, v2], d => [d0, d1, d2], flux, bound, info }
    BeamHull { info, p }
    TriParams { n, r0, rows, quad_rows, cur_off, has_prev, max_edge, _pad }
    BlendParams { count, pass_index, _pad => [_pad0, _pad1] }
    ObjectTransform { model, normal }
    DisplayParams { width, height, exposure, _pad }
    BvhNode { lo, a, hi, count }
    RayQuery { o, d }
    RayResult { t, object, triangle, overflows, ng }
    QueryParams { count, any_hit, _pad => [_pad0, _pad1] }
    BvhTri { p0, p1, p2, n0, n1, n2 }
    BvhInstance { to_object, to_world, lo, hi, root, first_tri, object, _pad }
}
