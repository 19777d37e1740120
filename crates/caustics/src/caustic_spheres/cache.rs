//! The on-disk cache of caustic spheres: one file per object and settings.
//!
//! Layout (little endian): magic `CAUSPHR\0`, format version (u32), key (u64: FNV-1a of the
//! object's geometry, its material and the settings), storage (u32: 0 = f32, 1 = f16),
//! settings (directions, spheres, width, height, max_depth: u32; photons: u64), centre (3 f32),
//! radii (count u32, f32 each), directions (count u32, 3 f32 each), cells (count u64), the
//! table (8 values per cell, f32 or f16), and an FNV-1a checksum (u64) of every byte before it.
//! A file whose magic, version, key, settings, sizes or checksum disagree, or that is cut
//! short, is not trusted: the caller recomputes and rewrites it.
//!
//! FNV-1a is written here (a dozen lines) rather than pulling a hashing crate: the key only has
//! to change when its input changes, and the checksum only has to catch truncation and
//! corruption, not an adversary.

use super::{CausticSpheres, SphereGeometry, SphereSettings};
use crate::scene::{Object, Scene, Shape};
use glam::Vec3;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"CAUSPHR\0";
/// Bumped whenever the stored quantity, the layout or the precomputation changes (2: r_min
/// just beyond the nearest surface point, no longer 1.02 × the nearest vertex).
pub const FORMAT_VERSION: u32 = 2;

/// FNV-1a, 64 bits.
#[derive(Clone, Copy)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    /// Hash `bytes` in.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    /// The hash.
    pub fn finish(self) -> u64 {
        self.0
    }
}

/// Storage precision of the table on disk and on the GPU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Storage {
    /// 32-bit floats.
    F32,
    /// 16-bit floats (half the memory).
    F16,
}

/// The cache key of `object` of `scene` with `settings`: its geometry (every vertex and normal,
/// or the analytic shape's parameters), its material, the settings and the format version.
pub fn key(scene: &Scene, object: &Object, settings: &SphereSettings) -> u64 {
    let mut h = Fnv::default();
    h.write(&FORMAT_VERSION.to_le_bytes());
    match &object.shape {
        Shape::Mesh(m) => {
            h.write(b"mesh");
            for p in &m.positions {
                h.write(bytemuck::bytes_of(p));
            }
            for n in &m.normals {
                h.write(bytemuck::bytes_of(n));
            }
            for t in &m.indices {
                h.write(bytemuck::bytes_of(t));
            }
        }
        other => h.write(format!("{other:?}").as_bytes()),
    }
    h.write(format!("{:?}", scene.material_of(object)).as_bytes());
    h.write(format!("{settings:?}").as_bytes());
    h.finish()
}

/// The cache file of a key in `dir`.
pub fn path(dir: &Path, key: u64, storage: Storage) -> PathBuf {
    let s = if storage == Storage::F16 { "f16" } else { "f32" };
    dir.join(format!("spheres-{key:016x}-{s}.bin"))
}

/// Bytes of the file (its payload dominates).
pub fn encode(sp: &CausticSpheres, key: u64, storage: Storage) -> Vec<u8> {
    let mut b = Vec::with_capacity(64 + sp.data.len() * 32);
    b.extend_from_slice(MAGIC);
    b.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    b.extend_from_slice(&key.to_le_bytes());
    b.extend_from_slice(&(storage as u32).to_le_bytes());
    let s = &sp.settings;
    for v in [s.directions, s.spheres, s.width, s.height, s.max_depth] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&s.photons.to_le_bytes());
    for v in sp.geometry.center.to_array() {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&(sp.geometry.radii.len() as u32).to_le_bytes());
    for r in &sp.geometry.radii {
        b.extend_from_slice(&r.to_le_bytes());
    }
    b.extend_from_slice(&(sp.layout_dirs.len() as u32).to_le_bytes());
    for d in &sp.layout_dirs {
        for v in d.to_array() {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    b.extend_from_slice(&(sp.data.len() as u64).to_le_bytes());
    for cell in &sp.data {
        for &v in cell {
            match storage {
                Storage::F32 => b.extend_from_slice(&v.to_le_bytes()),
                Storage::F16 => b.extend_from_slice(&half::f16::from_f32(v).to_le_bytes()),
            }
        }
    }
    let mut h = Fnv::default();
    h.write(&b);
    b.extend_from_slice(&h.finish().to_le_bytes());
    b
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8], String> {
        let s = self.b.get(self.at..self.at + n).ok_or("the file is cut short")?;
        self.at += n;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().map_err(|_| "bad bytes")?))
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().map_err(|_| "bad bytes")?))
    }
    fn f32(&mut self) -> Result<f32, String> {
        Ok(f32::from_le_bytes(self.take(4)?.try_into().map_err(|_| "bad bytes")?))
    }
}

