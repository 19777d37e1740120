//! The GPU side: device creation, shader loading, timing and readback. Techniques live in
//! [`crate::render`].

pub(crate) mod pass;
pub mod pool;
pub mod types;

pub use pool::ResourceCounts;
use pool::{BoundKey, LayoutOf, Slot, TextureKey, keep};

use crate::error::{Error, Result};
use std::sync::mpsc;

/// Every WGSL stage, with its source. Each is prepended with `shaders/shared/common.wgsl`.
pub const STAGES: &[(&str, &str)] = &[
    ("raster", include_str!("../../shaders/raster.wgsl")),
    ("raster_peel", include_str!("../../shaders/raster_peel.wgsl")),
    ("photon_trace", include_str!("../../shaders/photon_trace.wgsl")),
    ("photon_splat", include_str!("../../shaders/photon_splat.wgsl")),
    ("caustic_resolve", include_str!("../../shaders/caustic_resolve.wgsl")),
    ("temporal_filter", include_str!("../../shaders/temporal_filter.wgsl")),
    ("shade_receivers", include_str!("../../shaders/shade_receivers.wgsl")),
    ("caustic_mask", include_str!("../../shaders/caustic_mask.wgsl")),
    ("shadow_tiles", include_str!("../../shaders/shadow_tiles.wgsl")),
    ("sphere_gather", include_str!("../../shaders/sphere_gather.wgsl")),
    ("sphere_compile", include_str!("../../shaders/sphere_compile.wgsl")),
    ("sphere_volume", include_str!("../../shaders/sphere_volume.wgsl")),
    ("composite", include_str!("../../shaders/composite.wgsl")),
    ("medium_scatter", include_str!("../../shaders/medium_scatter.wgsl")),
    ("coverage_mip", include_str!("../../shaders/coverage_mip.wgsl")),
    ("adaptive_plan", include_str!("../../shaders/adaptive_plan.wgsl")),
    ("adaptive_init", include_str!("../../shaders/adaptive_init.wgsl")),
    ("adaptive_setup", include_str!("../../shaders/adaptive_setup.wgsl")),
    ("adaptive_refine", include_str!("../../shaders/adaptive_refine.wgsl")),
    ("hcm_traverse", include_str!("../../shaders/hcm_traverse.wgsl")),
    ("splat_lens", include_str!("../../shaders/splat_lens.wgsl")),
    ("splat_multires", include_str!("../../shaders/splat_multires.wgsl")),
    ("splat_multires_blend", include_str!("../../shaders/splat_multires_blend.wgsl")),
    ("caustic_triangles", include_str!("../../shaders/caustic_triangles.wgsl")),
    ("splat_quads", include_str!("../../shaders/splat_quads.wgsl")),
    ("display", include_str!("../../shaders/display.wgsl")),
    ("ray_query", include_str!("../../shaders/ray_query.wgsl")),
    ("medium_bounce_lights", include_str!("../../shaders/medium_bounce_lights.wgsl")),
    ("medium_bounce", include_str!("../../shaders/medium_bounce.wgsl")),
    ("medium_bounce_beams", include_str!("../../shaders/medium_bounce_beams.wgsl")),
    ("medium_bounce_glow", include_str!("../../shaders/medium_bounce_glow.wgsl")),
    ("medium_bounce_shafts", include_str!("../../shaders/medium_bounce_shafts.wgsl")),
    ("medium_bounce_surfaces", include_str!("../../shaders/medium_bounce_surfaces.wgsl")),
    ("beam_refine", include_str!("../../shaders/beam_refine.wgsl")),
    ("beam_shrink", include_str!("../../shaders/beam_shrink.wgsl")),
    ("beam_order", include_str!("../../shaders/beam_order.wgsl")),
    ("beam_order_runs", include_str!("../../shaders/beam_order_runs.wgsl")),
    ("beam_gather", include_str!("../../shaders/beam_gather.wgsl")),
    ("beam_surface", include_str!("../../shaders/beam_surface.wgsl")),
    ("beam_hull", include_str!("../../shaders/beam_hull.wgsl")),
    ("beam_raster", include_str!("../../shaders/beam_raster.wgsl")),
    ("beam_surface_raster", include_str!("../../shaders/beam_surface_raster.wgsl")),
    ("beam_resolve", include_str!("../../shaders/beam_resolve.wgsl")),
];
pub const COMMON_WGSL: &str = include_str!("../../shaders/shared/common.wgsl");

