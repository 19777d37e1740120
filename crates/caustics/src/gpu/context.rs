//! [`GpuContext`]: the device and queue, adapter choice and device requirements, and the
//! caches of pipelines and bind group layouts shared by its clones.

use super::layout::{compute_stage_layout, render_stage_layout, shared_group_bindings};
use super::pool::{self, ResourceCounts};
use super::stages::{logged_build, stage_source};
use crate::error::{Error, Result};

/// A device and queue, and what the adapter can do.
#[derive(Clone)]
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// The device's queue.
    pub queue: wgpu::Queue,
    /// The adapter: name, vendor, backend and driver.
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
    /// layout shared by every stage whose group 0 is the same, and the layout of each shared
    /// group it declares (`GpuContext::shared_layout`).
    pub fn stage_layout(&self, name: &str) -> wgpu::PipelineLayout {
        let (entries, shared) = compute_stage_layout(name).unwrap_or_else(|e| panic!("{e}"));
        self.layout_of(name, entries, &shared)
    }

    /// The pipeline layout of render stage `name` ([`super::render_stage_bindings`]).
    pub fn render_stage_layout(&self, name: &str) -> wgpu::PipelineLayout {
        let (entries, shared) = render_stage_layout(name).unwrap_or_else(|e| panic!("{e}"));
        self.layout_of(name, entries, &shared)
    }

    /// The bind group layout of shared group `group` (`gpu::layout::SHARED_GROUPS`): every
    /// binding its WGSL module declares, one layout per context for every pipeline that uses it.
    pub(crate) fn shared_layout(&self, group: u32) -> wgpu::BindGroupLayout {
        let entries = shared_group_bindings(group).unwrap_or_else(|e| panic!("{e}"));
        self.group_layout(&format!("shared group {group}"), entries)
    }

    fn group_layout(&self, label: &str, entries: Vec<wgpu::BindGroupLayoutEntry>) -> wgpu::BindGroupLayout {
        self.layouts
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .entry(entries.clone())
            .or_insert_with(|| {
                self.device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                    label: Some(label),
                    entries: &entries,
                })
            })
            .clone()
    }

    fn layout_of(&self, name: &str, entries: Vec<wgpu::BindGroupLayoutEntry>, shared: &[u32]) -> wgpu::PipelineLayout {
        let own = self.group_layout(name, entries);
        let shared: Vec<(u32, wgpu::BindGroupLayout)> = shared.iter().map(|&g| (g, self.shared_layout(g))).collect();
        let groups = shared.iter().map(|(g, _)| *g as usize + 1).max().unwrap_or(1);
        let layouts: Vec<Option<&wgpu::BindGroupLayout>> = (0..groups as u32)
            .map(|g| if g == 0 { Some(&own) } else { shared.iter().find(|(s, _)| *s == g).map(|(_, l)| l) })
            .collect();
        self.device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(name),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        })
    }

    /// Distinct bind group layouts of the stages built so far (shared groups included).
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

    pub(super) fn pool(&self) -> std::sync::MutexGuard<'_, pool::Pool> {
        self.pool.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// GPU objects created through this context so far.
    pub fn created(&self) -> ResourceCounts {
        self.pool().counts
    }
}
