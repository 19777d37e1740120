//! A scene file read into a [`Scene`]: every reference resolved (materials by name, meshes and
//! maps by path relative to the file), every field checked and named in the error.

use super::*;
use crate::error::{Error, Result};
use format::*;
use glam::{Mat3, Vec2, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

struct Ctx<'a> {
    file: &'a str,
}

impl Ctx<'_> {
    fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> Error {
        Error::input(self.file, field, msg)
    }
    fn finite3(&self, field: &str, a: [f32; 3]) -> Result<Vec3> {
        if a.iter().all(|x| x.is_finite()) { Ok(v3(a)) } else { Err(self.err(field, "must be finite numbers")) }
    }
    fn dir(&self, field: &str, a: [f32; 3]) -> Result<Vec3> {
        let v = self.finite3(field, a)?;
        if v.length() < 1e-12 {
            return Err(self.err(field, "must be a non-zero direction"));
        }
        Ok(v.normalize())
    }
    fn nonneg_rgb(&self, field: &str, c: Rgb) -> Result<Vec3> {
        let v = self.finite3(field, c.0)?;
        if v.min_element() < 0.0 {
            return Err(self.err(field, format!("must not be negative (got {:?})", c.0)));
        }
        Ok(v)
    }
    fn unit_rgb(&self, field: &str, c: Rgb) -> Result<Vec3> {
        let v = self.nonneg_rgb(field, c)?;
        if v.max_element() > 1.0 {
            return Err(self.err(field, format!("must lie in [0, 1]: more would create energy (got {:?})", c.0)));
        }
        Ok(v)
    }
    fn positive(&self, field: &str, x: f32) -> Result<f32> {
        if x.is_finite() && x > 0.0 {
            Ok(x)
        } else {
            Err(self.err(field, format!("must be a positive number (got {x})")))
        }
    }
}

