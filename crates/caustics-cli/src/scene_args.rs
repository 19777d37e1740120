//! `--environment FILE`: an environment light added to a scene that has none (a glTF scene,
//! whose format has no environment, or a JSON scene without one), for `render`, `view` and
//! `bench` alike.

use caustics::Scene;
use caustics::error::Error;
use caustics::scene::Environment;
use glam::Vec3;
use std::path::PathBuf;
use std::sync::Arc;

#[derive(clap::Args, Debug, Clone, Default)]
pub struct EnvironmentFileArgs {
    /// Add an environment light to a scene that has none: an equirectangular map (EXR or
    /// Radiance .hdr) in W/(m^2 sr), read as docs/scene-format.md says; with
    /// `--environment-scale S` (radiance = texel x S) and `--environment-rotate DEG` (about +Y).
    #[arg(long, value_name = "FILE")]
    pub environment: Option<PathBuf>,
    #[arg(
        long,
        value_name = "S",
        default_value_t = 1.0,
        hide = true,
        requires = "environment",
        allow_negative_numbers = true
    )]
    pub environment_scale: f32,
    #[arg(
        long,
        value_name = "DEG",
        default_value_t = 0.0,
        hide = true,
        requires = "environment",
        allow_negative_numbers = true
    )]
    pub environment_rotate: f32,
}

impl EnvironmentFileArgs {
    /// `scene` with the environment light added; an input error naming the flag for a scene
    /// that has one already, a bad scale or angle, or a map that does not load.
    pub fn apply(&self, mut scene: Scene) -> Result<Scene, Error> {
        let Some(path) = &self.environment else { return Ok(scene) };
        let bad = |flag: &str, msg: String| Error::input("<command line>", flag, msg);
        if scene.environment.is_some() {
            return Err(bad("--environment", format!("{} has an environment light already", scene.source)));
        }
        let s = self.environment_scale;
        if !(s.is_finite() && s >= 0.0) {
            return Err(bad("--environment-scale", format!("must be a finite number >= 0 (got {s})")));
        }
        if !self.environment_rotate.is_finite() {
            return Err(bad("--environment-rotate", format!("must be finite (got {})", self.environment_rotate)));
        }
        let env = Environment::load(path, Vec3::splat(s), self.environment_rotate)
            .map_err(|msg| bad("--environment", format!("environment map {}: {msg}", path.display())))?;
        if env.clamped_negative > 0 {
            scene.warnings.push(format!(
                "--environment: set {} negative value(s) of environment map {} to 0",
                env.clamped_negative,
                path.display()
            ));
        }
        scene.environment = Some(Arc::new(env));
        Ok(scene)
    }
}
