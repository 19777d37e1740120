//! The frame's intermediate buffers as images for people to look at (`caustics render --dump`).

use super::GBuffer;
use crate::error::Result;
use crate::gpu::GpuContext;
use crate::image_io::Image;
use glam::Vec3;

pub(crate) fn bytes_to_image(data: &[u8], w: u32, h: u32) -> Image {
    let px: &[[f32; 4]] = bytemuck::cast_slice(data);
    Image { width: w, height: h, pixels: px.iter().map(|p| [p[0], p[1], p[2]]).collect() }
}

/// An image of a frame's intermediate buffers, for people to look at
/// ([`crate::renderer::Renderer::dump_images`]; `caustics render --dump` writes them).
#[derive(Debug, Clone)]
pub struct DumpImage {
    /// File name without extension (`light0_face0_caster_front_normal`).
    pub name: String,
    /// The buffer's values, linear.
    pub image: Image,
    /// How it is meant to be shown.
    pub kind: DumpKind,
}

/// How a [`DumpImage`] is meant to be shown.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum DumpKind {
    /// Values already meant for display (normals as 0.5 + 0.5 n, normalised depths), linear.
    Display,
    /// Irradiance or radiance: shown with this exposure (and kept linear in EXR).
    Radiance {
        /// Multiplies the values before tone mapping.
        exposure: f32,
    },
}

/// The light-space buffers as images: normals (0.5 + 0.5 n), depths (distance from the light,
/// normalised), and the caustic maps (with the exposure that maps their 99.9th percentile to
/// white: they span orders of magnitude).
pub(crate) fn dump_images(
    ctx: &GpuContext,
    lights: &[(Vec<(&str, &GBuffer)>, u32)],
    maps: &[Vec<Image>],
) -> Result<Vec<DumpImage>> {
    let mut out = Vec::new();
    for (li, (bufs, nf)) in lights.iter().enumerate() {
        for f in 0..*nf {
            for &(name, gb) in bufs {
                // A spill face has no caster buffers (their arrays hold the emitting faces only).
                if f >= gb.pos.depth_or_array_layers() {
                    continue;
                }
                let pos = ctx.read_texture(&gb.pos, f, 16)?;
                let nrm = ctx.read_texture(&gb.nrm, f, 16)?;
                let (w, h) = (gb.pos.width(), gb.pos.height());
                let p: &[[f32; 4]] = bytemuck::cast_slice(&pos);
                let nn: &[[f32; 4]] = bytemuck::cast_slice(&nrm);
                let mut ni = Image::new(w, h);
                let mut di = Image::new(w, h);
                let valid: Vec<f32> =
                    p.iter().filter(|q| q[3] >= 0.0).map(|q| Vec3::new(q[0], q[1], q[2]).length()).collect();
                let (dmin, dmax) = valid.iter().fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
                for i in 0..(w * h) as usize {
                    if p[i][3] >= 0.0 {
                        ni.pixels[i] = [0.5 + 0.5 * nn[i][0], 0.5 + 0.5 * nn[i][1], 0.5 + 0.5 * nn[i][2]]
                            .map(crate::image_io::srgb_decode);
                        let d = Vec3::new(p[i][0], p[i][1], p[i][2]).length();
                        let t = 1.0 - (d - dmin) / (dmax - dmin).max(1e-6);
                        di.pixels[i] = [crate::image_io::srgb_decode(t); 3];
                    }
                }
                let stem = format!("light{li}_face{f}_{name}");
                out.push(DumpImage { name: format!("{stem}_normal"), image: ni, kind: DumpKind::Display });
                out.push(DumpImage { name: format!("{stem}_depth"), image: di, kind: DumpKind::Display });
            }
            let map = &maps[li][f as usize];
            let mut l: Vec<f32> = map.luminance().into_iter().filter(|x| *x > 0.0).collect();
            l.sort_by(f32::total_cmp);
            let p = l.get(l.len().saturating_sub(1 + l.len() / 1000)).copied().unwrap_or(1.0).max(1e-9);
            out.push(DumpImage {
                name: format!("light{li}_face{f}_caustic_map"),
                image: map.clone(),
                kind: DumpKind::Radiance { exposure: 2.0 / p },
            });
        }
    }
    Ok(out)
}
