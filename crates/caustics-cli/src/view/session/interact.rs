//! Camera, settings and pointer interaction: orbit and camera changes, the settings' changes,
//! picking and dragging lights and objects, material edits.

use super::{Action, Mods, ROTATE_RAD_PER_PIXEL, Session, TEMPORAL_SETTLE_FRAMES};
use crate::view::pick::{self, Selection};
use caustics::render::RenderSettings;
use caustics::scene::{Light, Material};
use caustics::{Error, Result};
use caustics_reference::reference::geometry::Accel;
use glam::{Affine3A, Vec2, Vec3};
use std::sync::Arc;
use std::time::Instant;

#[derive(Debug, Clone)]
pub(super) enum Drag {
    MoveLight {
        light: usize,
        start: Vec3,
        anchor: Vec3,
    },
    AimLight {
        light: usize,
    },
    /// The end of a spot light's axis handle, dragged in the plane facing the camera.
    AimHandle {
        light: usize,
        anchor: Vec3,
    },
    MoveObject {
        object: usize,
        t0: Affine3A,
        anchor: Vec3,
    },
    RotateObject {
        object: usize,
        t0: Affine3A,
        centre: Vec3,
        start: Vec2,
    },
}

impl Session {
    pub(super) fn set_camera(&mut self, cam: caustics::scene::Camera) -> Result<()> {
        let old = self.scene().camera.clone();
        if let Err(e) = self.renderer.set_camera(cam) {
            // The renderer keeps a camera it rejected: put the old one back.
            let _ = self.renderer.set_camera(old);
            return Err(e);
        }
        self.view_changed();
        Ok(())
    }

    pub(super) fn camera_from_orbit(&mut self) -> Result<()> {
        let cam = self.orbit.apply(&self.scene().camera);
        self.set_camera(cam)
    }

    pub(super) fn change_settings(&mut self, f: impl FnOnce(&mut RenderSettings)) -> Result<()> {
        let mut s = self.settings().clone();
        f(&mut s);
        // (RenderSettings has no PartialEq.)
        if format!("{s:?}") == format!("{:?}", self.settings()) {
            return Ok(());
        }
        self.renderer.set_settings(s)?;
        self.dirty = true;
        self.error = None;
        Ok(())
    }

    /// The camera, a light, an object or a material changed: the reference is stale.
    pub(super) fn view_changed(&mut self) {
        self.generation += 1;
        self.changed_at = Instant::now();
        self.dirty = true;
        self.settle = if self.temporal { TEMPORAL_SETTLE_FRAMES } else { 0 };
        self.error = None;
        if let Some(j) = self.job.take() {
            j.cancel();
        }
    }

    fn accel(&mut self) -> Arc<Accel> {
        match &self.accel {
            Some((v, a)) if *v == self.geometry_version => a.clone(),
            _ => {
                let a = Arc::new(Accel::new(self.renderer.scene()));
                self.accel = Some((self.geometry_version, a.clone()));
                a
            }
        }
    }

    pub(super) fn press(&mut self, x: f32, y: f32, mods: Mods) -> Result<()> {
        self.drag = None;
        if mods.rotate {
            match self.selection {
                Some(Selection::Light(i)) if matches!(self.scene().lights.get(i), Some(Light::Spot { .. })) => {
                    self.drag = Some(Drag::AimLight { light: i });
                    return self.drag_to(x, y);
                }
                Some(Selection::Object(i)) => {
                    let centre = pick::centre(&self.scene().objects[i].shape);
                    let t0 = self.renderer.object_transform(i).unwrap_or(Affine3A::IDENTITY);
                    self.drag = Some(Drag::RotateObject { object: i, t0, centre, start: Vec2::new(x, y) });
                    return Ok(());
                }
                _ => {}
            }
        }
        if let Some((i, h)) = pick::pick_handle(self.scene(), x, y) {
            self.selection = Some(Selection::Light(i));
            self.drag = Some(Drag::AimHandle { light: i, anchor: h });
            return Ok(());
        }
        let accel = self.accel();
        let picked = pick::pick(self.scene(), &accel, x, y);
        // A press on nothing keeps the selection (it starts an orbit); a click on nothing
        // deselects (the panel sends `Select(None)`).
        if let Some((s, _)) = picked {
            self.selection = Some(s);
        }
        self.drag = match picked {
            Some((Selection::Light(i), p)) => Some(Drag::MoveLight { light: i, start: p, anchor: p }),
            Some((Selection::Object(i), p)) => Some(Drag::MoveObject {
                object: i,
                t0: self.renderer.object_transform(i).unwrap_or(Affine3A::IDENTITY),
                anchor: p,
            }),
            None => None,
        };
        Ok(())
    }

    pub(super) fn drag_to(&mut self, x: f32, y: f32) -> Result<()> {
        let Some(drag) = self.drag.clone() else { return Ok(()) };
        let cam = self.scene().camera.clone();
        match drag {
            Drag::MoveLight { light, start, anchor } => {
                let Some(p) = pick::on_view_plane(&cam, anchor, x, y) else { return Ok(()) };
                let l = pick::moved(&self.scene().lights[light], start + (p - anchor));
                self.apply(Action::SetLight(light, l))
            }
            Drag::AimLight { light } => {
                let accel = self.accel();
                let target = pick::scene_point(self.scene(), &accel, x, y)
                    .unwrap_or_else(|| cam.position + cam.ray_dir(x, y) * self.orbit.distance);
                let l = pick::aimed(&self.scene().lights[light], target);
                self.apply(Action::SetLight(light, l))
            }
            Drag::AimHandle { light, anchor } => {
                let Some(p) = pick::on_view_plane(&cam, anchor, x, y) else { return Ok(()) };
                let l = pick::aimed(&self.scene().lights[light], p);
                self.apply(Action::SetLight(light, l))
            }
            Drag::MoveObject { object, t0, anchor } => {
                let Some(p) = pick::on_view_plane(&cam, anchor, x, y) else { return Ok(()) };
                self.apply(Action::SetObjectTransform(object, Affine3A::from_translation(p - anchor) * t0))
            }
            Drag::RotateObject { object, t0, centre, start } => {
                let d = Vec2::new(x, y) - start;
                let t = pick::rotated_about(
                    t0,
                    centre,
                    cam.up,
                    cam.right(),
                    d.x * ROTATE_RAD_PER_PIXEL,
                    d.y * ROTATE_RAD_PER_PIXEL,
                );
                self.apply(Action::SetObjectTransform(object, t))
            }
        }
    }

    /// A new index of refraction for a dielectric material (every light is redone).
    pub(super) fn set_ior(&mut self, material: usize, ior: f32) -> Result<()> {
        let Some(Material::Dielectric { ext_ior, absorption, .. }) = self.base.materials.get(material).copied() else {
            return Err(Error::input("<viewer>", format!("materials[{material}].ior"), "not a dielectric material"));
        };
        if !(ior.is_finite() && (1.0..=4.0).contains(&ior)) {
            return Err(Error::input("<viewer>", format!("materials[{material}].ior"), "must lie in [1, 4]"));
        }
        let m = Material::Dielectric { ior, ext_ior, absorption };
        self.renderer.set_material(material, m)?;
        self.base.materials[material] = m;
        // The caustic spheres were traced through the old material (their cache key has it).
        self.sphere_tables = None;
        self.view_changed();
        Ok(())
    }
}
