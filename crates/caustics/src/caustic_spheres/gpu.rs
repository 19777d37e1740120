//! The run time of caustic spheres on the GPU: the tables uploaded once, and per frame the
//! records of every (directional light, caustic object, blended stored direction) and the
//! `sphere_gather` pass (`shaders/sphere_gather.wgsl`).
//!
//! Why one eye-space pass over the visible receivers rather than a caustic map per light: the
//! spheres already hold each light's caustic in 3D around the object, so a light costs one
//! table lookup per visible pixel and blended direction (three records), with no light-space
//! rasterization, photon tracing or splatting. D lights cost D × 3 lookups per pixel in one
//! dispatch (the paper's single-pass variant), and nothing is redone when a light turns.

use super::{Blend, CausticSpheres, DirectionLayout};
use crate::gpu::pass::Pass;
use crate::gpu::types::{SphereGatherParams, SphereRecord};
use crate::gpu::{GpuContext, PassTimer};
use crate::passes::{DrawCtx, EyeFrame, layer_view};
use crate::scene::Light;
use glam::{Affine3A, Quat, Vec3};
use std::sync::Arc;

/// The caustic spheres of a renderer: per caustic object, its table, on the GPU in one buffer
/// of `vec4<u32>`: per cell two (f32 bits: C, d) or, with half floats, one (the 8 values as
/// f16 pairs, `unpack2x16float`).
pub struct GpuSpheres {
    /// (object index, table, index of its first vec4 in `table`).
    pub objects: Vec<(usize, Arc<CausticSpheres>, u32)>,
    /// The table holds half floats.
    pub half: bool,
    /// Per object, its direction layout.
    pub layouts: Vec<DirectionLayout>,
    /// Every object's table.
    pub table: wgpu::Buffer,
    /// Bytes of `table`.
    pub bytes: u64,
    /// The compiled variant (section 6): per frame `sphere_compile` sums every record of an
    /// object into one compiled table, and `sphere_gather` looks up one record per object.
    pub compiled: bool,
    /// BVH stack entries the occlusion ray may use (`bvh_stack_limit` of `sphere_gather`;
    /// `crate::accel::BVH_STACK` unless a test lowers it to provoke overflows).
    pub stack_limit: u32,
    /// Points per pixel side of `sphere_gather`'s box filter ([`PIXEL_SAMPLES`] by default).
    pub pixel_samples: u32,
}

impl GpuSpheres {
    /// Uploads the tables (f32, or half floats: half the memory; a value beyond the f16 range
    /// is an error).
    pub fn new(ctx: &GpuContext, objects: Vec<(usize, Arc<CausticSpheres>)>, half: bool) -> crate::Result<GpuSpheres> {
        let mut data: Vec<[u32; 4]> = Vec::new();
        let mut out = Vec::new();
        let mut layouts = Vec::new();
        for (oi, sp) in objects {
            let base = data.len();
            if base > u32::MAX as usize {
                return Err(crate::Error::input("<renderer>", "caustic spheres", "tables over 2^32 vec4s"));
            }
            if half {
                let h = |v: f32| half::f16::from_f32(v).to_bits() as u32;
                if let Some(v) = sp.data.iter().flatten().find(|v| !half::f16::from_f32(**v).is_finite()) {
                    return Err(crate::Error::input(
                        "<command line>",
                        "--half",
                        format!("object {oi}: a caustic sphere value ({v}) is beyond the half-float range; use f32"),
                    ));
                }
                for c in &sp.data {
                    data.push([0, 2, 4, 6].map(|i| h(c[i]) | h(c[i + 1]) << 16));
                }
            } else {
                for c in &sp.data {
                    data.push([c[0], c[1], c[2], c[3]].map(f32::to_bits));
                    data.push([c[4], c[5], c[6], c[7]].map(f32::to_bits));
                }
            }
            layouts.push(DirectionLayout::new(sp.settings.directions));
            out.push((oi, sp, base as u32));
        }
        if data.is_empty() {
            data.push([0; 4]);
        }
        let bytes = (data.len() * 16) as u64;
        let max = ctx.device.limits().max_storage_buffer_binding_size;
        if bytes > max {
            return Err(crate::Error::input(
                "<settings>",
                "caustic_spheres",
                format!(
                    "caustic sphere tables of {bytes} bytes exceed the device's storage binding limit of {max} bytes"
                ),
            ));
        }
        let table = ctx.buffer_init("sphere_table", bytemuck::cast_slice(&data), wgpu::BufferUsages::STORAGE);
        Ok(GpuSpheres {
            objects: out,
            half,
            layouts,
            table,
            bytes,
            compiled: false,
            stack_limit: crate::accel::BVH_STACK as u32,
            pixel_samples: PIXEL_SAMPLES,
        })
    }