/// Shared WGSL modules a stage can pull in with a line `#import NAME`.
pub const SHARED: &[(&str, &str)] = &[
    ("shapes", include_str!("../../shaders/shared/shapes.wgsl")),
    ("raster_common", include_str!("../../shaders/shared/raster_common.wgsl")),
    ("raytrace", include_str!("../../shaders/shared/raytrace.wgsl")),
    ("trace", include_str!("../../shaders/shared/trace.wgsl")),
    ("hierarchy", include_str!("../../shaders/shared/hierarchy.wgsl")),
    ("coverage", include_str!("../../shaders/shared/coverage.wgsl")),
    ("splat", include_str!("../../shaders/shared/splat.wgsl")),
    ("triangles", include_str!("../../shaders/shared/triangles.wgsl")),
    ("environment", include_str!("../../shaders/shared/environment.wgsl")),
    ("medium", include_str!("../../shaders/shared/medium.wgsl")),
    ("medium_bounce", include_str!("../../shaders/shared/medium_bounce.wgsl")),
    ("medium_emit", include_str!("../../shaders/shared/medium_emit.wgsl")),
    ("beams", include_str!("../../shaders/shared/beams.wgsl")),
    ("beam_medium", include_str!("../../shaders/shared/beam_medium.wgsl")),
    ("beam_trace", include_str!("../../shaders/shared/beam_trace.wgsl")),
    ("beam_scatter", include_str!("../../shaders/shared/beam_scatter.wgsl")),
    ("beam_receive", include_str!("../../shaders/shared/beam_receive.wgsl")),
    ("beam_fan", include_str!("../../shaders/shared/beam_fan.wgsl")),
    ("sphere_table", include_str!("../../shaders/shared/sphere_table.wgsl")),
];

/// Build a pipeline with `make`; with the environment variable `CAUSTICS_LOG_PIPELINES` set,
/// say on stderr which pipeline is being built before the driver compiles it and how long that
/// took after, so that a driver whose shader compiler stalls on one stage names it (a device's
/// compiler runs inside `create_*_pipeline`, on the calling thread, before any GPU work).
fn logged_build<T>(kind: &str, name: &str, make: impl FnOnce() -> T) -> T {
    if std::env::var_os("CAUSTICS_LOG_PIPELINES").is_none() {
        return make();
    }
    eprintln!("pipeline {kind} {name}: building");
    let t0 = std::time::Instant::now();
    let p = make();
    eprintln!("pipeline {kind} {name}: {:.1} ms", t0.elapsed().as_secs_f64() * 1e3);
    p
}

/// Full source of a stage: the shared code, then the stage with its `#import` lines replaced by
/// the modules they name (a tiny preprocessor, as vello does; WGSL has no includes).
pub fn stage_source(name: &str) -> String {
    let src =
        STAGES.iter().find(|(n, _)| *n == name).map(|(_, s)| *s).unwrap_or_else(|| panic!("no shader stage {name}"));
    let mut out = String::from(COMMON_WGSL);
    out.push('\n');
    for line in src.lines() {
        match line.trim().strip_prefix("#import ") {
            Some(module) => {
                let m = SHARED
                    .iter()
                    .find(|(n, _)| *n == module.trim())
                    .unwrap_or_else(|| panic!("{name}: no shared module {module}"));
                out.push_str(m.1);
            }
            None => out.push_str(line),
        }
        out.push('\n');
    }
    out
}

/// Validate a stage with naga (the tests do this for every stage).
pub fn validate_stage(name: &str) -> Result<naga::Module> {
    parse_stage(name).map(|(module, _)| module)
}

/// Stage `name` parsed and validated by naga, with what each function uses.
fn parse_stage(name: &str) -> Result<(naga::Module, naga::valid::ModuleInfo)> {
    let src = stage_source(name);
    let module = naga::front::wgsl::parse_str(&src)
        .map_err(|e| Error::Shader { name: name.into(), message: e.emit_to_string(&src) })?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| Error::Shader { name: name.into(), message: format!("{e:?}") })?;
    Ok((module, info))
}

/// Group 0 of compute stage `name` as layout entries: every binding its `main` uses, typed from
/// the WGSL (naga reflection). Float textures are non-filterable (the stages read them with
/// `textureLoad`; a stage with a filtering sampler is refused).
pub fn stage_bindings(name: &str) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    entry_bindings(name, &[("main", wgpu::ShaderStages::COMPUTE)])
}

