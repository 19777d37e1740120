//! Blocking read-backs of the last frame (images, caustic maps, flux words, dumps) and the
//! one-shot render built on them.

use super::{FrameRequest, Renderer};
use crate::error::{Error, Result};
use crate::gpu::GpuContext;
use crate::image_io::Image;
use crate::output::GpuRender;
use crate::passes::{LightFrame, bytes_to_image};
use crate::scene::Scene;
use crate::settings::RenderSettings;
use crate::temporal::TemporalFilter;

impl Renderer {
    fn last_outputs(&self) -> Result<&(wgpu::Buffer, wgpu::Buffer, wgpu::Texture)> {
        self.outputs.as_ref().ok_or_else(|| Error::Device("no frame rendered yet".into()))
    }

    /// Read the last frame's linear radiance back (blocking; screenshots, tests).
    pub fn read_image(&self) -> Result<Image> {
        let c = &self.scene.camera;
        let data = self.ctx.read_buffer(&self.last_outputs()?.0, c.width as u64 * c.height as u64 * 16)?;
        Ok(bytes_to_image(&data, c.width, c.height))
    }

    /// Read the last frame's caustic-only radiance back (blocking).
    pub fn read_caustic_image(&self) -> Result<Image> {
        let c = &self.scene.camera;
        let data = self.ctx.read_buffer(&self.last_outputs()?.1, c.width as u64 * c.height as u64 * 16)?;
        Ok(bytes_to_image(&data, c.width, c.height))
    }

    /// The exact tracer's BVH as the CPU keeps it and as the GPU holds it after the last frame
    /// (blocking; the refit's tests). Before the first frame: an error.
    #[doc(hidden)]
    pub fn read_bvh(&self) -> Result<BvhReadback> {
        let geo = &self.geometry.as_ref().ok_or_else(|| Error::Device("no frame rendered yet".into()))?.1;
        let (cpu_nodes, cpu_tris) = geo.bvh.gpu_arrays();
        let read = |b: &wgpu::Buffer| self.ctx.read_buffer(b, b.size());
        let inst = read(&geo.bvh_instances)?;
        Ok(BvhReadback {
            gpu_nodes: bytemuck::pod_collect_to_vec(&read(&geo.bvh_nodes)?),
            gpu_tris: bytemuck::pod_collect_to_vec(&read(&geo.bvh_tris)?),
            gpu_instances: bytemuck::pod_collect_to_vec(&inst),
            cpu_instances: geo.bvh.instance_records(&self.transforms),
            cpu_nodes,
            cpu_tris,
            ranges: (0..geo.bvh.instances.len())
                .map(|k| {
                    let (n, t) = geo.bvh.instance_ranges(k);
                    (geo.bvh.instances[k].0 as usize, n, t)
                })
                .collect(),
        })
    }

    fn light_frame(&self, light: usize) -> Result<&LightFrame> {
        self.features
            .photon_maps
            .frame(light)
            .ok_or_else(|| Error::Device(format!("light {light}: no such light, or no frame rendered yet")))
    }

    /// Read light `light`'s caustic irradiance maps back, one image per face (blocking).
    pub fn read_caustic_maps(&self, light: usize) -> Result<Vec<Image>> {
        let lf = self.light_frame(light)?;
        let m = self.settings.photons.caustic_map_size;
        let texels = m as u64 * m as u64;
        let irr = self.ctx.read_buffer(&lf.irradiance, texels * lf.faces as u64 * 16)?;
        Ok((0..lf.faces as u64)
            .map(|f| bytes_to_image(&irr[(f * texels * 16) as usize..((f + 1) * texels * 16) as usize], m, m))
            .collect())
    }

