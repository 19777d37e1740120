//! The environment light: radiance arriving from infinitely far away, read from an
//! equirectangular map (OpenEXR or Radiance `.hdr`), and a distribution to importance-sample it.
//!
//! Orientation (`docs/scene-format.md`, "environment"): for a unit direction `d` from the scene
//! toward the sky, the map is read at `u = 0.5 + atan2(d.x, -d.z) / 2π`, `v = acos(d.y) / π`
//! (u to the right, v down, texel (0, 0) top-left), bilinearly, at `R_y(-angle) d` where
//! `angle` is `rotate_y_deg` and `R_y` the right-handed rotation about +Y. Bilinear filtering
//! wraps around in u and clamps at the poles in v, with texel centres at `(i + ½, j + ½) / size`.
//!
//! Sampling: a piecewise-constant distribution over the map's texels (marginal over rows,
//! conditional within a row), each texel weighted by the integral of the bilinear radiance over
//! its cell (a [1/8, 3/4, 1/8] tensor filter of its 3×3 neighbourhood: so wherever the bilinear
//! lookup is non-zero, the density is too) times `sin θ` at its centre (the solid angle a texel
//! covers). A point uniform in the chosen texel's (u, v) cell has solid-angle density
//! `p(u, v) / (2π² sin θ)`.

use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

/// An environment map with its importance-sampling distribution.
#[derive(Clone)]
pub struct Environment {
    /// The map file (for messages).
    pub path: PathBuf,
    /// Map width in texels (twice the height).
    pub width: u32,
    /// Map height in texels.
    pub height: u32,
    /// Radiance (texel value × scale, negatives set to 0), W/(m² sr), row-major, top row first.
    pub texels: Vec<Vec3>,
    /// The scene file's `scale` (already applied to `texels`).
    pub scale: Vec3,
    /// The scene file's `rotate_y_deg`, in radians.
    pub rotate_y: f32,
    /// Negative texel values (DWAB ringing, for example) that loading set to 0.
    pub clamped_negative: usize,
    /// World → map space: `R_y(-rotate_y)`.
    world_to_map: Mat3,
    dist: Distribution2D,
}

impl std::fmt::Debug for Environment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Environment")
            .field("path", &self.path)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("scale", &self.scale)
            .field("rotate_y", &self.rotate_y)
            .finish_non_exhaustive()
    }
}

/// One direction drawn from [`Environment::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    /// Unit direction toward the sky (the opposite of the way the light travels).
    pub dir: Vec3,
    /// Radiance arriving from `dir` ([`Environment::lookup`]), W/(m² sr).
    pub radiance: Vec3,
    /// Density of `dir` with respect to solid angle (sr⁻¹).
    pub pdf: f32,
}

impl Environment {
    /// Load a map file (`.exr` or `.hdr`); the message of an error says what is wrong with it
    /// (the caller names the file).
    pub fn load(path: &Path, scale: Vec3, rotate_y_deg: f32) -> Result<Environment, String> {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
        if !path.exists() {
            return Err("file not found".into());
        }
        let (w, h, mut texels) = match ext.as_str() {
            "exr" => read_exr(path)?,
            "hdr" => read_hdr(path)?,
            _ => return Err("unknown environment map type (expected .exr or Radiance .hdr)".into()),
        };
        if texels.iter().any(|t| !t.is_finite()) {
            return Err("the map holds non-finite values (NaN or infinity)".into());
        }
        let mut clamped_negative = 0;
        for t in &mut texels {
            for c in 0..3 {
                if t[c] < 0.0 {
                    t[c] = 0.0;
                    clamped_negative += 1;
                }
            }
            *t *= scale;
        }
        let mut env = Environment::from_texels(w, h, texels, rotate_y_deg)?;
        env.path = path.to_path_buf();
        env.scale = scale;
        env.clamped_negative = clamped_negative;
        Ok(env)
    }

