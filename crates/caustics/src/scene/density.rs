//! Density grids of heterogeneous media (scene `medium.density`): a regular grid of
//! non-negative scalars spanning the medium's box, multiplying its `sigma_s` and `sigma_a`.
//!
//! **File format: Mitsuba's binary `.vol` ("gridvolume"), not OpenVDB.** The one pure-Rust
//! OpenVDB reader (`vdb-rs`, 0.6.0 of January 2024) reads only, documents missing features and
//! unreadable files, and its documentation does not build on docs.rs; there is no NanoVDB reader
//! on crates.io. A raw dense grid needs about forty lines to read exactly, the renderers upload
//! it densely anyway (a 3D texture), and `.vol` is the format Mitsuba reads natively, so the
//! same file drives the independent check (`tools/mitsuba/convert.py`). Layout, little-endian:
//!
//! | bytes | content |
//! | --- | --- |
//! | 0..3 | `V`, `O`, `L` |
//! | 3 | version, 3 |
//! | 4..8 | encoding, i32: 1 = float32 (the only one read) |
//! | 8..20 | xres, yres, zres, i32, each at least 1 |
//! | 20..24 | channels, i32: 1 (density) |
//! | 24..48 | bounding box, 6 × f32 (min xyz, max xyz): ignored, the grid spans `medium.bounds` |
//! | 48.. | xres·yres·zres f32 values, x fastest, then y, then z |
//!
//! **Lookup**: trilinear between voxel centres `lo + (i + ½)/res · (hi − lo)`, clamped to the
//! outermost centres (Mitsuba's `gridvolume` with its default `filter_type = trilinear` and
//! `wrap_mode = clamp`). The GPU (`shaders/shared/medium.wgsl`, `grid_density`) does the same
//! arithmetic with `textureLoad`.

use glam::Vec3;
use std::path::Path;

/// Largest grid resolution per axis: wgpu's default limit for 3D textures is 2048, and a
/// 1024³ float grid is already 4 GiB.
pub const MAX_GRID_RES: u32 = 1024;

/// A dense scalar grid over the medium's box (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct DensityGrid {
    /// Resolution along x, y, z.
    pub dims: [u32; 3],
    /// `dims[0]·dims[1]·dims[2]` values, x fastest.
    pub data: Vec<f32>,
    /// The largest value: the majorant of delta and ratio tracking.
    pub max: f32,
}

impl DensityGrid {
    /// A grid from values (x fastest), checked as a file is: dimensions 1..=[`MAX_GRID_RES`],
    /// exactly as many values, all finite and non-negative.
    pub fn new(dims: [u32; 3], data: Vec<f32>) -> Result<Self, String> {
        for (k, &n) in dims.iter().enumerate() {
            if n == 0 || n > MAX_GRID_RES {
                return Err(format!("grid dimension {} is {n}: must be 1 to {MAX_GRID_RES}", ["x", "y", "z"][k]));
            }
        }
        let count = dims.iter().map(|&n| n as usize).product::<usize>();
        if data.len() != count {
            return Err(format!("{} values for a {}×{}×{} grid", data.len(), dims[0], dims[1], dims[2]));
        }
        let mut max = 0.0f32;
        for (i, &v) in data.iter().enumerate() {
            if !(v.is_finite() && v >= 0.0) {
                let (x, y, z) =
                    (i % dims[0] as usize, i / dims[0] as usize % dims[1] as usize, i / (count / dims[2] as usize));
                return Err(format!("density at voxel ({x}, {y}, {z}) is {v}: must be finite and non-negative"));
            }
            max = max.max(v);
        }
        Ok(DensityGrid { dims, data, max })
    }