    /// Read light `light`'s raw fixed-point flux per texel (r, g, b words per texel, all faces).
    pub fn read_caustic_flux_bits(&self, light: usize) -> Result<Vec<u64>> {
        let lf = self.light_frame(light)?;
        let m = self.settings.photons.caustic_map_size as u64;
        let acc = self.ctx.read_buffer(&lf.accum, m * m * lf.faces as u64 * 24)?;
        Ok(acc.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().unwrap())).collect())
    }

    /// The light-space buffers of the last frame (and the caustic maps `maps`, one list of faces
    /// per light) as images to look at (blocking).
    pub fn dump_images(&self, maps: &[Vec<Image>]) -> Result<Vec<crate::passes::DumpImage>> {
        let n = self.scene.lights.len();
        let lights: Vec<_> = (0..n)
            .map(|l| {
                let p = self.light_frame(l)?;
                let mut bufs =
                    vec![("receivers", &p.recv), ("caster_front", &p.casters.0), ("caster_back", &p.casters.1)];
                if let Some((front2, back2)) = &p.casters2 {
                    bufs.extend([("caster_front2", front2), ("caster_back2", back2)]);
                }
                Ok((bufs, p.faces))
            })
            .collect::<Result<_>>()?;
        crate::passes::dump_images(&self.ctx, &lights, maps)
    }

    /// Render one frame, wait for it and read everything back (the one-shot render of
    /// [`crate::render()`]).
    pub fn render_once(&mut self) -> Result<GpuRender> {
        let ctx = self.ctx.clone();
        let val_scope = ctx.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom_scope = ctx.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let mut enc = ctx.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        // (its beam statistics are read: the hulls' fragments counted too)
        self.features.beams.count_fragments = true;
        let recorded = self.encode(&mut enc, FrameRequest { stats: true }).map(|_| ());
        self.features.beams.count_fragments = false;
        let submitted = std::time::Instant::now();
        let polled = if recorded.is_ok() {
            ctx.queue.submit([enc.finish()]);
            ctx.device.poll(wgpu::PollType::Wait { submission_index: None, timeout: None }).map(|_| ())
        } else {
            Ok(())
        };
        let frame_wall_ms = submitted.elapsed().as_secs_f64() * 1e3;
        let oom = pollster::block_on(oom_scope.pop());
        let val = pollster::block_on(val_scope.pop());
        recorded?;
        if let Some(e) = oom {
            return Err(Error::Device(format!("out of GPU memory: {e}")));
        }
        if let Some(e) = val {
            return Err(Error::Device(format!("{e}")));
        }
        polled.map_err(|e| Error::Device(format!("{e}")))?;
        let stats = self.wait_stats()?.ok_or_else(|| Error::Device("the frame's statistics were not read".into()))?;
        if let Some(m) = stats.overflow {
            return Err(Error::Device(m));
        }
        let n = self.scene.lights.len();
        let caustic_maps = (0..n).map(|l| self.read_caustic_maps(l)).collect::<Result<Vec<_>>>()?;
        let caustic_flux_bits = (0..n).map(|l| self.read_caustic_flux_bits(l)).collect::<Result<Vec<_>>>()?;
        let technique = stats.technique;
        let beams =
            self.features.beams.frames.iter().map(|f| crate::beams::read_frame(&ctx, f)).collect::<Result<Vec<_>>>()?;
        if let Some(b) = beams.iter().find(|b| b.0.overflow > 0) {
            return Err(Error::Device(format!(
                "beam buffer overflow: {} beams did not fit (capacity {}; raise beams.capacity)",
                b.0.overflow, self.settings.beams.capacity
            )));
        }
        Ok(GpuRender {
            beams,
            image: self.read_image()?,
            caustic: self.read_caustic_image()?,
            caustic_maps,
            caustic_flux_bits,
            flux: stats.flux,
            timings: stats.timings,
            frame_wall_ms,
            photons_traced: technique.photons_traced,
            batches: technique.batches,
            technique,
            adapter: format!("{} ({:?}, {})", ctx.info.name, ctx.info.backend, ctx.info.driver),
        })
    }

    /// [`Renderer::render_once`] with `filter` as the temporal filter (it is handed back).
    pub(crate) fn render_once_filtered(&mut self, filter: &mut TemporalFilter) -> Result<GpuRender> {
        self.features.photon_maps.temporal = Some(std::mem::replace(filter, TemporalFilter::new(filter.settings)));
        let out = self.render_once();
        if let Some(f) = self.features.photon_maps.temporal.take() {
            *filter = f;
        }
        out
    }
}

impl TemporalFilter {
    /// Render a frame of `scene` like [`crate::render()`], with every light's caustic
    /// maps filtered against this filter's history before shading.
    pub fn render(&mut self, ctx: &GpuContext, scene: &Scene, settings: &RenderSettings) -> Result<GpuRender> {
        self.settings.validate()?;
        let mut r = crate::renderer::Renderer::with_context(ctx.clone(), scene.clone(), settings.clone())?;
        let out = r.render_once_filtered(self);
        // The environment's directional lights have histories too.
        self.lights.truncate(r.lights().len());
        out
    }
}

/// The BVH on the CPU and on the GPU ([`Renderer::read_bvh`]).
#[doc(hidden)]
#[derive(Debug, Clone)]
pub struct BvhReadback {
    pub cpu_nodes: Vec<crate::gpu::types::BvhNode>,
    pub gpu_nodes: Vec<crate::gpu::types::BvhNode>,
    pub cpu_tris: Vec<crate::gpu::types::BvhTri>,
    pub gpu_tris: Vec<crate::gpu::types::BvhTri>,
    pub cpu_instances: Vec<crate::gpu::types::BvhInstance>,
    pub gpu_instances: Vec<crate::gpu::types::BvhInstance>,
    /// Per mesh object: (object, its nodes, its triangles), global index ranges.
    pub ranges: Vec<(usize, std::ops::Range<usize>, std::ops::Range<usize>)>,
}