    /// A map from radiance texels (row-major, top row first, `width = 2 × height`).
    pub fn from_texels(width: u32, height: u32, texels: Vec<Vec3>, rotate_y_deg: f32) -> Result<Environment, String> {
        if width == 0 || height == 0 || width != 2 * height {
            return Err(format!("an equirectangular map must be twice as wide as it is high (got {width}×{height})"));
        }
        if texels.len() != (width * height) as usize {
            return Err(format!("expected {} texels, got {}", width * height, texels.len()));
        }
        if !rotate_y_deg.is_finite() {
            return Err("rotate_y_deg must be finite".into());
        }
        let rotate_y = rotate_y_deg.to_radians();
        let dist = Distribution2D::new(width as usize, height as usize, &texels);
        Ok(Environment {
            path: PathBuf::new(),
            width,
            height,
            texels,
            scale: Vec3::ONE,
            rotate_y,
            clamped_negative: 0,
            world_to_map: Mat3::from_rotation_y(-rotate_y),
            dist,
        })
    }

    /// Turn the map to `rotate_y` radians about +Y (the scene format's `rotate_y_deg`, in
    /// radians); lookups and sampling follow.
    pub fn set_rotate_y(&mut self, rotate_y: f32) {
        self.rotate_y = rotate_y;
        self.world_to_map = Mat3::from_rotation_y(-rotate_y);
    }

    /// Map coordinates (u, v) in [0, 1]² of unit world direction `d` (toward the sky).
    pub fn uv(&self, d: Vec3) -> Vec2 {
        let m = self.world_to_map * d;
        let u = 0.5 + m.x.atan2(-m.z) / (2.0 * PI);
        let v = m.y.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(u, v)
    }

    /// Unit world direction of map coordinates (u, v); inverse of [`Self::uv`].
    pub fn direction(&self, uv: Vec2) -> Vec3 {
        let phi = (uv.x - 0.5) * 2.0 * PI;
        let theta = uv.y * PI;
        let (st, ct) = theta.sin_cos();
        let m = Vec3::new(st * phi.sin(), ct, -st * phi.cos());
        self.world_to_map.transpose() * m
    }

    /// Texel (x, y) (x wrapped around, y clamped).
    #[inline]
    pub fn texel(&self, x: i64, y: i64) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        self.texels[(y.clamp(0, h - 1) * w + x.rem_euclid(w)) as usize]
    }

    /// Radiance (W/(m² sr)) arriving from unit world direction `d` (toward the sky), bilinear.
    pub fn lookup(&self, d: Vec3) -> Vec3 {
        let uv = self.uv(d);
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0) * (1.0 - fx) + self.texel(x0 + 1, y0) * fx;
        let bottom = self.texel(x0, y0 + 1) * (1.0 - fx) + self.texel(x0 + 1, y0 + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Whether the map is black everywhere (nothing to sample).
    pub fn is_black(&self) -> bool {
        self.dist.total <= 0.0
    }

    /// A direction drawn with density roughly proportional to radiance × solid angle, for a
    /// uniform point `u` of the unit square; `None` when the map is black.
    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        let (uv, pdf_uv) = self.dist.sample(u)?;
        let dir = self.direction(uv);
        let sin_t = (uv.y * PI).sin();
        if sin_t <= 0.0 {
            return None;
        }
        let pdf = pdf_uv / (2.0 * PI * PI * sin_t);
        Some(EnvSample { dir, radiance: self.lookup(dir), pdf })
    }

    /// The solid-angle density with which [`Self::sample`] draws unit world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let m = self.world_to_map * d;
        let sin_t = (1.0 - m.y * m.y).max(0.0).sqrt();
        if sin_t <= 0.0 {
            return 0.0;
        }
        self.dist.pdf(self.uv(d)) / (2.0 * PI * PI * sin_t)
    }

    /// Solid angle (sr) of texel row `y`: `(2π / W) (cos θ₀ − cos θ₁)`.
    pub fn texel_solid_angle(&self, y: u32) -> f32 {
        let h = self.height as f64;
        let t0 = y as f64 / h * std::f64::consts::PI;
        let t1 = (y + 1) as f64 / h * std::f64::consts::PI;
        (2.0 * std::f64::consts::PI / self.width as f64 * (t0.cos() - t1.cos())) as f32
    }
}