pub(super) fn resolve(d: SceneFile, file: &str, base: &Path) -> Result<Scene> {
    let cx = Ctx { file };
    if d.schema_version != 1 {
        return Err(
            cx.err("schema_version", format!("unsupported version {} (this program reads 1)", d.schema_version))
        );
    }
    if d.name.trim().is_empty() {
        return Err(cx.err("name", "must not be empty (it is the output file stem)"));
    }

    let c = &d.camera;
    let camera = Camera {
        position: cx.finite3("camera.position", c.position)?,
        look_at: cx.finite3("camera.look_at", c.look_at)?,
        up: cx.dir("camera.up", c.up)?,
        fov_y_deg: c.fov_y_deg,
        width: c.width,
        height: c.height,
    };
    if camera.position.distance(camera.look_at) < 1e-9 {
        return Err(cx.err("camera.look_at", "must differ from camera.position"));
    }
    if camera.forward().cross(camera.up).length() < 1e-6 {
        return Err(cx.err("camera.up", "must not be parallel to the viewing direction"));
    }
    if !(c.fov_y_deg > 0.0 && c.fov_y_deg < 180.0) {
        return Err(cx.err("camera.fov_y_deg", format!("must lie in (0, 180) degrees (got {})", c.fov_y_deg)));
    }
    for (f, v) in [("camera.width", c.width), ("camera.height", c.height)] {
        if v == 0 || v > 16384 {
            return Err(cx.err(f, format!("must be between 1 and 16384 pixels (got {v})")));
        }
    }
    let exposure = d.display.as_ref().map_or(1.0, |x| x.exposure);
    if !(exposure.is_finite() && exposure > 0.0) {
        return Err(cx.err("display.exposure", format!("must be a positive number (got {exposure})")));
    }

    if d.lights.is_empty() {
        return Err(cx.err("lights", "the scene has no light"));
    }
    let mut lights = Vec::new();
    let mut environment: Option<(usize, Arc<Environment>)> = None;
    let mut warnings = Vec::new();
    for (i, l) in d.lights.iter().enumerate() {
        let f = |s: &str| format!("lights[{i}].{s}");
        lights.push(match l {
            LightDesc::Spot(SpotDesc { position, direction, cone_angle_deg, falloff_start_deg, intensity, falloff }) => {
                let cone = *cone_angle_deg;
                if !(cone > 0.0 && cone < 180.0) {
                    return Err(cx.err(f("cone_angle_deg"), format!("must lie in (0, 180) degrees (got {cone})")));
                }
                let start = falloff_start_deg.unwrap_or(0.75 * cone);
                if !(start >= 0.0 && start <= cone) {
                    return Err(cx.err(
                        f("falloff_start_deg"),
                        format!("must lie in [0, cone_angle_deg = {cone}] (got {start})"),
                    ));
                }
                let profile = match falloff.as_deref() {
                    None | Some("linear") => SpotProfile::Linear,
                    Some("gltf") => SpotProfile::Gltf,
                    Some(other) => {
                        return Err(cx.err(f("falloff"), format!("must be \"linear\" or \"gltf\" (got \"{other}\")")));
                    }
                };
                Light::Spot {
                    position: cx.finite3(&f("position"), *position)?,
                    direction: cx.dir(&f("direction"), *direction)?,
                    cone_angle: cone.to_radians(),
                    falloff_start: start.to_radians(),
                    intensity: cx.nonneg_rgb(&f("intensity"), *intensity)?,
                    profile,
                }
            }
            LightDesc::Point(PointDesc { position, intensity }) => Light::Point {
                position: cx.finite3(&f("position"), *position)?,
                intensity: cx.nonneg_rgb(&f("intensity"), *intensity)?,
            },
            LightDesc::Directional(DirectionalDesc { direction, irradiance }) => Light::Directional {
                direction: cx.dir(&f("direction"), *direction)?,
                irradiance: cx.nonneg_rgb(&f("irradiance"), *irradiance)?,
            },
            LightDesc::Environment(e) => {
                if let Some((k, _)) = &environment {
                    return Err(cx.err(
                        format!("lights[{i}]"),
                        format!("at most one environment light (lights[{k}] is one already)"),
                    ));
                }
                let scale = cx.nonneg_rgb(&f("scale"), e.scale.unwrap_or(Rgb([1.0; 3])))?;
                if !e.rotate_y_deg.is_finite() {
                    return Err(cx.err(f("rotate_y_deg"), "must be finite"));
                }
                let full = resolve_path(base, &e.path);
                let env = Environment::load(&full, scale, e.rotate_y_deg)
                    .map_err(|msg| cx.err(f("path"), format!("environment map {}: {msg}", full.display())))?;
                if env.clamped_negative > 0 {
                    warnings.push(format!(
                        "{file}: {}: set {} negative value(s) of environment map {} to 0 (lossy compression rings around bright texels)",
                        f("path"),
                        env.clamped_negative,
                        full.display()
                    ));
                }
                environment = Some((i, Arc::new(env)));
                continue;
            }
        });
    }

    let mut materials = Vec::new();
    let mut material_names = Vec::new();
    for (name, m) in &d.materials {
        let f = |s: &str| format!("materials.{name}.{s}");
        materials.push(match m {
            MaterialDesc::Diffuse(DiffuseDesc { albedo }) => {
                Material::Diffuse { albedo: cx.unit_rgb(&f("albedo"), *albedo)? }
            }
            MaterialDesc::Dielectric(d) => Material::Dielectric {
                ior: cx.positive(&f("ior"), d.ior)?,
                ext_ior: cx.positive(&f("ext_ior"), d.ext_ior)?,
                absorption: dielectric_absorption(&cx, &f, d)?,
            },
            MaterialDesc::Mirror(MirrorDesc { reflectance }) => {
                Material::Mirror { reflectance: cx.unit_rgb(&f("reflectance"), *reflectance)? }
            }
            MaterialDesc::Conductor(ConductorDesc { eta, k }) => {
                let eta = cx.nonneg_rgb(&f("eta"), *eta)?;
                if eta.min_element() <= 0.0 {
                    return Err(cx.err(f("eta"), "must be positive"));
                }
                Material::Conductor { eta, k: cx.nonneg_rgb(&f("k"), *k)? }
            }
        });
        material_names.push(name.clone());
    }

    let mut objects = Vec::new();
    for (i, o) in d.objects.iter().enumerate() {
        let f = |s: &str| format!("objects[{i}].{s}");
        let (mat_name, caster) = match o {
            ObjectDesc::Sphere(SphereDesc { material, caustic_caster, .. })
            | ObjectDesc::Rectangle(RectangleDesc { material, caustic_caster, .. })
            | ObjectDesc::Cylinder(CylinderDesc { material, caustic_caster, .. })
            | ObjectDesc::Mesh(MeshDesc { material, caustic_caster, .. })
            | ObjectDesc::Waves(WavesDesc { material, caustic_caster, .. }) => (material, caustic_caster),
        };
        let material = material_names.iter().position(|n| n == mat_name).ok_or_else(|| {
            cx.err(
                f("material"),
                format!("unknown material \"{mat_name}\" (the scene defines: {})", material_names.join(", ")),
            )
        })?;
        let mut waves = None;
        let shape = match o {
            ObjectDesc::Sphere(SphereDesc { center, radius, .. }) => Shape::Sphere {
                center: cx.finite3(&f("center"), *center)?,
                radius: cx.positive(&f("radius"), *radius)?,
            },
            ObjectDesc::Rectangle(RectangleDesc { center, normal, size, u_axis, .. }) => {
                let normal = cx.dir(&f("normal"), *normal)?;
                let size = Vec2::new(cx.positive(&f("size[0]"), size[0])?, cx.positive(&f("size[1]"), size[1])?);
                let default_u = if normal.dot(Vec3::X).abs() > 25f32.to_radians().cos() { Vec3::Z } else { Vec3::X };
                let u0 = match u_axis {
                    Some(a) => cx.dir(&f("u_axis"), *a)?,
                    None => default_u,
                };
                let u = u0 - normal * normal.dot(u0);
                if u.length() < 1e-6 {
                    return Err(cx.err(f("u_axis"), "must not be parallel to the normal"));
                }
                let u = u.normalize();
                Shape::Rectangle { center: cx.finite3(&f("center"), *center)?, normal, u, v: normal.cross(u), size }
            }
            ObjectDesc::Cylinder(CylinderDesc { base_center, axis, radius, height, .. }) => Shape::Cylinder {
                base_center: cx.finite3(&f("base_center"), *base_center)?,
                axis: cx.dir(&f("axis"), *axis)?,
                radius: cx.positive(&f("radius"), *radius)?,
                height: cx.positive(&f("height"), *height)?,
            },
            ObjectDesc::Mesh(MeshDesc { path, smooth_normals, transform, .. }) => {
                let t = transform.as_ref();
                let scale = match t.and_then(|t| t.scale) {
                    Some(Scale(s)) => {
                        for (k, x) in s.iter().enumerate() {
                            if !(x.is_finite() && *x > 0.0) {
                                return Err(
                                    cx.err(f(&format!("transform.scale[{k}]")), format!("must be positive (got {x})"))
                                );
                            }
                        }
                        v3(s)
                    }
                    None => Vec3::ONE,
                };
                let rot = t.map_or(0.0, |t| t.rotate_y_deg);
                if !rot.is_finite() {
                    return Err(cx.err(f("transform.rotate_y_deg"), "must be finite"));
                }
                let translate = cx.finite3(&f("transform.translate"), t.map_or([0.0; 3], |t| t.translate))?;
                let full = resolve_path(base, path);
                let mut m = mesh::load_obj(&full)
                    .map_err(|msg| cx.err(f("path"), format!("mesh {}: {msg}", full.display())))?;
                let dropped = m.drop_degenerate();
                if dropped > 0 {
                    warnings.push(format!(
                        "{file}: {}: dropped {dropped} degenerate triangle(s) of {}",
                        f("path"),
                        full.display()
                    ));
                }
                if m.indices.is_empty() {
                    return Err(cx.err(f("path"), format!("mesh {} has no usable triangle", full.display())));
                }
                let rot = Mat3::from_rotation_y(rot.to_radians());
                m.transform(Mat3::from_diagonal(scale), rot, translate);
                if !*smooth_normals {
                    m.use_face_normals();
                }
                if matches!(materials[material], Material::Dielectric { .. }) {
                    let open = m.boundary_edges();
                    if open > 0 {
                        warnings.push(format!(
                            "{file}: {}: dielectric mesh {} is not closed ({open} boundary edges); refraction through its holes is undefined",
                            f("path"),
                            full.display()
                        ));
                    }
                }
                Shape::Mesh(Arc::new(m))
            }
            ObjectDesc::Waves(w) => {
                let body = load_waves(&cx, &f, w)?;
                let shape = Shape::Mesh(Arc::new(body.mesh(0.0)));
                waves = Some(Arc::new(body));
                shape
            }
        };
        if matches!(shape, Shape::Rectangle { .. } | Shape::Cylinder { .. })
            && materials[material].absorption().max_element() > 0.0
        {
            return Err(cx.err(
                f("material"),
                format!(
                    "\"{mat_name}\" absorbs (absorption or attenuation_color): it needs a closed object (sphere, mesh, waves), and a {} has no inside",
                    if matches!(shape, Shape::Rectangle { .. }) { "rectangle" } else { "cylinder" }
                ),
            ));
        }
        let caustic_caster = caster.unwrap_or(materials[material].is_specular());
        objects.push(Object { shape, material, caustic_caster, waves });
    }
    if objects.is_empty() {
        return Err(cx.err("objects", "the scene has no object"));
    }

    let medium = match &d.medium {
        None => None,
        Some(m) => {
            let phase = match m.phase {
                None | Some(PhaseDesc::Isotropic) => Phase::Isotropic,
                Some(PhaseDesc::Hg { g }) => {
                    if !(g > -1.0 && g < 1.0) {
                        return Err(cx.err("medium.phase.g", format!("must lie in (-1, 1) (got {g})")));
                    }
                    Phase::HenyeyGreenstein { g }
                }
            };
            let lo = cx.finite3("medium.bounds.min", m.bounds.min)?;
            let hi = cx.finite3("medium.bounds.max", m.bounds.max)?;
            if !lo.cmplt(hi).all() {
                return Err(cx.err(
                    "medium.bounds",
                    format!("min must be below max on every axis (an empty or inverted box: min {lo}, max {hi})"),
                ));
            }
            let sigma_s = cx.nonneg_rgb("medium.sigma_s", m.sigma_s)?;
            let sigma_a = cx.nonneg_rgb("medium.sigma_a", m.sigma_a)?;
            let density = match &m.density {
                None => None,
                Some(d) => {
                    let full = resolve_path(base, &d.path);
                    let g = DensityGrid::load(&full).map_err(|msg| {
                        cx.err("medium.density.path", format!("density grid {}: {msg}", full.display()))
                    })?;
                    Some(Arc::new(g))
                }
            };
            Some(Medium { sigma_s, sigma_a, phase, bounds_min: lo, bounds_max: hi, density })
        }
    };

    Ok(Scene {
        name: d.name,
        description: d.description,
        source: file.to_string(),
        camera,
        exposure,
        lights,
        materials,
        material_names,
        objects,
        medium,
        environment: environment.map(|(_, e)| e),
        warnings,
    })
}

