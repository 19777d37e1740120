//! GPU resources kept from frame to frame.
//!
//! Every buffer, texture, view, sampler, query set and bind group a frame needs is asked of the
//! [`GpuContext`](super::GpuContext) (`ctx.buffer`, `ctx.uniform`, `ctx.texture`, `ctx.view`,
//! `ctx.bind`, ...). Inside a *scope* (`ctx.begin_scope`), the k-th request of the scope is
//! answered by the k-th resource the scope handed out last time it was recorded, if that one
//! matches the request (same size and usage, same texture description, same bound resources);
//! otherwise a new one is made and kept in its place. A frame that records the same passes as
//! the last one therefore creates nothing: this is a render graph's transient-resource cache,
//! keyed by recording order rather than by name, which keeps every technique's recording code
//! as it was (a technique asks for what it needs where it needs it). Scopes are independent:
//! the renderer records one per light and one for the camera, so a light whose passes are
//! skipped keeps its resources (and the maps in them) and the others' order is not disturbed.
//!
//! Semantics are those of fresh resources: a storage buffer handed out again is cleared at the
//! scope's start (`clear_buffer`), as a new one is zeroed; a uniform's contents are written
//! with `queue.write_buffer` when they changed. Outside a scope, requests create resources
//! (one-off work such as read-backs). Every creation is counted ([`ResourceCounts`]).

use std::collections::HashMap;

/// GPU objects created through a context, counted since it was made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ResourceCounts {
    /// Buffers created.
    pub buffers: u64,
    /// Textures created.
    pub textures: u64,
    /// Texture views created.
    pub texture_views: u64,
    /// Bind groups created.
    pub bind_groups: u64,
    /// Query sets created.
    pub query_sets: u64,
    /// Samplers created.
    pub samplers: u64,
}

impl ResourceCounts {
    /// All objects created, of every kind.
    pub fn total(&self) -> u64 {
        self.buffers + self.textures + self.texture_views + self.bind_groups + self.query_sets + self.samplers
    }
}

impl std::ops::Sub for ResourceCounts {
    type Output = ResourceCounts;
    fn sub(self, o: ResourceCounts) -> ResourceCounts {
        ResourceCounts {
            buffers: self.buffers - o.buffers,
            textures: self.textures - o.textures,
            texture_views: self.texture_views - o.texture_views,
            bind_groups: self.bind_groups - o.bind_groups,
            query_sets: self.query_sets - o.query_sets,
            samplers: self.samplers - o.samplers,
        }
    }
}

/// What a bind group binds, for comparing a request with the kept group.
#[derive(Clone, PartialEq)]
pub(crate) enum BoundKey {
    Buffer(wgpu::Buffer, u64, Option<wgpu::BufferSize>),
    View(wgpu::TextureView),
    Sampler(wgpu::Sampler),
}

/// The pipeline whose group-0 layout a bind group follows.
#[derive(Clone, PartialEq)]
pub(crate) enum LayoutOf {
    Compute(wgpu::ComputePipeline),
    Render(wgpu::RenderPipeline),
}

impl LayoutOf {
    pub(crate) fn layout(&self) -> wgpu::BindGroupLayout {
        match self {
            LayoutOf::Compute(p) => p.get_bind_group_layout(0),
            LayoutOf::Render(p) => p.get_bind_group_layout(0),
        }
    }
}

pub(crate) enum Slot {
    /// `zeroed`: handed out as a fresh (zero) buffer, so cleared when the scope starts again.
    Buffer {
        size: u64,
        usage: wgpu::BufferUsages,
        zeroed: bool,
        contents: Vec<u8>,
        buffer: wgpu::Buffer,
    },
    Texture {
        key: TextureKey,
        texture: wgpu::Texture,
    },
    View {
        key: (wgpu::Texture, Option<wgpu::TextureViewDimension>, u32, Option<u32>),
        view: wgpu::TextureView,
    },
    BindGroup {
        layout: LayoutOf,
        key: Vec<(u32, BoundKey)>,
        group: wgpu::BindGroup,
    },
    Sampler {
        key: String,
        sampler: wgpu::Sampler,
    },
    QuerySet {
        count: u32,
        set: wgpu::QuerySet,
    },
}

#[derive(Clone, PartialEq)]
pub(crate) struct TextureKey {
    pub dimension: wgpu::TextureDimension,
    pub size: wgpu::Extent3d,
    pub format: wgpu::TextureFormat,
    pub usage: wgpu::TextureUsages,
}

#[derive(Default)]
pub(crate) struct Scope {
    pub slots: Vec<Slot>,
    pub cursor: usize,
}

#[derive(Default)]
pub(crate) struct Pool {
    pub scopes: HashMap<String, Scope>,
    pub current: Option<String>,
    pub counts: ResourceCounts,
}

impl Pool {
    /// The slot the current scope hands out next, if a scope is open: (slot index, scope).
    pub fn next(&mut self) -> Option<(usize, &mut Scope)> {
        let name = self.current.as_ref()?;
        let scope = self.scopes.get_mut(name)?;
        let i = scope.cursor;
        scope.cursor += 1;
        Some((i, scope))
    }
}

/// Put `slot` at index `i` of `scope` (replacing what was there).
pub(crate) fn keep(scope: &mut Scope, i: usize, slot: Slot) {
    if i < scope.slots.len() {
        scope.slots[i] = slot;
    } else {
        scope.slots.push(slot);
    }
}