/// Decodes a cache file written for `key` and `settings`; any disagreement is an error saying
/// why (the caller rebuilds).
pub fn decode(bytes: &[u8], key: u64, settings: &SphereSettings) -> Result<(CausticSpheres, Storage), String> {
    if bytes.len() < MAGIC.len() + 8 {
        return Err("the file is cut short".into());
    }
    let (body, sum) = bytes.split_at(bytes.len() - 8);
    let mut h = Fnv::default();
    h.write(body);
    let mut r = Reader { b: body, at: 0 };
    if r.take(8)? != MAGIC {
        return Err("not a caustic spheres cache".into());
    }
    let version = r.u32()?;
    if version != FORMAT_VERSION {
        return Err(format!("format version {version}, expected {FORMAT_VERSION}"));
    }
    if u64::from_le_bytes(sum.try_into().map_err(|_| "bad bytes")?) != h.finish() {
        return Err("checksum mismatch (truncated or corrupt)".into());
    }
    if r.u64()? != key {
        return Err("written for another object, material or settings".into());
    }
    let storage = match r.u32()? {
        0 => Storage::F32,
        1 => Storage::F16,
        s => return Err(format!("unknown storage {s}")),
    };
    let s = SphereSettings {
        directions: r.u32()?,
        spheres: r.u32()?,
        width: r.u32()?,
        height: r.u32()?,
        max_depth: r.u32()?,
        photons: r.u64()?,
    };
    if s != *settings {
        return Err("written with other settings".into());
    }
    let center = Vec3::new(r.f32()?, r.f32()?, r.f32()?);
    let ns = r.u32()? as usize;
    if ns != s.spheres as usize {
        return Err("sphere count disagrees".into());
    }
    let radii = (0..ns).map(|_| r.f32()).collect::<Result<Vec<_>, _>>()?;
    let nd = r.u32()? as usize;
    if nd > (s.directions * s.directions) as usize {
        return Err("direction count disagrees".into());
    }
    let dirs = (0..nd).map(|_| Ok(Vec3::new(r.f32()?, r.f32()?, r.f32()?))).collect::<Result<Vec<_>, String>>()?;
    let cells = r.u64()? as usize;
    if cells != nd * ns * (s.width * s.height) as usize {
        return Err("table size disagrees".into());
    }
    let geometry = SphereGeometry { center, radii, width: s.width, height: s.height };
    let mut sp = CausticSpheres::empty(s, geometry, dirs);
    let per = if storage == Storage::F16 { 2 } else { 4 };
    let payload = r.take(cells * 8 * per)?;
    for (cell, chunk) in sp.data.iter_mut().zip(payload.chunks_exact(8 * per)) {
        for (v, c) in cell.iter_mut().zip(chunk.chunks_exact(per)) {
            *v = match storage {
                Storage::F32 => f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                Storage::F16 => half::f16::from_le_bytes([c[0], c[1]]).to_f32(),
            };
        }
    }
    if r.at != body.len() {
        return Err("trailing bytes".into());
    }
    Ok((sp, storage))
}

/// Writes the cache atomically (a temporary file renamed into place).
pub fn write(path: &Path, bytes: &[u8]) -> crate::Result<()> {
    let err = |e: std::io::Error| crate::Error::Output { path: path.to_path_buf(), message: e.to_string() };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(err)?;
    }
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, bytes).map_err(err)?;
    std::fs::rename(&tmp, path).map_err(err)
}