/// A dielectric's absorption coefficient σa (1/m): `absorption` as given, or from the glTF-style
/// pair, σa = −ln(attenuation_color) / attenuation_distance per channel; zero when neither.
fn dielectric_absorption(cx: &Ctx, f: &dyn Fn(&str) -> String, d: &DielectricDesc) -> Result<Vec3> {
    match (d.absorption, d.attenuation_color, d.attenuation_distance) {
        (None, None, None) => Ok(Vec3::ZERO),
        (Some(a), None, None) => cx.nonneg_rgb(&f("absorption"), a),
        (Some(_), _, _) => Err(
            cx.err(f("absorption"), "give either absorption or attenuation_color with attenuation_distance, not both")
        ),
        (None, Some(c), Some(dist)) => {
            let c = cx.finite3(&f("attenuation_color"), c.0)?;
            if !(c.min_element() > 0.0 && c.max_element() <= 1.0) {
                return Err(cx.err(f("attenuation_color"), format!("must lie in (0, 1] (got {:?})", c.to_array())));
            }
            let dist = cx.positive(&f("attenuation_distance"), dist)?;
            // (−ln 1 = −0: a zero channel is +0, as `absorption: 0` gives)
            Ok(Vec3::from_array(c.to_array().map(|x| (-x.ln() / dist).max(0.0))))
        }
        (None, Some(_), None) => {
            Err(cx.err(f("attenuation_distance"), "is required with attenuation_color (a distance in m)"))
        }
        (None, None, Some(_)) => {
            Err(cx.err(f("attenuation_color"), "is required with attenuation_distance (the colour at that distance)"))
        }
    }
}

