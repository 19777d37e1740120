//! The persistent renderer: what an engine drives frame by frame on its own device.
//!
//! ```no_run
//! # fn f(device: &wgpu::Device, queue: &wgpu::Queue, scene: caustics::Scene) -> caustics::Result<()> {
//! use caustics::renderer::{FrameRequest, Renderer};
//! let mut r = Renderer::new(device, queue, scene, caustics::render::RenderSettings::default())?;
//! loop {
//!     // Change what moved (camera, lights, object transforms, settings): uniform writes only.
//!     let mut cam = r.scene().camera.clone();
//!     cam.position.x += 0.01;
//!     r.set_camera(cam)?;
//!     let mut enc = device.create_command_encoder(&Default::default());
//!     let out = r.encode(&mut enc, FrameRequest { stats: true })?;
//!     let _display = out.display; // tone-mapped image, Rgba8Unorm (sRGB-encoded values)
//!     queue.submit([enc.finish()]);
//!     // Statistics of an earlier frame, once the GPU has finished it (never blocks).
//!     if let Some(stats) = r.poll_stats()? {
//!         let _ = stats.frame;
//!     }
//! #   break;
//! }
//! # Ok(()) }
//! ```
//!
//! State is the loaded scene plus what changed since: the camera, the lights, a transform per
//! object (relative to the pose the scene file gives, a rotation, translation and uniform
//! scale), the settings and the temporal filter. A fresh renderer brought to the same state
//! renders the same maps and image bit for bit as one that got there frame by frame.

use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::image_io::Image;
use crate::render::{FluxStats, GpuRender, RenderSettings};
use crate::scene::{Camera, Light, Scene};
use crate::techniques::TechniqueStats;
use crate::temporal::{TemporalFilter, TemporalSettings};
use glam::Affine3A;

/// What a frame should produce beyond the image.
#[derive(Debug, Clone, Copy, Default)]
pub struct FrameRequest {
    /// Copy this frame's statistics (pass times, photon counts, flux bookkeeping, overflow
    /// flags) for [`Renderer::poll_stats`]; frames without it record no copies.
    pub stats: bool,
}

/// Textures of one light, valid until the next [`Renderer::encode`].
pub struct LightOutputs<'a> {
    /// Caustic irradiance (W/m²) per face: a 2D array texture (M × M × faces, Rgba32Float).
    pub irradiance: &'a wgpu::Texture,
    /// The receiver map: world position and object id (w, −1 where empty) per face.
    pub receiver_position: &'a wgpu::Texture,
    /// The receiver map's shading normals per face.
    pub receiver_normal: &'a wgpu::Texture,
    /// Whether this frame recomputed the light's maps (false: kept from an earlier frame).
    pub redone: bool,
}

/// What [`Renderer::encode`] recorded.
pub struct FrameOutputs<'a> {
    /// The image tone-mapped with the scene's exposure (ACES fit), sRGB-encoded values in an
    /// Rgba8Unorm texture (`TEXTURE_BINDING | COPY_SRC`), camera width × height.
    pub display: &'a wgpu::Texture,
    /// Linear radiance, W/(m² sr), `vec4<f32>` per pixel row-major (`STORAGE | COPY_SRC`).
    pub radiance: &'a wgpu::Buffer,
    /// Caustic light only, on the diffuse surfaces the camera sees directly.
    pub caustic_radiance: &'a wgpu::Buffer,
    pub lights: Vec<LightOutputs<'a>>,
}

/// Statistics of one frame, read back asynchronously.
#[derive(Debug, Clone, Default)]
pub struct FrameStats {
    /// The frame's number (counted from 0 by [`Renderer::encode`]).
    pub frame: u64,
    /// GPU milliseconds per named pass (empty without timestamp queries).
    pub timings: Vec<(String, f64)>,
    /// Per light: flux bookkeeping of the light's last photon stage.
    pub flux: Vec<FluxStats>,
    /// Photon work done in this frame (zero when every light's maps were kept).
    pub technique: TechniqueStats,
    /// Per light: whether this frame redid the light's passes.
    pub lights_redone: Vec<bool>,
}