    /// The records of a frame: per directional light (world direction, irradiance), per object
    /// (moved by `transforms[object]` from the scene file's pose), per stored direction of the
    /// blend with a positive weight. `visibility(light, object)` scales a light's irradiance for
    /// one object (the environment's regions, occluded as seen from the object: section 5 of the
    /// paper; 1 for the scene's own lights).
    pub fn records(
        &self,
        lights: &[Light],
        transforms: &[Affine3A],
        blend: Blend,
        visibility: impl Fn(usize, usize) -> f32,
    ) -> Vec<SphereRecord> {
        let mut out = self.records_with(lights, transforms, blend, |li, oi| Err(visibility(li, oi)));
        out.iter_mut().for_each(|r| r.base[3] = 0);
        out
    }

    /// [`GpuSpheres::records`] with the visibility applied on the GPU (`sphere_weights`):
    /// `index(light, object)` is the visibility's index in its GPU buffer, or None (1). An
    /// indexed record carries the light's irradiance E (rgb) and its blend weight w (w), and
    /// its index in `base.w` (`u32::MAX` on the others).
    pub(crate) fn records_indexed(
        &self,
        lights: &[Light],
        transforms: &[Affine3A],
        blend: Blend,
        index: impl Fn(usize, usize) -> Option<u32>,
    ) -> Vec<SphereRecord> {
        self.records_with(lights, transforms, blend, |li, oi| index(li, oi).ok_or(1.0))
    }

    /// The records, `weight(light, object)` a visibility index (Ok) or a factor (Err).
    fn records_with(
        &self,
        lights: &[Light],
        transforms: &[Affine3A],
        blend: Blend,
        weight: impl Fn(usize, usize) -> Result<u32, f32>,
    ) -> Vec<SphereRecord> {
        let mut out = Vec::new();
        for (li, light) in lights.iter().enumerate() {
            let Light::Directional { direction, irradiance } = light else { continue };
            for ((oi, sp, base), layout) in self.objects.iter().zip(&self.layouts) {
                let (irradiance, index) = match weight(li, *oi) {
                    Ok(index) => (*irradiance, Some(index)),
                    Err(v) => (*irradiance * v, None),
                };
                if irradiance.max_element() <= 0.0 {
                    continue;
                }
                let inv = transforms[*oi].inverse();
                let l = (glam::Mat3::from(inv.matrix3) * *direction).normalize();
                let m = glam::Mat4::from(inv);
                let to_obj = [m.row(0).to_array(), m.row(1).to_array(), m.row(2).to_array()];
                let g = &sp.geometry;
                let s = g.radii.len();
                let stride = if self.half { 1 } else { 2 };
                let cells = (s * g.cells()) as u32 * stride;
                for (k, w) in layout.weights(l, blend) {
                    if w <= 0.0 {
                        continue;
                    }
                    let wk = sp.layout_dirs[k as usize];
                    let r = Quat::from_rotation_arc(wk, l);
                    let (a, b) = super::basis(wk);
                    let rm = glam::Mat3::from_quat(r);
                    let row = |v: Vec3| v.extend(0.0).to_array();
                    out.push(SphereRecord {
                        to_obj,
                        axes: [row(r * a), row(r * b), row(r * wk)],
                        rot: [row(rm.row(0)), row(rm.row(1)), row(rm.row(2))],
                        center: g.center.extend(g.radii[0]).to_array(),
                        shape: [g.radii[s - 1], s as f32, g.width as f32, g.height as f32],
                        irradiance: match index {
                            Some(_) => irradiance.extend(w).to_array(),
                            None => (irradiance * w).extend(0.0).to_array(),
                        },
                        base: [base + k * cells, *oi as u32, self.half as u32, index.unwrap_or(u32::MAX)],
                    });
                }
            }
        }
        out
    }
}