fn resolve_path(base: &Path, p: &str) -> PathBuf {
    let p = Path::new(p);
    if p.is_absolute() { p.to_path_buf() } else { base.join(p) }
}

/// A `waves` object's fields checked (`f` names a field of the object).
fn load_waves(cx: &Ctx, f: &dyn Fn(&str) -> String, w: &WavesDesc) -> Result<waves::Waves> {
    let finite = |field: &str, x: f32| {
        if x.is_finite() { Ok(x) } else { Err(cx.err(f(field), format!("must be a finite number (got {x})"))) }
    };
    let center = Vec2::new(finite("center[0]", w.center[0])?, finite("center[1]", w.center[1])?);
    let size = Vec2::new(cx.positive(&f("size[0]"), w.size[0])?, cx.positive(&f("size[1]"), w.size[1])?);
    let surface = finite("surface", w.surface)?;
    let bottom = finite("bottom", w.bottom)?;
    if !(2..=1024).contains(&w.grid) {
        return Err(cx.err(f("grid"), format!("must lie in 2..=1024 quads per side (got {})", w.grid)));
    }
    if w.waves.is_empty() || w.waves.len() > 64 {
        return Err(cx.err(f("waves"), format!("must list 1 to 64 waves (got {})", w.waves.len())));
    }
    let mut out = Vec::new();
    for (k, d) in w.waves.iter().enumerate() {
        let g = |s: &str| format!("waves[{k}].{s}");
        let amplitude = finite(&g("amplitude"), d.amplitude)?;
        if amplitude < 0.0 {
            return Err(cx.err(f(&g("amplitude")), format!("must not be negative (got {amplitude})")));
        }
        if !(0.0..=1.0).contains(&d.steepness) {
            return Err(cx.err(f(&g("steepness")), format!("must lie in [0, 1] (got {})", d.steepness)));
        }
        out.push(waves::Wave {
            amplitude,
            wavelength: cx.positive(&f(&g("wavelength")), d.wavelength)?,
            direction_deg: finite(&g("direction_deg"), d.direction_deg)?,
            steepness: d.steepness,
            phase: finite(&g("phase"), d.phase)?,
        });
    }
    let swing: f32 = out.iter().map(|w| w.amplitude).sum();
    if surface - swing <= bottom {
        return Err(cx.err(
            f("bottom"),
            format!("must lie below the deepest trough, surface − Σ amplitude = {} (got {bottom})", surface - swing),
        ));
    }
    Ok(waves::Waves { center, size, surface, bottom, grid: w.grid, smooth_normals: w.smooth_normals, waves: out })
}
