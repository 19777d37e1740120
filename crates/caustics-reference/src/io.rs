//! Image files: EXR (linear radiance) and PNG (tone-mapped, or display values), written through a
//! temporary file and renamed so that a failure never leaves a half-written image.

use caustics::error::{Error, Result};
use caustics::image_io::{Image, srgb_decode, srgb_encode, tonemap};
use std::path::Path;

/// Reading and writing an [`Image`] as a file.
pub trait ImageIo: Sized {
    /// Read an EXR (RGB or RGBA; a single Y channel is read as grey) or a PNG (decoded to
    /// linear [0,1] through the sRGB curve).
    fn read(path: &Path) -> Result<Self>;
    /// Write EXR (linear radiance) or PNG (tone-mapped with `exposure`), chosen by extension.
    fn write(&self, path: &Path, exposure: f32) -> Result<()> {
        self.write_with_settings(path, exposure, None)
    }
    /// [`ImageIo::write`], an EXR's header also holding `settings` (the JSON of the settings the
    /// image was rendered with, in the attribute [`SETTINGS_ATTRIBUTE`]; [`read_exr_settings`]
    /// reads it back). PNG files hold no settings.
    fn write_with_settings(&self, path: &Path, exposure: f32, settings: Option<&str>) -> Result<()>;
}

/// The EXR header attribute (text) that holds the settings an image was rendered with, as JSON
/// (`caustics render --settings` reads it back once saved to a file).
pub const SETTINGS_ATTRIBUTE: &str = "caustics_settings";

/// The settings JSON an EXR was rendered with ([`SETTINGS_ATTRIBUTE`]), if its header has them.
pub fn read_exr_settings(path: &Path) -> Result<Option<String>> {
    let file = path.display().to_string();
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| Error::input(&file, "", format!("cannot read EXR: {e}")))?;
    let key = exr::meta::attribute::Text::new_or_panic(SETTINGS_ATTRIBUTE);
    Ok(meta.headers.iter().find_map(|h| match h.own_attributes.other.get(&key) {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => Some(t.to_string()),
        _ => None,
    }))
}

impl ImageIo for Image {
    fn read(path: &Path) -> Result<Image> {
        let file = path.display().to_string();
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "exr" => read_exr(path).map_err(|m| Error::input(file, "", m)),
            "png" => {
                let img = image::open(path).map_err(|e| Error::input(&file, "", format!("cannot read PNG: {e}")))?;
                let rgb = img.to_rgb8();
                let mut out = Image::new(rgb.width(), rgb.height());
                for (p, q) in out.pixels.iter_mut().zip(rgb.pixels()) {
                    *p = q.0.map(|c| srgb_decode(c as f32 / 255.0));
                }
                Ok(out)
            }
            _ => Err(Error::input(file, "", "unknown image type (expected .exr or .png)")),
        }
    }

    fn write_with_settings(&self, path: &Path, exposure: f32, settings: Option<&str>) -> Result<()> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        match ext.as_str() {
            "exr" => write_atomically(path, |tmp| write_exr(self, tmp, settings)),
            "png" => write_atomically(path, |tmp| {
                let bytes: Vec<u8> = self.pixels.iter().flat_map(|p| tonemap(*p, exposure)).collect();
                image::save_buffer_with_format(
                    tmp,
                    &bytes,
                    self.width,
                    self.height,
                    image::ColorType::Rgb8,
                    image::ImageFormat::Png,
                )
                .map_err(|e| e.to_string())
            }),
            _ => Err(Error::Output { path: path.into(), message: "unknown image type (use .png or .exr)".into() }),
        }
    }
}

fn write_exr(img: &Image, path: &Path, settings: Option<&str>) -> std::result::Result<(), String> {
    use exr::prelude::*;
    let w = img.width as usize;
    let px = &img.pixels;
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = px[p.y() * w + p.x()];
        (c[0], c[1], c[2])
    });
    let mut attributes = LayerAttributes::named("caustics");
    if let Some(json) = settings {
        // EXR text is bytes of Latin-1: anything beyond ASCII is written as a JSON escape.
        let ascii: String = json
            .chars()
            .flat_map(|c| {
                if c.is_ascii() {
                    vec![c]
                } else {
                    let mut units = [0u16; 2];
                    c.encode_utf16(&mut units)
                        .iter()
                        .flat_map(|u| format!("\\u{u:04x}").chars().collect::<Vec<_>>())
                        .collect()
                }
            })
            .collect();
        let text = exr::meta::attribute::Text::new_or_panic(ascii);
        attributes.other.insert(Text::new_or_panic(crate::io::SETTINGS_ATTRIBUTE), AttributeValue::Text(text));
    }
    let layer = Layer::new((img.width as usize, img.height as usize), attributes, Encoding::SMALL_LOSSLESS, channels);
    exr::image::Image::from_layer(layer).write().to_file(path).map_err(|e| e.to_string())
}

fn read_exr(path: &Path) -> std::result::Result<caustics::image_io::Image, String> {
    use exr::prelude::*;
    let img = read_first_rgba_layer_from_file(
        path,
        |res, _| {
            let s: exr::math::Vec2<usize> = res;
            caustics::image_io::Image::new(s.width() as u32, s.height() as u32)
        },
        |img: &mut caustics::image_io::Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = img.width as usize;
            img.pixels[pos.y() * w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| format!("cannot read EXR: {e}"))?;
    Ok(img.layer_data.channel_data.pixels)
}

/// Write values already meant for display (linear, in [0, 1]) as an sRGB PNG, without tone
/// mapping: normal maps, depth maps, heat maps.
pub fn write_display_png(img: &Image, path: &Path) -> Result<()> {
    write_atomically(path, |tmp| {
        let bytes: Vec<u8> =
            img.pixels.iter().flat_map(|p| p.map(|c| (255.0 * srgb_encode(c.clamp(0.0, 1.0))).round() as u8)).collect();
        image::save_buffer_with_format(
            tmp,
            &bytes,
            img.width,
            img.height,
            image::ColorType::Rgb8,
            image::ImageFormat::Png,
        )
        .map_err(|e| e.to_string())
    })
}

/// Write through a temporary file in the same folder, then rename, so that no half-written
/// output is ever left behind.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<()> {
    let err = |message: String| Error::Output { path: path.into(), message };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(err(format!("folder {} does not exist", dir.display())));
    }
    let name = path.file_name().ok_or_else(|| err("not a file name".into()))?;
    let ext = path.extension().map(|e| e.to_string_lossy().to_string()).unwrap_or_default();
    let tmp = dir.join(format!(".{}.{}.tmp.{ext}", name.to_string_lossy(), std::process::id()));
    if let Err(m) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(err(m));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        err(e.to_string())
    })
}