    /// Read a `.vol` file (module documentation). Errors say what is wrong with the file.
    pub fn load(path: &Path) -> Result<Self, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("cannot read density grid: {e}"))?;
        Self::from_vol_bytes(&bytes)
    }

    /// Parse the bytes of a `.vol` file.
    pub fn from_vol_bytes(b: &[u8]) -> Result<Self, String> {
        const HEADER: usize = 48;
        if b.len() < 4 || &b[0..3] != b"VOL" {
            return Err("not a .vol density grid (the file does not start with \"VOL\")".into());
        }
        if b[3] != 3 {
            return Err(format!("unsupported .vol version {} (this program reads 3)", b[3]));
        }
        if b.len() < HEADER {
            return Err(format!("truncated .vol header ({} bytes, the header has {HEADER})", b.len()));
        }
        let i32_at = |o: usize| i32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
        let encoding = i32_at(4);
        if encoding != 1 {
            return Err(format!("unsupported .vol encoding {encoding} (this program reads 1, float32)"));
        }
        let mut dims = [0u32; 3];
        for (k, d) in dims.iter_mut().enumerate() {
            let n = i32_at(8 + 4 * k);
            if n <= 0 || n as u32 > MAX_GRID_RES {
                return Err(format!("grid dimension {} is {n}: must be 1 to {MAX_GRID_RES}", ["x", "y", "z"][k]));
            }
            *d = n as u32;
        }
        let channels = i32_at(20);
        if channels != 1 {
            return Err(format!("{channels} channels: a density grid has 1"));
        }
        let count = dims.iter().map(|&n| n as usize).product::<usize>();
        let want = HEADER + 4 * count;
        if b.len() < want {
            return Err(format!(
                "truncated: a {}×{}×{} grid needs {want} bytes, the file has {}",
                dims[0],
                dims[1],
                dims[2],
                b.len()
            ));
        }
        if b.len() > want {
            return Err(format!(
                "malformed: {} bytes after the {}×{}×{} grid's data",
                b.len() - want,
                dims[0],
                dims[1],
                dims[2]
            ));
        }
        let data = b[HEADER..].chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        Self::new(dims, data)
    }

    /// The `.vol` bytes of this grid, with the box `lo..hi` in its header (informational).
    pub fn to_vol_bytes(&self, lo: Vec3, hi: Vec3) -> Vec<u8> {
        let mut b = Vec::with_capacity(48 + 4 * self.data.len());
        b.extend_from_slice(b"VOL");
        b.push(3);
        b.extend_from_slice(&1i32.to_le_bytes());
        for n in self.dims {
            b.extend_from_slice(&(n as i32).to_le_bytes());
        }
        b.extend_from_slice(&1i32.to_le_bytes());
        for v in [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z] {
            b.extend_from_slice(&v.to_le_bytes());
        }
        for v in &self.data {
            b.extend_from_slice(&v.to_le_bytes());
        }
        b
    }

    /// Value at voxel (x, y, z), clamped into the grid.
    #[inline]
    fn at(&self, x: i32, y: i32, z: i32) -> f32 {
        let [nx, ny, nz] = self.dims.map(|n| n as i32);
        let (x, y, z) = (x.clamp(0, nx - 1), y.clamp(0, ny - 1), z.clamp(0, nz - 1));
        self.data[((z * ny + y) * nx + x) as usize]
    }

    /// Trilinear density at the box coordinates `u` (0..1 on each axis from the box's min to
    /// its max corner) between voxel centres, clamped to the outermost ones.
    pub fn lookup(&self, u: Vec3) -> f32 {
        let n = Vec3::new(self.dims[0] as f32, self.dims[1] as f32, self.dims[2] as f32);
        let p = u * n - 0.5;
        let f = p.floor();
        let t = p - f;
        let (x, y, z) = (f.x as i32, f.y as i32, f.z as i32);
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let c00 = lerp(self.at(x, y, z), self.at(x + 1, y, z), t.x);
        let c10 = lerp(self.at(x, y + 1, z), self.at(x + 1, y + 1, z), t.x);
        let c01 = lerp(self.at(x, y, z + 1), self.at(x + 1, y, z + 1), t.x);
        let c11 = lerp(self.at(x, y + 1, z + 1), self.at(x + 1, y + 1, z + 1), t.x);
        lerp(lerp(c00, c10, t.y), lerp(c01, c11, t.y), t.z)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vol_round_trip_and_trilinear_lookup() {
        let g = DensityGrid::new([2, 1, 1], vec![1.0, 3.0]).unwrap();
        let b = g.to_vol_bytes(Vec3::ZERO, Vec3::ONE);
        assert_eq!(DensityGrid::from_vol_bytes(&b).unwrap(), g);
        // Voxel centres at x = 0.25 and 0.75; clamped outside them, linear between.
        assert_eq!(g.lookup(Vec3::new(0.1, 0.5, 0.5)), 1.0);
        assert_eq!(g.lookup(Vec3::new(0.9, 0.5, 0.5)), 3.0);
        assert!((g.lookup(Vec3::new(0.5, 0.2, 0.9)) - 2.0).abs() < 1e-6);
        assert!(DensityGrid::from_vol_bytes(&b[..b.len() - 1]).unwrap_err().contains("truncated"));
    }
}