/// The weight of a colour in the sampling distribution.
#[inline]
fn weight(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// Piecewise-constant density over the unit square, one cell per texel.
#[derive(Clone)]
struct Distribution2D {
    w: usize,
    h: usize,
    /// Cell weights, row-major.
    func: Vec<f32>,
    /// Per row, the normalised cumulative weights (w + 1 entries each).
    cond_cdf: Vec<f64>,
    /// Normalised cumulative row weights (h + 1 entries).
    marg_cdf: Vec<f64>,
    total: f64,
}

impl Distribution2D {
    fn new(w: usize, h: usize, texels: &[Vec3]) -> Distribution2D {
        let at =
            |x: i64, y: i64| weight(texels[(y.clamp(0, h as i64 - 1) as usize) * w + x.rem_euclid(w as i64) as usize]);
        const K: [f32; 3] = [0.125, 0.75, 0.125];
        let mut func = vec![0.0f32; w * h];
        for y in 0..h {
            let sin_t = ((y as f64 + 0.5) / h as f64 * std::f64::consts::PI).sin() as f32;
            for x in 0..w {
                let mut s = 0.0;
                for (j, ky) in K.iter().enumerate() {
                    for (i, kx) in K.iter().enumerate() {
                        s += ky * kx * at(x as i64 + i as i64 - 1, y as i64 + j as i64 - 1);
                    }
                }
                func[y * w + x] = s * sin_t;
            }
        }
        let mut cond_cdf = vec![0.0f64; h * (w + 1)];
        let mut row_sum = vec![0.0f64; h];
        for y in 0..h {
            let c = &mut cond_cdf[y * (w + 1)..(y + 1) * (w + 1)];
            for x in 0..w {
                c[x + 1] = c[x] + func[y * w + x] as f64;
            }
            row_sum[y] = c[w];
            if c[w] > 0.0 {
                let t = c[w];
                c.iter_mut().for_each(|v| *v /= t);
            }
        }
        let mut marg_cdf = vec![0.0f64; h + 1];
        for y in 0..h {
            marg_cdf[y + 1] = marg_cdf[y] + row_sum[y];
        }
        let total = marg_cdf[h];
        if total > 0.0 {
            marg_cdf.iter_mut().for_each(|v| *v /= total);
        }
        Distribution2D { w, h, func, cond_cdf, marg_cdf, total }
    }

    /// Index `i` with `cdf[i] <= u < cdf[i + 1]` and a non-empty interval, and the position of
    /// `u` inside it.
    fn pick(cdf: &[f64], u: f64) -> (usize, f64) {
        let n = cdf.len() - 1;
        let mut i = cdf.partition_point(|&c| c <= u).saturating_sub(1).min(n - 1);
        while i > 0 && cdf[i + 1] <= cdf[i] {
            i -= 1; // an empty interval at the end (u rounded to 1)
        }
        let span = cdf[i + 1] - cdf[i];
        let f = if span > 0.0 { ((u - cdf[i]) / span).clamp(0.0, 1.0 - 1e-7) } else { 0.5 };
        (i, f)
    }

    /// A point of the unit square and its density there.
    fn sample(&self, u: Vec2) -> Option<(Vec2, f32)> {
        if self.total <= 0.0 {
            return None;
        }
        let (y, fy) = Self::pick(&self.marg_cdf, u.y as f64);
        let (x, fx) = Self::pick(&self.cond_cdf[y * (self.w + 1)..(y + 1) * (self.w + 1)], u.x as f64);
        let f = self.func[y * self.w + x];
        if f <= 0.0 {
            return None;
        }
        let uv = Vec2::new(((x as f64 + fx) / self.w as f64) as f32, ((y as f64 + fy) / self.h as f64) as f32);
        Some((uv, (f as f64 * (self.w * self.h) as f64 / self.total) as f32))
    }

    /// Density at a point of the unit square.
    fn pdf(&self, uv: Vec2) -> f32 {
        if self.total <= 0.0 {
            return 0.0;
        }
        let x = ((uv.x * self.w as f32) as i64).rem_euclid(self.w as i64) as usize;
        let y = ((uv.y * self.h as f32) as usize).min(self.h - 1);
        (self.func[y * self.w + x] as f64 * (self.w * self.h) as f64 / self.total) as f32
    }
}

fn read_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>), String> {
    use exr::prelude::*;
    type Px = (u32, u32, Vec<Vec3>);
    let img = read_first_rgba_layer_from_file(
        path,
        |res, _| {
            let s: exr::math::Vec2<usize> = res;
            (s.width() as u32, s.height() as u32, vec![Vec3::ZERO; s.width() * s.height()])
        },
        |px: &mut Px, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = px.0 as usize;
            px.2[pos.y() * w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|e| format!("cannot read as OpenEXR (RGB): {e}"))?;
    Ok(img.layer_data.channel_data.pixels)
}

fn read_hdr(path: &Path) -> Result<(u32, u32, Vec<Vec3>), String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let dec = image::codecs::hdr::HdrDecoder::new(std::io::BufReader::new(file))
        .map_err(|e| format!("cannot read as Radiance HDR: {e}"))?;
    let img = image::DynamicImage::from_decoder(dec).map_err(|e| format!("cannot read as Radiance HDR: {e}"))?;
    let rgb = img.into_rgb32f();
    let (w, h) = rgb.dimensions();
    let texels = rgb.pixels().map(|p| Vec3::new(p.0[0], p.0[1], p.0[2])).collect();
    Ok((w, h, texels))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one_bright(w: u32, h: u32, x: u32, y: u32, rot: f32) -> Environment {
        let mut t = vec![Vec3::ZERO; (w * h) as usize];
        t[(y * w + x) as usize] = Vec3::new(1.0, 2.0, 3.0);
        Environment::from_texels(w, h, t, rot).unwrap()
    }

    fn centre_uv(env: &Environment, x: u32, y: u32) -> Vec2 {
        Vec2::new((x as f32 + 0.5) / env.width as f32, (y as f32 + 0.5) / env.height as f32)
    }

    #[test]
    fn orientation_follows_the_scene_format() {
        // The centre column looks along -Z, the top row straight up, u grows toward +X
        // (atan2(d.x, -d.z) > 0 for d = +X).
        let env = one_bright(64, 32, 0, 0, 0.0);
        let near = |a: Vec2, b: Vec2| (a - b).abs().max_element() < 1e-5;
        assert!(near(env.uv(Vec3::NEG_Z), Vec2::new(0.5, 0.5)));
        assert!(near(env.uv(Vec3::X), Vec2::new(0.75, 0.5)));
        assert!(near(env.uv(Vec3::NEG_X), Vec2::new(0.25, 0.5)));
        assert!(env.uv(Vec3::Y).y.abs() < 1e-6);
        assert!((env.uv(Vec3::NEG_Y).y - 1.0).abs() < 1e-6);
        // A bright texel at (x, y) is seen along the direction of its centre, at full value.
        for (x, y) in [(48, 16), (10, 5), (33, 27)] {
            let e = one_bright(64, 32, x, y, 0.0);
            let d = e.direction(centre_uv(&e, x, y));
            assert!((e.lookup(d) - Vec3::new(1.0, 2.0, 3.0)).abs().max_element() < 1e-4, "{x} {y}");
            assert!(near(e.uv(d), centre_uv(&e, x, y)));
        }
        // Texel (48, 16) of a 64×32 map: u = 0.7578, v = 0.5156, close to +X, slightly below
        // the horizon.
        let e = one_bright(64, 32, 48, 16, 0.0);
        let d = e.direction(centre_uv(&e, 48, 16));
        assert!(d.x > 0.99 && d.y < 0.0 && d.y > -0.06 && d.z.abs() < 0.06, "{d}");
        assert!(e.lookup(Vec3::X).max_element() > 0.2);
        assert_eq!(e.lookup(Vec3::NEG_X), Vec3::ZERO);
    }

    #[test]
    fn rotate_y_turns_the_map_about_y() {
        // The map is read at R_y(-angle) d: with 90°, what was seen along +X (u = 0.75) is seen
        // along R_y(90°) X = -Z.
        let a = one_bright(64, 32, 48, 16, 0.0);
        let b = one_bright(64, 32, 48, 16, 90.0);
        let rot = Mat3::from_rotation_y(90f32.to_radians());
        assert!((rot * Vec3::X - Vec3::NEG_Z).length() < 1e-6);
        for d in [Vec3::X, Vec3::new(0.9, -0.1, 0.2).normalize(), Vec3::new(0.3, 0.5, -0.8).normalize()] {
            assert!((a.lookup(d) - b.lookup(rot * d)).abs().max_element() < 1e-4, "{d}");
            assert!((a.pdf(d) - b.pdf(rot * d)).abs() <= 1e-4 * a.pdf(d).max(1.0));
        }
        assert!(b.lookup(Vec3::NEG_Z).max_element() > 0.2);
    }

    fn bumpy() -> Environment {
        let (w, h) = (32u32, 16u32);
        let t = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                Vec3::new(1.0 + (x * 0.7).sin() * 0.9, 0.5 + (y * 0.3).cos().abs(), if i == 77 { 50.0 } else { 0.2 })
            })
            .collect();
        Environment::from_texels(w, h, t, 30.0).unwrap()
    }

    #[test]
    fn sampling_pdf_matches_and_integrates_to_one() {
        let env = bumpy();
        // pdf(sample.dir) == sample.pdf.
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (rng >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut mismatches = 0;
        let n = 20_000;
        let mut mean_ratio = 0.0f64;
        for _ in 0..n {
            let s = env.sample(Vec2::new(next(), next())).unwrap();
            assert!((s.dir.length() - 1.0).abs() < 1e-4);
            assert!((s.radiance - env.lookup(s.dir)).abs().max_element() < 1e-5);
            let p = env.pdf(s.dir);
            if (p - s.pdf).abs() > 1e-3 * s.pdf {
                mismatches += 1;
            }
            // E[f / p] over samples = ∫ f dω; with f = lookup's weight, check against a grid.
            mean_ratio += (weight(s.radiance) / s.pdf) as f64;
        }
        assert!(mismatches < n / 1000, "{mismatches}");
        // ∫ pdf dω = 1 on a fine (θ, φ) grid.
        let (nt, np) = (1024, 2048);
        let mut integral = 0.0f64;
        let mut radiance_integral = 0.0f64;
        for i in 0..nt {
            let t = (i as f64 + 0.5) / nt as f64 * std::f64::consts::PI;
            for j in 0..np {
                let p = (j as f64 + 0.5) / np as f64 * 2.0 * std::f64::consts::PI;
                let d = Vec3::new((t.sin() * p.cos()) as f32, t.cos() as f32, (t.sin() * p.sin()) as f32);
                let dw = t.sin() * (std::f64::consts::PI / nt as f64) * (2.0 * std::f64::consts::PI / np as f64);
                integral += env.pdf(d) as f64 * dw;
                radiance_integral += weight(env.lookup(d)) as f64 * dw;
            }
        }
        assert!((integral - 1.0).abs() < 2e-3, "{integral}");
        let est = mean_ratio / n as f64;
        assert!((est / radiance_integral - 1.0).abs() < 0.02, "{est} vs {radiance_integral}");
    }

    #[test]
    fn black_map_has_no_samples_and_bad_layouts_are_refused() {
        let env = Environment::from_texels(8, 4, vec![Vec3::ZERO; 32], 0.0).unwrap();
        assert!(env.is_black() && env.sample(Vec2::splat(0.5)).is_none() && env.pdf(Vec3::Y) == 0.0);
        assert!(Environment::from_texels(8, 8, vec![Vec3::ZERO; 64], 0.0).unwrap_err().contains("twice as wide"));
    }

    #[test]
    fn radiance_hdr_files_load_top_row_first() {
        let dir = std::env::temp_dir().join(format!("caustics-hdr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("map.hdr");
        let (w, h) = (8usize, 4usize);
        let px: Vec<image::Rgb<f32>> =
            (0..w * h).map(|i| image::Rgb([1.0 + i as f32, 0.5, if i == 0 { 64.0 } else { 0.25 }])).collect();
        let file = std::fs::File::create(&path).unwrap();
        image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(file)).encode(&px, w, h).unwrap();
        let env = Environment::load(&path, Vec3::new(2.0, 1.0, 1.0), 0.0).unwrap();
        assert_eq!((env.width, env.height), (8, 4));
        for (i, t) in env.texels.iter().enumerate() {
            let want = Vec3::new(2.0 * (1.0 + i as f32), 0.5, if i == 0 { 64.0 } else { 0.25 });
            // RGBE keeps 8 bits of mantissa per channel relative to the largest.
            assert!((*t - want).abs().max_element() <= 0.01 * want.max_element(), "{i}: {t} vs {want}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn texel_solid_angles_sum_to_the_sphere() {
        let env = bumpy();
        let s: f32 = (0..env.height).map(|y| env.texel_solid_angle(y) * env.width as f32).sum();
        assert!((s - 4.0 * PI).abs() < 1e-4, "{s}");
    }
}