/// GPU objects the renderer created, counted since it was made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ResourceCounts {
    pub buffers: u64,
    pub textures: u64,
    pub texture_views: u64,
    pub bind_groups: u64,
    pub query_sets: u64,
    pub samplers: u64,
}

impl ResourceCounts {
    pub fn total(&self) -> u64 {
        self.buffers + self.textures + self.texture_views + self.bind_groups + self.query_sets + self.samplers
    }
}

/// The persistent GPU renderer (module documentation).
pub struct Renderer {
    ctx: GpuContext,
    /// The scene as loaded, and as it is now (object transforms baked in).
    base: Scene,
    scene: Scene,
    transforms: Vec<Affine3A>,
    settings: RenderSettings,
    temporal: Option<TemporalFilter>,
    frame: u64,
    last: Option<GpuRender>,
    stats: Option<FrameStats>,
    display: Option<wgpu::Texture>,
    outputs: Vec<(wgpu::Texture, wgpu::Texture, wgpu::Texture)>,
    radiance: Option<(wgpu::Buffer, wgpu::Buffer)>,
    counts: ResourceCounts,
}

impl Renderer {
    /// A renderer for `scene` on the caller's device (made with at least
    /// [`GpuContext::device_requirements`]). Settings are checked against the device's limits.
    pub fn new(device: &wgpu::Device, queue: &wgpu::Queue, scene: Scene, settings: RenderSettings) -> Result<Renderer> {
        Renderer::with_context(GpuContext::from_device(device, queue), scene, settings)
    }

    /// A renderer on an existing context (the command line's convenience).
    pub fn with_context(ctx: GpuContext, scene: Scene, settings: RenderSettings) -> Result<Renderer> {
        ctx.check_device()?;
        settings.validate(&ctx, &scene)?;
        let transforms = vec![Affine3A::IDENTITY; scene.objects.len()];
        Ok(Renderer {
            ctx,
            base: scene.clone(),
            scene,
            transforms,
            settings,
            temporal: None,
            frame: 0,
            last: None,
            stats: None,
            display: None,
            outputs: Vec::new(),
            radiance: None,
            counts: ResourceCounts::default(),
        })
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// The scene as it is now: camera, lights and objects with their transforms applied.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    pub fn set_camera(&mut self, camera: Camera) -> Result<()> {
        if camera.width == 0 || camera.height == 0 {
            return Err(Error::input("<renderer>", "camera.width", "the image must be at least 1x1"));
        }
        self.scene.camera = camera;
        self.settings.validate(&self.ctx, &self.scene)
    }

    /// Replace light `index` (its kind may change; a point light's six faces are made on the
    /// next frame).
    pub fn set_light(&mut self, index: usize, light: Light) -> Result<()> {
        if index >= self.scene.lights.len() {
            return Err(Error::input("<renderer>", format!("lights[{index}]"), "no such light"));
        }
        self.scene.lights[index] = light;
        Ok(())
    }

    /// The transform of object `index` relative to its pose in the scene file.
    pub fn object_transform(&self, index: usize) -> Option<Affine3A> {
        self.transforms.get(index).copied()
    }

    /// Move object `index`: `transform` (a rotation, translation and uniform scale) is applied to
    /// its pose in the scene file.
    pub fn set_object_transform(&mut self, index: usize, transform: Affine3A) -> Result<()> {
        let Some(o) = self.base.objects.get(index) else {
            return Err(Error::input("<renderer>", format!("objects[{index}]"), "no such object"));
        };
        let shape = o
            .shape
            .transformed(&transform)
            .map_err(|m| Error::input("<renderer>", format!("objects[{index}].transform"), m))?;
        self.scene.objects[index].shape = shape;
        self.transforms[index] = transform;
        Ok(())
    }

    /// Change the settings; an error (named by setting) leaves the old ones in place.
    pub fn set_settings(&mut self, settings: RenderSettings) -> Result<()> {
        settings.validate(&self.ctx, &self.scene)?;
        self.settings = settings;
        Ok(())
    }