/// The directional lights whose caustics the spheres draw, spread over the environment
/// regions' sub-directions (`crate::env_taps`): `lights` is the frame's light list (the scene's
/// `own` lights, then one per non-black region), `taps` the sub-directions of every region
/// (map frame, black regions included, in the order of the segmentation), `rotation` the
/// environment's. A region with taps becomes one directional light per sub-direction k, from
/// its direction with the region light's irradiance times its weight (the sub-region's total
/// `Σ L Ω`: what a ball intercepts of it, whatever the spread); a region without taps stays one
/// light. The renderer's visibility of the environment (`super::visibility`, on the GPU) has
/// one value per light returned, each sub-region's own. The records are cheap where the basic technique's taps are lookups
/// of one turned map: a sub-direction is three more table lookups per pixel, exact for any
/// caster (the table has every direction), not only for casters symmetric about their centre.
pub fn spread_lights(
    lights: &[Light],
    own: usize,
    taps: &[crate::env_taps::RegionTaps],
    drawn: &[bool],
    rotation: glam::Mat3,
) -> Vec<Light> {
    let mut out: Vec<Light> = lights[..own.min(lights.len())].to_vec();
    let regions = taps.iter().zip(drawn).filter(|(_, d)| **d).map(|(t, _)| t);
    for (light, t) in lights.iter().skip(own).zip(regions) {
        match light {
            Light::Directional { irradiance, .. } if !t.is_empty() => {
                for (dir, w) in t {
                    let direction = -(rotation * *dir).normalize();
                    out.push(Light::Directional { direction, irradiance: *irradiance * *w });
                }
            }
            _ => out.push(light.clone()),
        }
    }
    out
}

impl GpuSpheres {
    /// Vec4s of one object's compiled table (three per cell).
    fn compiled_len(sp: &CausticSpheres) -> u32 {
        (sp.geometry.radii.len() * sp.geometry.cells() * 3) as u32
    }

    /// The compiled variant's records: per caustic object (moved by `transforms[object]`), one
    /// record of its compiled table: its own spheres and cells in a fixed frame of the object
    /// (pole straight down in the scene file's pose, where light from above goes), `base.x`
    /// the table's first vec4 in the compiled buffer.
    pub fn compiled_records(&self, transforms: &[Affine3A]) -> Vec<SphereRecord> {
        let mut base = 0u32;
        let mut out = Vec::new();
        for (oi, sp, _) in &self.objects {
            let inv = transforms[*oi].inverse();
            let m = glam::Mat4::from(inv);
            let g = &sp.geometry;
            let s = g.radii.len();
            let w = Vec3::NEG_Y;
            let (a, b) = super::basis(w);
            let row = |v: Vec3| v.extend(0.0).to_array();
            out.push(SphereRecord {
                to_obj: [m.row(0).to_array(), m.row(1).to_array(), m.row(2).to_array()],
                axes: [row(a), row(b), row(w)],
                rot: [row(Vec3::X), row(Vec3::Y), row(Vec3::Z)],
                center: g.center.extend(g.radii[0]).to_array(),
                shape: [g.radii[s - 1], s as f32, g.width as f32, g.height as f32],
                irradiance: [1.0, 1.0, 1.0, 0.0],
                base: [base, *oi as u32, 2, 0],
            });
            base += Self::compiled_len(sp);
        }
        out
    }
}

