//! [`PassTimer`]: GPU timestamps per named pass, resolved and turned into timings.

use super::GpuContext;

/// GPU pass timer: a pair of timestamps per named pass, when the adapter supports them. Its
/// query set and resolve buffer come from the open resource scope, so a renderer keeps them.
pub struct PassTimer {
    set: Option<wgpu::QuerySet>,
    names: Vec<String>,
    capacity: u32,
}

impl PassTimer {
    /// A timer for up to `capacity` passes; it times nothing when the adapter has no timestamp
    /// queries.
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