    /// Turn the temporal filter of the caustic maps on (with these settings) or off.
    pub fn set_temporal(&mut self, temporal: Option<TemporalSettings>) -> Result<()> {
        match temporal {
            None => self.temporal = None,
            Some(t) => {
                t.validate()?;
                match &mut self.temporal {
                    Some(f) if f.settings == t => {}
                    _ => self.temporal = Some(TemporalFilter::new(t)),
                }
            }
        }
        Ok(())
    }

    /// GPU objects created so far.
    pub fn created(&self) -> ResourceCounts {
        self.counts
    }

    /// Record a frame into `encoder`.
    pub fn encode(&mut self, _encoder: &mut wgpu::CommandEncoder, request: FrameRequest) -> Result<FrameOutputs<'_>> {
        let out = crate::render::render_with(&self.ctx, &self.scene, &self.settings, None, self.temporal.as_mut())?;
        let (w, h) = (out.image.width, out.image.height);
        let exposure = self.scene.exposure;
        let bytes: Vec<u8> = out
            .image
            .pixels
            .iter()
            .flat_map(|p| {
                let [r, g, b] = crate::image_io::tonemap(*p, exposure);
                [r, g, b, 255]
            })
            .collect();
        let display = self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("display"),
            size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        self.ctx.queue.write_texture(
            display.as_image_copy(),
            &bytes,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 4), rows_per_image: Some(h) },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.display = Some(display);
        let buf = |label: &str| {
            self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: (w as u64 * h as u64 * 16).max(16),
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        self.radiance = Some((buf("radiance"), buf("caustic_radiance")));
        let tex = |label: &str, size: u32, layers: u32| {
            self.ctx.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: size, height: size, depth_or_array_layers: layers },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let m = self.settings.caustic_map_size;
        self.outputs = out
            .caustic_maps
            .iter()
            .map(|faces| {
                let n = faces.len() as u32;
                (
                    tex("caustic_irradiance", m, n),
                    tex("light_receivers_position", m, n),
                    tex("light_receivers_normal", m, n),
                )
            })
            .collect();
        let lights_redone = vec![true; self.scene.lights.len()];
        if request.stats {
            self.stats = Some(FrameStats {
                frame: self.frame,
                timings: out.timings.clone(),
                flux: out.flux.clone(),
                technique: out.technique.clone(),
                lights_redone: lights_redone.clone(),
            });
        }
        self.frame += 1;
        self.last = Some(out);
        let (radiance, caustic_radiance) = self.radiance.as_ref().unwrap();
        Ok(FrameOutputs {
            display: self.display.as_ref().unwrap(),
            radiance,
            caustic_radiance,
            lights: self
                .outputs
                .iter()
                .map(|(irradiance, receiver_position, receiver_normal)| LightOutputs {
                    irradiance,
                    receiver_position,
                    receiver_normal,
                    redone: true,
                })
                .collect(),
        })
    }

    /// The statistics of the latest frame that asked for them and that the GPU has finished, if
    /// not returned before. Never blocks.
    pub fn poll_stats(&mut self) -> Result<Option<FrameStats>> {
        Ok(self.stats.take())
    }

    /// Wait for the statistics of the latest frame that asked for them (tests, command line).
    pub fn wait_stats(&mut self) -> Result<Option<FrameStats>> {
        self.poll_stats()
    }

    /// Read the last frame's linear radiance back (blocking; screenshots, tests).
    pub fn read_image(&self) -> Result<Image> {
        self.last.as_ref().map(|o| o.image.clone()).ok_or_else(|| Error::Device("no frame rendered yet".into()))
    }

    /// Read the last frame's caustic-only radiance back (blocking).
    pub fn read_caustic_image(&self) -> Result<Image> {
        self.last.as_ref().map(|o| o.caustic.clone()).ok_or_else(|| Error::Device("no frame rendered yet".into()))
    }

    /// Read light `light`'s caustic irradiance maps back, one image per face (blocking).
    pub fn read_caustic_maps(&self, light: usize) -> Result<Vec<Image>> {
        self.last
            .as_ref()
            .and_then(|o| o.caustic_maps.get(light).cloned())
            .ok_or_else(|| Error::Device("no such light or no frame rendered yet".into()))
    }
}
