//! The statistics ring: staging slots the frames' counters are copied into, mapped once the
//! GPU finished, and parsed into [`FrameStats`] (`poll_stats`, `wait_stats`).

use super::{FrameStats, Renderer};
use crate::error::{Error, Result};
use crate::frame::StatsCopies;
use crate::gpu::{GpuContext, PassTimer};
use crate::techniques::{Pending, TechniqueStats};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};

/// One slot of the statistics ring: a staging buffer the frame's counters are copied into.
pub(super) struct StatsSlot {
    pub(super) staging: wgpu::Buffer,
    /// 0 free, 1 recorded (not yet mapped), 2 mapping, 3 mapped, 4 failed.
    pub(super) state: Arc<AtomicU8>,
    pub(super) job: Option<StatsJob>,
}

/// How to read a slot: its frame, and what lies where in the staging buffer.
pub(super) struct StatsJob {
    pub(super) frame: u64,
    pub(super) timer: Option<(Vec<String>, u64, u64)>,
    /// Per light: offset of its flux words and its fixed-point scale.
    pub(super) flux: Vec<(u64, f64)>,
    /// Per redone light: its technique's pending statistics and their (offset, size) pieces.
    pub(super) pendings: Vec<(Pending, Vec<(u64, u64)>)>,
    pub(super) lights_redone: Vec<bool>,
    /// Offset of `sphere_gather`'s counters, when it ran.
    pub(super) sphere_stats: Option<u64>,
    /// Offset and size of `indirect_trace`'s counters, when the cache was rebuilt.
    pub(super) indirect_stats: Option<(u64, u64)>,
}

const STATS_SLOTS: usize = 3;

impl Renderer {
    /// Start mapping the slots recorded by submitted frames.
    fn map_recorded(&mut self) {
        for slot in &self.ring {
            if slot.state.compare_exchange(1, 2, Ordering::AcqRel, Ordering::Acquire).is_ok() {
                let state = slot.state.clone();
                slot.staging.map_async(wgpu::MapMode::Read, .., move |r| {
                    state.store(if r.is_ok() { 3 } else { 4 }, Ordering::Release);
                });
            }
        }
    }

    /// Read the mapped slots; keep the newest frame's statistics.
    fn collect(&mut self) -> Result<()> {
        let period = self.ctx.queue.get_timestamp_period();
        let mut order: Vec<usize> = (0..self.ring.len()).collect();
        order.sort_by_key(|&i| self.ring[i].job.as_ref().map_or(0, |j| j.frame));
        for i in order {
            let slot = &mut self.ring[i];
            match slot.state.load(Ordering::Acquire) {
                3 => {}
                4 => {
                    slot.job = None;
                    slot.state.store(0, Ordering::Release);
                    return Err(Error::Device("reading the frame statistics failed".into()));
                }
                _ => continue,
            }
            let job = slot.job.take().expect("a mapped slot has a job");
            let data = slot.staging.get_mapped_range(..).map_err(|e| Error::Device(format!("{e:?}")))?.to_vec();
            slot.staging.unmap();
            slot.state.store(0, Ordering::Release);
            let piece = |off: u64, size: u64| data[off as usize..(off + size) as usize].to_vec();
            let mut stats = FrameStats {
                frame: job.frame,
                timings: job
                    .timer
                    .as_ref()
                    .map(|(names, off, size)| PassTimer::timings(names, &piece(*off, *size), period))
                    .unwrap_or_default(),
                flux: job
                    .flux
                    .iter()
                    .map(|&(off, scale)| crate::passes::flux_stats(&piece(off, crate::output::FLUX_STATS_BYTES), scale))
                    .collect(),
                lights_redone: job.lights_redone,
                ..Default::default()
            };
            stats.technique = TechniqueStats {
                technique: self.settings.photons.emission,
                grid: self.settings.photons.count,
                ..Default::default()
            };
            for (p, pieces) in job.pendings {
                let bytes: Vec<Vec<u8>> = pieces.iter().map(|&(off, size)| piece(off, size)).collect();
                match p.finish(&bytes) {
                    // The lights report their emission technique; the frame's is the setting.
                    Ok(t) => stats.technique.merge(&TechniqueStats { technique: self.settings.photons.emission, ..t }),
                    Err(e) => {
                        let m = e.to_string();
                        self.last_error = Some(m.clone());
                        stats.overflow = Some(m);
                    }
                }
            }
            if let Some(off) = job.sphere_stats {
                let c = piece(off, 4);
                stats.sphere_stack_overflows = u64::from(u32::from_le_bytes([c[0], c[1], c[2], c[3]]));
            }
            if let Some((off, size)) = job.indirect_stats {
                (stats.indirect_lost_deposits, stats.indirect_order_flux) =
                    crate::indirect::read_counters(&piece(off, size));
            }
            if stats.indirect_lost_deposits > 0 {
                let m = format!(
                    "{} interreflection photon deposits found no slot in the cache (indirect.capacity is too small \
                     for the scene's surfaces at indirect.grid): that light is missing",
                    stats.indirect_lost_deposits
                );
                self.last_error = Some(m.clone());
                stats.overflow.get_or_insert(m);
            }
            if stats.sphere_stack_overflows > 0 {
                let m = format!(
                    "{} caustic-sphere occlusion rays overflowed the BVH traversal stack: those pixels got no caustic \
                     from that object",
                    stats.sphere_stack_overflows
                );
                self.last_error = Some(m.clone());
                stats.overflow.get_or_insert(m);
            }
            let overflows: u64 = stats.flux.iter().map(|f| f.stack_overflows).sum();
            if overflows > 0 {
                let m = format!(
                    "{overflows} photon rays overflowed the BVH traversal stack ({} entries) and may have missed \
                     a surface",
                    crate::accel::BVH_STACK
                );
                self.last_error = Some(m.clone());
                stats.overflow.get_or_insert(m);
            }
            if self.latest.as_ref().is_none_or(|l| l.frame <= stats.frame) {
                self.latest = Some(stats);
            }
        }
        Ok(())
    }