/// Group 0 of render stage `name` (entry points `vs_main` and `fs_main`) as layout entries,
/// every binding either uses, visible to those that use it (as [`stage_bindings`] for compute
/// stages).
pub fn render_stage_bindings(name: &str) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    entry_bindings(name, &[("vs_main", wgpu::ShaderStages::VERTEX), ("fs_main", wgpu::ShaderStages::FRAGMENT)])
}

/// Group 0 of stage `name` as its entry points (name, stage) use it.
fn entry_bindings(name: &str, entries_of: &[(&str, wgpu::ShaderStages)]) -> Result<Vec<wgpu::BindGroupLayoutEntry>> {
    let (module, info) = parse_stage(name)?;
    let mut uses = Vec::new();
    for (entry, stage) in entries_of {
        let ep = module
            .entry_points
            .iter()
            .position(|e| e.name == *entry)
            .ok_or_else(|| Error::Shader { name: name.into(), message: format!("no entry point {entry}") })?;
        uses.push((info.get_entry_point(ep), *stage));
    }
    let mut entries = Vec::new();
    for (handle, var) in module.global_variables.iter() {
        let Some(binding) = &var.binding else { continue };
        let visibility = uses
            .iter()
            .filter(|(u, _)| !u[handle].is_empty())
            .fold(wgpu::ShaderStages::NONE, |v, (_, stage)| v | *stage);
        if visibility.is_empty() {
            continue;
        }
        let bad = |m: &str| Error::Shader { name: name.into(), message: format!("binding {}: {m}", binding.binding) };
        if binding.group != 0 {
            return Err(bad("only group 0 is used"));
        }
        let ty = match (&module.types[var.ty].inner, var.space) {
            (_, naga::AddressSpace::Uniform) => wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            (_, naga::AddressSpace::Storage { access }) => wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: access == naga::StorageAccess::LOAD },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            (naga::TypeInner::Sampler { comparison: true }, _) => {
                wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison)
            }
            (naga::TypeInner::Sampler { comparison: false }, _) => return Err(bad("filtering samplers are not used")),
            (naga::TypeInner::Image { dim, arrayed, class }, _) => {
                let view_dimension = match (dim, arrayed) {
                    (naga::ImageDimension::D2, false) => wgpu::TextureViewDimension::D2,
                    (naga::ImageDimension::D2, true) => wgpu::TextureViewDimension::D2Array,
                    // A medium's density grid.
                    (naga::ImageDimension::D3, false) => wgpu::TextureViewDimension::D3,
                    _ => return Err(bad("only 2D textures, 2D arrays and 3D textures are used")),
                };
                match class {
                    naga::ImageClass::Sampled { kind, multi } => wgpu::BindingType::Texture {
                        sample_type: match kind {
                            naga::ScalarKind::Float => wgpu::TextureSampleType::Float { filterable: false },
                            naga::ScalarKind::Uint => wgpu::TextureSampleType::Uint,
                            _ => wgpu::TextureSampleType::Sint,
                        },
                        view_dimension,
                        multisampled: *multi,
                    },
                    naga::ImageClass::Depth { multi } => wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Depth,
                        view_dimension,
                        multisampled: *multi,
                    },
                    naga::ImageClass::Storage { format: naga::StorageFormat::Rgba8Unorm, access }
                        if *access == naga::StorageAccess::STORE =>
                    {
                        wgpu::BindingType::StorageTexture {
                            access: wgpu::StorageTextureAccess::WriteOnly,
                            format: wgpu::TextureFormat::Rgba8Unorm,
                            view_dimension,
                        }
                    }
                    _ => return Err(bad("unsupported texture class")),
                }
            }
            _ => return Err(bad("unsupported binding")),
        };
        entries.push(wgpu::BindGroupLayoutEntry { binding: binding.binding, visibility, ty, count: None });
    }
    entries.sort_by_key(|e| e.binding);
    Ok(entries)
}

/// A storage buffer (zeroed; at least 16 bytes) of the open scope.
pub(crate) fn storage(ctx: &GpuContext, label: &str, size: u64, extra: wgpu::BufferUsages) -> wgpu::Buffer {
    ctx.buffer(label, size.max(16), wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | extra)
}

pub(crate) fn uniform(ctx: &GpuContext, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    ctx.uniform(label, bytes)
}

