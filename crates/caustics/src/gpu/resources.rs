//! The pooled resource requests of a [`GpuContext`] (resource scopes, buffers, textures,
//! views, bind groups, samplers, query sets) and the blocking readback of buffers and textures.

use super::GpuContext;
use super::pool::{BoundKey, LayoutOf, ResourceCounts, Slot, TextureKey, keep};
use crate::error::{Error, Result};
use std::sync::mpsc;

impl GpuContext {
    /// Open the resource scope `name` ([`pool`](super::pool)): its requests are answered, in
    /// order, by the resources it handed out last time; those of them that were handed out as
    /// fresh storage buffers are cleared first, in `enc`.
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

    /// A bind group of shared group `group` (`gpu::layout::SHARED_GROUPS`) binding `entries`,
    /// which its owner keeps (not pooled; counted): the scene group of a geometry upload.
    pub(crate) fn shared_bind_group(
        &self,
        label: &str,
        group: u32,
        entries: &[wgpu::BindGroupEntry],
    ) -> wgpu::BindGroup {
        let layout = self.shared_layout(group);
        self.pool().counts.bind_groups += 1;
        self.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(label), layout: &layout, entries })
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