/// Records `sphere_compile` (the compiled variant, section 6 of the paper): per caustic object
/// one dispatch over its compiled table's cells summing `records` of that object (`records`
/// holds each object's records contiguously, in the order of `objects`). Returns the compiled
/// buffer that `sphere_gather` reads with the `objects` records. `weighted`: the records as
/// `sphere_weights` wrote them on the GPU (the same count and order, dropped ones black).
pub(crate) fn record_compile(
    dc: &DrawCtx,
    spheres: &GpuSpheres,
    (records, weighted): (&[SphereRecord], Option<&wgpu::Buffer>),
    objects: &[SphereRecord],
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> wgpu::Buffer {
    use crate::gpu::types::SphereCompileParams;
    let ctx = dc.ctx;
    let total: u64 = spheres.objects.iter().map(|(_, sp, _)| u64::from(GpuSpheres::compiled_len(sp))).sum();
    let compiled = ctx.buffer("sphere_compiled", total.max(1) * 16, wgpu::BufferUsages::STORAGE);
    let zero = [SphereRecord::zeroed_record()];
    let recs = if records.is_empty() { &zero[..] } else { records };
    let rb = match weighted {
        Some(b) => b.clone(),
        None => ctx.buffer_init("sphere_compile_records", bytemuck::cast_slice(recs), wgpu::BufferUsages::STORAGE),
    };
    let mut first = 0u32;
    for ((_, sp, _), obj) in spheres.objects.iter().zip(objects) {
        let count = records[first as usize..].iter().take_while(|r| r.base[1] == obj.base[1]).count() as u32;
        let cells = (sp.geometry.radii.len() * sp.geometry.cells()) as u32;
        let params = ctx.uniform(
            "sphere_compile_params",
            bytemuck::bytes_of(&SphereCompileParams { first, count, cells, out_base: obj.base[0] }),
        );
        let ob = ctx.buffer_init("sphere_compile_object", bytemuck::bytes_of(obj), wgpu::BufferUsages::STORAGE);
        Pass::new(ctx, "sphere_compile")
            .bind("cp", &params)
            .bind("object", &ob)
            .bind("records", &rb)
            .bind("table", &spheres.table)
            .bind("compiled", &compiled)
            .dispatch(enc, timer, [cells.div_ceil(64), 1, 1]);
        first += count;
    }
    compiled
}

/// Points per pixel side at which `sphere_gather` looks the tables up (a box filter over the
/// pixel's footprint on the receiver's tangent plane, `shaders/sphere_gather.wgsl`). One point
/// at the pixel's centre under- or over-states a focus narrower than the pixel at random: on
/// `glass_sphere_sky` at 128 × 96 under one sun at 48°, 0.57 of the CPU reference's caustic
/// energy with 1 point, 1.04 with 8 × 8 (CPU evaluation; docs/benchmarks.md). The cost of the
/// lookups grows as its square.
pub const PIXEL_SAMPLES: u32 = 3;

/// Records `sphere_gather`: adds the caustic radiance of `records` to the eye's diffuse
/// radiance and caustic buffers. Returns its statistics buffer (8 bytes; the first u32 counts
/// the occlusion rays that overflowed the BVH stack) for the frame's statistics.
pub(crate) fn record_gather(
    dc: &DrawCtx,
    eye: &EyeFrame,
    (spheres, table): (&GpuSpheres, &wgpu::Buffer),
    records: Records,
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) -> wgpu::Buffer {
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    // A homogeneous medium attenuates the light's path to the receiver (a density grid: not
    // modelled here, as in `sphere_volume`).
    let medium = dc.scene.medium.as_ref().filter(|m| m.density.is_none());
    // The records that get every point of the box filter however many there are: those with at
    // least a 32nd of all records' irradiance (luminance r + g + b).
    // (Records written on the GPU: `sphere_weights` computes it, copied in below.)
    let lum = |r: &SphereRecord| r.irradiance[0] + r.irradiance[1] + r.irradiance[2];
    let heavy = records.cpu().iter().map(lum).sum::<f32>() / 32.0;
    // Rewritten (zeroed) every frame: a storage buffer from `buffer_init`.
    let counters =
        ctx.buffer_init("sphere_gather_stats", &[0u8; 8], wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC);
    let params = ctx.uniform(
        "sphere_gather_params",
        bytemuck::bytes_of(&SphereGatherParams {
            width: w,
            height: h,
            records: records.len(),
            samples: spheres.pixel_samples,
            camera: cam.position.extend(1.0).to_array(),
            medium_lo: medium.map_or([0.0; 4], |m| m.bounds_min.extend(1.0).to_array()),
            medium_hi: medium.map_or([0.0; 4], |m| m.bounds_max.extend(0.0).to_array()),
            sigma_t: medium.map_or(Vec3::ZERO, |m| m.sigma_s + m.sigma_a).extend(heavy).to_array(),
        }),
    );
    let rb = records.buffer(ctx, "sphere_records");
    if let Records::Gpu { counts, .. } = records {
        use crate::gpu::types::SphereGatherParams as P;
        enc.copy_buffer_to_buffer(counts, 0, &params, std::mem::offset_of!(P, records) as u64, 4);
        enc.copy_buffer_to_buffer(counts, 4, &params, std::mem::offset_of!(P, sigma_t) as u64 + 12, 4);
    }
    let (erp, ern) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.recv.nrm, 0));
    Pass::new(ctx, "sphere_gather")
        .constants(&[("bvh_stack_limit", f64::from(spheres.stack_limit))])
        .bind("gp", &params)
        .bind("eye_pos", &erp)
        .bind("eye_nrm", &ern)
        .shared(&dc.geo.scene)
        .bind("records", &rb)
        .bind("table", table)
        .bind("radiance", &eye.radiance)
        .bind("caustic", &eye.caustic)
        .bind("gather_stats", &counters)
        .dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
    counters
}