/// A device and queue, and what the adapter can do.
#[derive(Clone)]
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// Timestamp queries are available (pass timings are measured on the GPU).
    pub timestamps: bool,
    /// Pipelines already built, by name: a frame after the first compiles no shader.
    /// Clones of a context share these: pipelines, and the resources kept from frame to frame
    /// with the count of those created ([`pool`]).
    compute_cache: std::sync::Arc<std::sync::Mutex<std::collections::HashMap<String, wgpu::ComputePipeline>>>,
    render_cache: std::sync::Arc<std::sync::Mutex<std::collections::HashMap<String, wgpu::RenderPipeline>>>,
    /// Bind group layouts by their entries: stages with the same interface share one.
    layouts: std::sync::Arc<
        std::sync::Mutex<std::collections::HashMap<Vec<wgpu::BindGroupLayoutEntry>, wgpu::BindGroupLayout>>,
    >,
    pool: std::sync::Arc<std::sync::Mutex<pool::Pool>>,
}

fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    if std::env::var_os("WGPU_BACKEND").is_none() {
        desc.backends = wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12;
    }
    wgpu::Instance::new(desc)
}

/// Every adapter wgpu can see.
pub fn list_adapters() -> Vec<wgpu::Adapter> {
    pollster::block_on(instance().enumerate_adapters(wgpu::Backends::all()))
}