    /// The statistics of the newest frame that asked for them and that the GPU has finished,
    /// if not returned before. Never blocks.
    pub fn poll_stats(&mut self) -> Result<Option<FrameStats>> {
        self.map_recorded();
        let _ = self.ctx.device.poll(wgpu::PollType::Poll);
        self.collect()?;
        Ok(self.latest.take())
    }

    /// Wait for the statistics of every submitted frame that asked for them; the newest.
    pub fn wait_stats(&mut self) -> Result<Option<FrameStats>> {
        self.map_recorded();
        self.ctx
            .device
            .poll(wgpu::PollType::Wait { submission_index: None, timeout: None })
            .map_err(|e| Error::Device(format!("{e}")))?;
        // On a device that other threads poll too, one of them may be about to run a mapping's
        // callback when our wait returns: wait for it.
        let start = std::time::Instant::now();
        while self.ring.iter().any(|s| s.state.load(Ordering::Acquire) == 2) {
            if start.elapsed().as_secs() > 60 {
                return Err(Error::Device("the frame statistics were never mapped".into()));
            }
            let _ = self.ctx.device.poll(wgpu::PollType::Poll);
            std::thread::sleep(std::time::Duration::from_micros(200));
        }
        self.collect()?;
        Ok(self.latest.take())
    }
}

/// A free statistics slot whose staging buffer holds `size` bytes (grown if needed); None when
/// every slot waits to be read (the frame's statistics are then not copied).
pub(super) fn free_slot(ring: &mut Vec<StatsSlot>, ctx: &GpuContext, size: u64) -> Option<usize> {
    let staging = |size: u64| {
        let usage = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        ctx.kept_buffer("frame_statistics", size.next_power_of_two(), usage)
    };
    let i = match ring.iter().position(|s| s.state.load(Ordering::Acquire) == 0) {
        Some(i) => i,
        None if ring.len() < STATS_SLOTS => {
            ring.push(StatsSlot { staging: staging(size), state: Arc::new(AtomicU8::new(0)), job: None });
            ring.len() - 1
        }
        None => return None,
    };
    if ring[i].staging.size() < size {
        ring[i].staging = staging(size);
    }
    Some(i)
}

impl Renderer {
    /// Copy the frame's counters (`copies`) and pass times into a free slot of the ring (none
    /// free: this frame's statistics are not copied).
    pub(super) fn copy_stats(
        &mut self,
        enc: &mut wgpu::CommandEncoder,
        timer: &mut PassTimer,
        (copies, pendings): (StatsCopies, Vec<Pending>),
        lights_redone: Vec<bool>,
    ) {
        let ctx = self.ctx.clone();
        ctx.begin_scope("stats", enc);
        let timestamps = timer.resolve(&ctx, enc);
        ctx.end_scope();
        let mut sources: Vec<(wgpu::Buffer, u64)> = Vec::new();
        let timer_job = timestamps.map(|(b, size)| {
            sources.push((b, size));
            (timer.names().to_vec(), 0, size)
        });
        for (b, _) in &copies.flux {
            sources.push((b.clone(), crate::output::FLUX_STATS_BYTES));
        }
        let piece_lists: Vec<Vec<(wgpu::Buffer, u64)>> = pendings.iter().map(|p| p.sources()).collect();
        for list in &piece_lists {
            sources.extend(list.iter().cloned());
        }
        if let Some(b) = &copies.spheres {
            sources.push((b.clone(), 8));
        }
        if let Some(b) = &copies.indirect {
            sources.push((b.clone(), b.size()));
        }
        // Offsets in the staging buffer (copies are 4-byte aligned; every size is).
        let mut offsets = Vec::with_capacity(sources.len());
        let mut total = 0u64;
        for (_, size) in &sources {
            offsets.push(total);
            total += size.div_ceil(8) * 8;
        }
        let Some(slot) = free_slot(&mut self.ring, &ctx, total.max(8)) else { return };
        let staging = &self.ring[slot].staging;
        for ((b, size), off) in sources.iter().zip(&offsets) {
            if *size > 0 {
                enc.copy_buffer_to_buffer(b, 0, staging, *off, *size);
            }
        }
        let mut k = usize::from(timer_job.is_some());
        let timer_job = timer_job.map(|(names, _, size)| (names, offsets[0], size));
        let mut flux = Vec::new();
        for (_, scale) in &copies.flux {
            flux.push((offsets[k], *scale));
            k += 1;
        }
        let mut pend = Vec::new();
        for (p, list) in pendings.into_iter().zip(&piece_lists) {
            let pieces = list.iter().map(|(_, size)| {
                let piece = (offsets[k], *size);
                k += 1;
                piece
            });
            pend.push((p, pieces.collect()));
        }
        let sphere_stats = copies.spheres.as_ref().map(|_| offsets[k]);
        k += usize::from(copies.spheres.is_some());
        let indirect_stats = copies.indirect.as_ref().map(|b| (offsets[k], b.size()));
        self.ring[slot].job = Some(StatsJob {
            frame: self.frame,
            timer: timer_job,
            flux,
            pendings: pend,
            lights_redone,
            sphere_stats,
            indirect_stats,
        });
        self.ring[slot].state.store(1, Ordering::Release);
    }
}