/// Records `sphere_volume` (volumetric caustics from the spheres, `shaders/sphere_volume.wgsl`)
/// for a scene with a homogeneous medium: the single scattering of the caustic light of
/// `records` (the direct records, one per light, object and blended direction: the compiled
/// table's summed vectors lose the fluence where light crosses from several sides) along each
/// pixel's camera ray, added into the composited images `images` (full, caustic-only) after
/// `medium_scatter` attenuated them. Nothing without a medium, with a density grid (not
/// modelled) or without records.
pub(crate) fn record_volume(
    dc: &DrawCtx,
    eye: &EyeFrame,
    (table, records): (&wgpu::Buffer, Records),
    steps: u32,
    images: (&wgpu::Buffer, &wgpu::Buffer),
    enc: &mut wgpu::CommandEncoder,
    timer: &mut PassTimer,
) {
    use crate::gpu::types::SphereVolumeParams;
    let Some(m) = &dc.scene.medium else { return };
    if m.density.is_some() || records.len() == 0 || m.sigma_s.max_element() <= 0.0 {
        return;
    }
    let ctx = dc.ctx;
    let cam = &dc.scene.camera;
    let (w, h) = (cam.width, cam.height);
    let g = match m.phase {
        crate::scene::Phase::Isotropic => 0.0,
        crate::scene::Phase::HenyeyGreenstein { g } => g,
    };
    let params = ctx.uniform(
        "sphere_volume_params",
        bytemuck::bytes_of(&SphereVolumeParams {
            clip_to_world: eye.cam_clip.inverse().to_cols_array_2d(),
            camera: cam.position.extend(1.0).to_array(),
            lo: m.bounds_min.extend(0.0).to_array(),
            hi: m.bounds_max.extend(0.0).to_array(),
            sigma_s: m.sigma_s.extend(g).to_array(),
            sigma_t: (m.sigma_s + m.sigma_a).extend(0.0).to_array(),
            width: w,
            height: h,
            steps: steps.max(1),
            records: records.len(),
        }),
    );
    let rb = records.buffer(ctx, "sphere_volume_records");
    if let Records::Gpu { counts, .. } = records {
        use crate::gpu::types::SphereVolumeParams as P;
        enc.copy_buffer_to_buffer(counts, 0, &params, std::mem::offset_of!(P, records) as u64, 4);
    }
    let (rv, sv) = (layer_view(ctx, &eye.recv.pos, 0), layer_view(ctx, &eye.front.pos, 0));
    Pass::new(ctx, "sphere_volume")
        .bind("vp", &params)
        .bind("recv_pos", &rv)
        .bind("spec_pos", &sv)
        .bind("records", &rb)
        .bind("table", table)
        .bind("out_full", images.0)
        .bind("out_caustic", images.1)
        .dispatch(enc, timer, [w.div_ceil(8), h.div_ceil(8), 1]);
}

/// A frame's records, as `sphere_gather` and `sphere_volume` read them.
#[derive(Clone, Copy)]
pub(crate) enum Records<'a> {
    /// Written by the CPU.
    Cpu(&'a [SphereRecord]),
    /// Written by `sphere_weights`: up to `len` in `buffer`; `counts` holds how many (u32) and
    /// `sphere_gather`'s full-filter threshold (f32 bits), copied into the passes' parameters.
    Gpu { buffer: &'a wgpu::Buffer, len: u32, counts: &'a wgpu::Buffer },
}

impl Records<'_> {
    /// The records' count as the CPU knows it (on the GPU: at most that many are kept).
    fn len(&self) -> u32 {
        match self {
            Records::Cpu(r) => r.len() as u32,
            Records::Gpu { len, .. } => *len,
        }
    }

    /// The CPU's records (none for those written on the GPU).
    fn cpu(&self) -> &[SphereRecord] {
        match self {
            Records::Cpu(r) => r,
            Records::Gpu { .. } => &[],
        }
    }

    /// The storage buffer of the records (a CPU list uploaded as `label`, one zeroed record
    /// when empty).
    fn buffer(&self, ctx: &GpuContext, label: &str) -> wgpu::Buffer {
        match self {
            Records::Cpu(records) => {
                let zero = [SphereRecord::zeroed_record()];
                let recs = if records.is_empty() { &zero[..] } else { records };
                ctx.buffer_init(label, bytemuck::cast_slice(recs), wgpu::BufferUsages::STORAGE)
            }
            Records::Gpu { buffer, .. } => (*buffer).clone(),
        }
    }
}

impl SphereRecord {
    fn zeroed_record() -> SphereRecord {
        bytemuck::Zeroable::zeroed()
    }
}