impl GpuContext {
    /// Open the first adapter whose name contains `name` (case-insensitive), or the default
    /// high-performance adapter (a software one, such as lavapipe, if nothing else exists).
    pub fn new(name: Option<&str>) -> Result<GpuContext> {
        let inst = instance();
        let adapters = pollster::block_on(inst.enumerate_adapters(wgpu::Backends::all()));
        let adapter = match name {
            Some(n) => {
                let n = n.to_lowercase();
                adapters
                    .into_iter()
                    .find(|a| a.get_info().name.to_lowercase().contains(&n))
                    .ok_or_else(|| Error::input("<settings>", "adapter", format!("no adapter named like \"{n}\"")))?
            }
            None => {
                let mut best = None;
                for a in adapters {
                    let rank = match a.get_info().device_type {
                        wgpu::DeviceType::DiscreteGpu => 0,
                        wgpu::DeviceType::IntegratedGpu => 1,
                        wgpu::DeviceType::VirtualGpu => 2,
                        wgpu::DeviceType::Cpu => 3,
                        wgpu::DeviceType::Other => 4,
                    };
                    if best.as_ref().is_none_or(|(r, _)| rank < *r) {
                        best = Some((rank, a));
                    }
                }
                best.map(|(_, a)| a).ok_or_else(|| {
                    Error::NoAdapter(
                        "no Vulkan, Metal or DX12 adapter was found. Install a GPU driver, or Mesa's software Vulkan driver (Debian/Ubuntu: `apt-get install mesa-vulkan-drivers`), or render with the CPU reference".into(),
                    )
                })?
            }
        };
        let info = adapter.get_info();
        let (required, limits) = GpuContext::device_requirements(&adapter);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("caustics"),
            required_features: required,
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| Error::Device(format!("cannot open {}: {e}", info.name)))?;
        Ok(GpuContext::from_device(&device, &queue))
    }

    /// The features and limits the renderer needs of a device made from `adapter`: request
    /// these when creating the device an engine shares with [`crate::renderer::Renderer`].
    pub fn device_requirements(adapter: &wgpu::Adapter) -> (wgpu::Features, wgpu::Limits) {
        let mut required = wgpu::Features::empty();
        // Optional features, used where the adapter has them: pass timings, and float32 blending
        // (the beams' hulls, `BeamVolume::Hulls`).
        for f in [wgpu::Features::TIMESTAMP_QUERY, wgpu::Features::FLOAT32_BLENDABLE] {
            if adapter.features().contains(f) {
                required |= f;
            }
        }
        let al = adapter.limits();
        let limits = wgpu::Limits {
            max_storage_buffer_binding_size: al.max_storage_buffer_binding_size,
            max_buffer_size: al.max_buffer_size,
            max_texture_dimension_2d: al.max_texture_dimension_2d,
            max_compute_workgroups_per_dimension: al.max_compute_workgroups_per_dimension,
            max_storage_buffers_per_shader_stage: al.max_storage_buffers_per_shader_stage.min(16),
            max_sampled_textures_per_shader_stage: al.max_sampled_textures_per_shader_stage.min(16),
            ..wgpu::Limits::default()
        };
        (required, limits)
    }

    /// A context on a device the caller made (with at least [`GpuContext::device_requirements`]);
    /// device and queue are shared handles, so the caller keeps using its own.
    pub fn from_device(device: &wgpu::Device, queue: &wgpu::Queue) -> GpuContext {
        GpuContext {
            device: device.clone(),
            queue: queue.clone(),
            info: device.adapter_info(),
            timestamps: device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
            compute_cache: Default::default(),
            render_cache: Default::default(),
            layouts: Default::default(),
            pool: Default::default(),
        }
    }

    /// Whether the device meets the renderer's needs; the error names the limit that falls short.
    pub fn check_device(&self) -> Result<()> {
        let l = self.device.limits();
        let need = [
            ("max_storage_buffers_per_shader_stage", l.max_storage_buffers_per_shader_stage, 8),
            ("max_sampled_textures_per_shader_stage", l.max_sampled_textures_per_shader_stage, 16),
        ];
        for (name, have, want) in need {
            if have < want {
                return Err(Error::Device(format!(
                    "the device's {name} is {have}; the renderer needs {want} (create the device with caustics::gpu::GpuContext::device_requirements)"
                )));
            }
        }
        Ok(())
    }

    /// A compute or render shader module for a stage.
    pub fn shader(&self, name: &str) -> wgpu::ShaderModule {
        let src = stage_source(name);
        self.device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(name),
            source: wgpu::ShaderSource::Wgsl(src.into()),
        })
    }

    /// A compute pipeline (layout derived from the shader) for a stage's `main`, built once per
    /// context.
    pub fn compute_pipeline(&self, name: &str) -> wgpu::ComputePipeline {
        self.compute_pipeline_with(name, &[])
    }

    /// A compute pipeline built once per context with the given values of the stage's
    /// pipeline-overridable constants (cached by name and values).
    pub fn compute_pipeline_with(&self, name: &str, constants: &[(&str, f64)]) -> wgpu::ComputePipeline {
        let key = if constants.is_empty() { name.to_string() } else { format!("{name}{constants:?}") };
        let mut cache = self.compute_cache.lock().unwrap_or_else(|e| e.into_inner());
        cache
            .entry(key)
            .or_insert_with(|| {
                logged_build("compute", name, || {
                    let module = self.shader(name);
                    let layout = self.stage_layout(name);
                    self.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(name),
                        layout: Some(&layout),
                        module: &module,
                        entry_point: Some("main"),
                        compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
                        cache: None,
                    })
                })
            })
            .clone()
    }

    /// The pipeline layout of compute stage `name`: group 0 as its WGSL declares it (the
    /// bindings its entry point uses, as wgpu's derived layouts have them), with the bind group
    /// layout shared by every stage whose group 0 is the same.
    pub fn stage_layout(&self, name: &str) -> wgpu::PipelineLayout {
        self.layout_of(name, stage_bindings(name).unwrap_or_else(|e| panic!("{e}")))
    }

    /// The pipeline layout of render stage `name` ([`render_stage_bindings`]).
    pub fn render_stage_layout(&self, name: &str) -> wgpu::PipelineLayout {
        self.layout_of(name, render_stage_bindings(name).unwrap_or_else(|e| panic!("{e}")))
    }

    fn layout_of(&self, name: &str, entries: Vec<wgpu::BindGroupLayoutEntry>) -> wgpu::PipelineLayout {
        let bgl = self
            .layouts
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(entries.clone())
            .or_insert_with(|| {
                self.device
                    .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(name), entries: &entries })
            })
            .clone();
        self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: &[Some(&bgl)],
            immediate_size: 0,
        })
    }

    /// Distinct bind group layouts of the compute stages built so far.
    pub fn shared_layouts(&self) -> usize {
        self.layouts.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// A render pipeline built once per context by `make`, under `name`.
    pub fn render_pipeline(&self, name: &str, make: impl FnOnce() -> wgpu::RenderPipeline) -> wgpu::RenderPipeline {
        let mut cache = self.render_cache.lock().unwrap_or_else(|e| e.into_inner());
        cache.entry(name.to_string()).or_insert_with(|| logged_build("render", name, make)).clone()
    }

    /// A context on the same device, sharing the pipelines, with a resource pool (and creation
    /// count) of its own: what a renderer works in.
    pub fn with_own_pool(&self) -> GpuContext {
        GpuContext { pool: Default::default(), ..self.clone() }
    }

    fn pool(&self) -> std::sync::MutexGuard<'_, pool::Pool> {
        self.pool.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// GPU objects created through this context so far.
    pub fn created(&self) -> ResourceCounts {
        self.pool().counts
    }

    /// Open the resource scope `name` ([`pool`]): its requests are answered, in order, by the
    /// resources it handed out last time; those of them that were handed out as fresh storage
    /// buffers are cleared first, in `enc`.
    pub fn begin_scope(&self, name: &str, enc: &mut wgpu::CommandEncoder) {
        let mut pool = self.pool();
        let scope = pool.scopes.entry(name.to_string()).or_default();
        scope.cursor = 0;
        for slot in &scope.slots {
            if let Slot::Buffer { zeroed: true, buffer, .. } = slot {
                enc.clear_buffer(buffer, 0, None);
            }
        }
        pool.current = Some(name.to_string());
    }

    /// Close the open scope; what it did not ask for this time is released.
    pub fn end_scope(&self) {
        let mut pool = self.pool();
        if let Some(name) = pool.current.take()
            && let Some(scope) = pool.scopes.get_mut(&name)
        {
            scope.slots.truncate(scope.cursor);
        }
    }

    /// Release every kept resource of the scopes whose name starts with `prefix`.
    pub fn drop_scopes(&self, prefix: &str) {
        self.pool().scopes.retain(|name, _| !name.starts_with(prefix));
    }

    /// A buffer its owner keeps itself across frames (not pooled; counted).
    pub fn kept_buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.pool().counts.buffers += 1;
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage,
            mapped_at_creation: false,
        })
    }

    /// The open scope's next resource: the kept one if `reuse` accepts its slot, else one `make`
    /// creates (counted), kept as `keep_as` says. Outside a scope, `make` alone.
    fn pooled<T: Clone>(
        &self,
        reuse: impl FnOnce(&mut Slot) -> Option<T>,
        make: impl FnOnce(&mut ResourceCounts) -> T,
        keep_as: impl FnOnce(T) -> Slot,
    ) -> T {
        let mut guard = self.pool();
        let pool = &mut *guard;
        let Some((i, scope)) = pool.next() else { return make(&mut pool.counts) };
        if let Some(found) = scope.slots.get_mut(i).and_then(reuse) {
            return found;
        }
        let name = pool.current.clone().expect("a scope is open");
        let made = make(&mut pool.counts);
        keep(pool.scopes.get_mut(&name).expect("the open scope"), i, keep_as(made.clone()));
        made
    }

    /// A storage (or other) buffer of `size` bytes, zeroed as a new buffer is.
    pub fn buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        self.pooled(
            |slot| match slot {
                Slot::Buffer { size: s, usage: u, zeroed: true, buffer, .. } if *s == size && *u == usage => {
                    Some(buffer.clone())
                }
                _ => None,
            },
            |counts| {
                counts.buffers += 1;
                let desc = wgpu::BufferDescriptor { label: Some(label), size, usage, mapped_at_creation: false };
                self.device.create_buffer(&desc)
            },
            |buffer| Slot::Buffer { size, usage, zeroed: true, contents: Vec::new(), buffer },
        )
    }

    /// A buffer holding `contents` (a uniform, or initial data): kept from frame to frame and
    /// rewritten with `queue.write_buffer` when the contents changed (always, for buffers the
    /// GPU may write).
    pub fn buffer_init(&self, label: &str, contents: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let gpu_writes = usage.contains(wgpu::BufferUsages::STORAGE);
        self.buffer_with(label, contents, usage, gpu_writes)
    }

    /// Shader constants read from a read-only storage binding (`var<storage, read>`), also
    /// bindable as a uniform: kept from frame to frame and rewritten only when the contents
    /// changed.
    ///
    /// For stages dispatched many times a frame with different bindings (the beams' chunks):
    /// lavapipe (Mesa 22.3) specializes a compute shader on the uniform values its loops and
    /// branches read, compiling a new variant at every bind and keeping each until the device
    /// is dropped; storage reads are never specialized (docs/beams.md, "Beams: memory").
    pub fn constants(&self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::UNIFORM;
        self.buffer_with(label, contents, usage, false)
    }

    /// [`GpuContext::buffer_init`], rewritten every frame when `gpu_writes`.
    fn buffer_with(&self, label: &str, contents: &[u8], usage: wgpu::BufferUsages, gpu_writes: bool) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        let usage = usage | wgpu::BufferUsages::COPY_DST;
        let size = contents.len() as u64;
        self.pooled(
            |slot| match slot {
                Slot::Buffer { size: s, usage: u, zeroed: false, contents: old, buffer }
                    if *s == size && *u == usage =>
                {
                    if old != contents || gpu_writes {
                        self.queue.write_buffer(buffer, 0, contents);
                        old.clear();
                        old.extend_from_slice(contents);
                    }
                    Some(buffer.clone())
                }
                _ => None,
            },
            |counts| {
                counts.buffers += 1;
                self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage,
                })
            },
            |buffer| Slot::Buffer { size, usage, zeroed: false, contents: contents.to_vec(), buffer },
        )
    }

    /// A uniform buffer with `contents`.
    pub fn uniform(&self, label: &str, contents: &[u8]) -> wgpu::Buffer {
        self.buffer_init(label, contents, wgpu::BufferUsages::UNIFORM)
    }

    /// A texture (one mip level, one sample).
    pub fn texture(
        &self,
        label: &str,
        size: wgpu::Extent3d,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        self.texture_dim(label, wgpu::TextureDimension::D2, size, format, usage)
    }

    /// A pooled texture of any dimension (a medium's 3D density grid).
    pub fn texture_dim(
        &self,
        label: &str,
        dimension: wgpu::TextureDimension,
        size: wgpu::Extent3d,
        format: wgpu::TextureFormat,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        let key = TextureKey { dimension, size, format, usage };
        self.pooled(
            |slot| match slot {
                Slot::Texture { key: k, texture } if *k == key => Some(texture.clone()),
                _ => None,
            },
            |counts| {
                counts.textures += 1;
                self.device.create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size,
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension,
                    format,
                    usage,
                    view_formats: &[],
                })
            },
            |texture| Slot::Texture { key: key.clone(), texture },
        )
    }

    /// A view of `layers` (None: all from `base`) of a texture, as `dimension`.
    pub fn view(
        &self,
        texture: &wgpu::Texture,
        dimension: Option<wgpu::TextureViewDimension>,
        base: u32,
        layers: Option<u32>,
    ) -> wgpu::TextureView {
        let key = (texture.clone(), dimension, base, layers);
        self.pooled(
            |slot| match slot {
                Slot::View { key: k, view } if *k == key => Some(view.clone()),
                _ => None,
            },
            |counts| {
                counts.texture_views += 1;
                texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension,
                    base_array_layer: base,
                    array_layer_count: layers,
                    ..Default::default()
                })
            },
            |view| Slot::View { key: key.clone(), view },
        )
    }

    /// A bind group of group 0 of `pipeline` binding `entries`.
    pub(crate) fn bind_group(
        &self,
        label: &str,
        pipeline: LayoutOf,
        entries: &[wgpu::BindGroupEntry],
    ) -> wgpu::BindGroup {
        let key: Vec<(u32, BoundKey)> = entries
            .iter()
            .map(|e| {
                let k = match &e.resource {
                    wgpu::BindingResource::Buffer(b) => BoundKey::Buffer(b.buffer.clone(), b.offset, b.size),
                    wgpu::BindingResource::TextureView(v) => BoundKey::View((*v).clone()),
                    wgpu::BindingResource::Sampler(s) => BoundKey::Sampler((*s).clone()),
                    _ => unreachable!("the renderer binds buffers, texture views and samplers only"),
                };
                (e.binding, k)
            })
            .collect();
        self.pooled(
            |slot| match slot {
                Slot::BindGroup { layout, key: k, group } if *layout == pipeline && *k == key => Some(group.clone()),
                _ => None,
            },
            |counts| {
                counts.bind_groups += 1;
                self.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(label),
                    layout: &pipeline.layout(),
                    entries,
                })
            },
            |group| Slot::BindGroup { layout: pipeline.clone(), key: key.clone(), group },
        )
    }

    /// A sampler, kept under `key` (its description does not change between frames).
    pub fn sampler(&self, key: &str, desc: &wgpu::SamplerDescriptor) -> wgpu::Sampler {
        self.pooled(
            |slot| match slot {
                Slot::Sampler { key: k, sampler } if k == key => Some(sampler.clone()),
                _ => None,
            },
            |counts| {
                counts.samplers += 1;
                self.device.create_sampler(desc)
            },
            |sampler| Slot::Sampler { key: key.to_string(), sampler },
        )
    }

    /// A timestamp query set of `count` queries.
    pub fn timestamp_set(&self, count: u32) -> wgpu::QuerySet {
        self.pooled(
            |slot| match slot {
                Slot::QuerySet { count: c, set } if *c == count => Some(set.clone()),
                _ => None,
            },
            |counts| {
                counts.query_sets += 1;
                self.device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count,
                })
            },
            |set| Slot::QuerySet { count, set },
        )
    }

    /// Copy a buffer back to the CPU (blocking).
    pub fn read_buffer(&self, buffer: &wgpu::Buffer, size: u64) -> Result<Vec<u8>> {
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_buffer_to_buffer(buffer, 0, &staging, 0, size);
        self.queue.submit([enc.finish()]);
        self.map_read(&staging)
    }

    fn map_read(&self, staging: &wgpu::Buffer) -> Result<Vec<u8>> {
        let (tx, rx) = mpsc::channel();
        staging.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map_err(|e| Error::Device(format!("{e}")))?;
        rx.recv()
            .map_err(|e| Error::Device(e.to_string()))?
            .map_err(|e| Error::Device(format!("readback failed: {e}")))?;
        let data = staging.get_mapped_range(..).map_err(|e| Error::Device(format!("{e:?}")))?.to_vec();
        staging.unmap();
        Ok(data)
    }

    /// Copy one layer of a texture back (rows unpadded), `bpp` bytes per texel.
    pub fn read_texture(&self, tex: &wgpu::Texture, layer: u32, bpp: u32) -> Result<Vec<u8>> {
        let (w, h) = (tex.width(), tex.height());
        let row = w * bpp;
        let padded = row.div_ceil(256) * 256;
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: (padded * h) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: tex,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: layer },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &staging,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(h) },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.queue.submit([enc.finish()]);
        let data = self.map_read(&staging)?;
        let mut out = Vec::with_capacity((row * h) as usize);
        for y in 0..h {
            let s = (y * padded) as usize;
            out.extend_from_slice(&data[s..s + row as usize]);
        }
        Ok(out)
    }
}

