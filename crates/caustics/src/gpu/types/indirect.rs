//! The interreflection cache's record (`shaders/shared/indirect.wgsl`, src/indirect/).

use bytemuck::{Pod, Zeroable};

/// `IndirectParams`: one record for `indirect_trace`, `indirect_resolve`, `indirect_blend` and
/// `indirect_gather`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub struct IndirectParams {
    /// The grid's corner (m) and its cells' side (w, m).
    pub origin: [f32; 4],
    /// A directional light's emission disk: centre, radius (m).
    pub disk: [f32; 4],
    /// The medium's box (`lo.w`: 0 none, 1 homogeneous, 2 a density grid).
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    /// rgb = sigma_t (1/m).
    pub sigma_t: [f32; 4],
    pub camera: [f32; 4],
    pub photons: u32,
    pub seed: u32,
    /// Hash table entries (a power of two).
    pub capacity: u32,
    pub bounces: u32,
    pub max_events: u32,
    pub width: u32,
    pub height: u32,
    /// `indirect_trace`: the light's place in the frame's list.
    pub light_index: u32,
    /// `indirect_blend`: the new batch's weight.
    pub alpha: f32,
    pub _pad: [u32; 3],
}

/// Bounce orders the statistics tell apart (`IC_ORDERS`: 2 to 9, the last 9 and up).
pub const IC_ORDERS: usize = 8;
/// `indirect_trace`'s counters: the lost deposits' word, then per light this many words from
/// `IC_COUNTER_BASE` (per order r, g, b as 64-bit pairs, then the light's scale as f32 bits).
pub const IC_COUNTER_BASE: usize = 4;
pub const IC_LIGHT_WORDS: usize = 52;