/// GPU pass timer: a pair of timestamps per named pass, when the adapter supports them. Its
/// query set and resolve buffer come from the open resource scope, so a renderer keeps them.
pub struct PassTimer {
    set: Option<wgpu::QuerySet>,
    names: Vec<String>,
    capacity: u32,
}

impl PassTimer {
    pub fn new(ctx: &GpuContext, capacity: u32) -> PassTimer {
        let set = ctx.timestamps.then(|| ctx.timestamp_set(capacity * 2));
        PassTimer { set, names: Vec::new(), capacity }
    }

    /// A timer that times nothing (for one-off dispatches outside a frame).
    pub fn disabled() -> PassTimer {
        PassTimer { set: None, names: Vec::new(), capacity: 0 }
    }

    /// Timestamp writes for a compute pass named `name` (None when timing is off or full).
    pub fn compute(&mut self, name: &str) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let i = self.next(name)?;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: self.set.as_ref()?,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    /// Timestamp writes for a render pass named `name`.
    pub fn render(&mut self, name: &str) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let i = self.next(name)?;
        Some(wgpu::RenderPassTimestampWrites {
            query_set: self.set.as_ref()?,
            beginning_of_pass_write_index: Some(2 * i),
            end_of_pass_write_index: Some(2 * i + 1),
        })
    }

    fn next(&mut self, name: &str) -> Option<u32> {
        self.set.as_ref()?;
        let i = self.names.len() as u32;
        if i >= self.capacity {
            return None;
        }
        self.names.push(name.to_string());
        Some(i)
    }

    /// The passes timed so far, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Record the resolve of the timestamps into a buffer of the open scope: (buffer, bytes to
    /// read), None without timestamps.
    pub fn resolve(&self, ctx: &GpuContext, enc: &mut wgpu::CommandEncoder) -> Option<(wgpu::Buffer, u64)> {
        let set = self.set.as_ref()?;
        let n = self.names.len() as u32;
        if n == 0 {
            return None;
        }
        let usage = wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC;
        let buf = ctx.buffer("timestamps", self.capacity as u64 * 16, usage);
        enc.resolve_query_set(set, 0..n * 2, &buf, 0);
        Some((buf, n as u64 * 16))
    }

    /// (pass name, milliseconds) from the resolved timestamps `data`, summed over passes of one
    /// name, in first-use order.
    pub fn timings(names: &[String], data: &[u8], period: f32) -> Vec<(String, f64)> {
        let ts: Vec<u64> = data.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().unwrap())).collect();
        let mut out: Vec<(String, f64)> = Vec::new();
        for (i, name) in names.iter().enumerate() {
            let (Some(a), Some(b)) = (ts.get(2 * i), ts.get(2 * i + 1)) else { break };
            let ms = b.saturating_sub(*a) as f64 * period as f64 * 1e-6;
            match out.iter_mut().find(|(n, _)| n == name) {
                Some(e) => e.1 += ms,
                None => out.push((name.clone(), ms)),
            }
        }
        out
    }
}
