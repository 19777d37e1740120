//! What the user can ask of the viewer ([`Action`], with the [`Mods`] of a drag) and what
//! the view area shows ([`ViewMode`]).

use crate::view::pick::Selection;
use caustics::render::RenderSettings;
use caustics::scene::Light;
use caustics::settings::Emission;
use caustics::splat::SplatMode;
use glam::Affine3A;
use std::path::PathBuf;

/// Modifier keys held when a drag starts.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Mods {
    /// Ctrl (or Cmd): rotate the selected object, aim the selected spot light.
    pub rotate: bool,
}

/// What the user can ask of the viewer. Positions are image pixels of the rendered view
/// ((0,0) = top-left), motions are pixels.
#[derive(Debug, Clone)]
pub enum Action {
    /// The view area changed size: the camera's image becomes `width` × `height`.
    Resize {
        width: u32,
        height: u32,
    },
    Orbit {
        dx: f32,
        dy: f32,
    },
    Pan {
        dx: f32,
        dy: f32,
    },
    /// Wheel notches (positive: closer).
    Zoom {
        steps: f32,
    },
    /// A primary-button press: picks a light or an object, or a spot light's axis handle (or,
    /// with [`Mods::rotate`], starts rotating the selected object or aiming the selected spot
    /// light). A press on nothing keeps the selection.
    Press {
        x: f32,
        y: f32,
        mods: Mods,
    },
    /// The pointer moved with the button held.
    Drag {
        x: f32,
        y: f32,
    },
    Release,
    Select(Option<Selection>),
    SetTechnique(Emission),
    SetSplat(SplatMode),
    SetTracer(caustics::render::Tracer),
    /// The photon grid N (N × N per light-view face).
    SetPhotons(u32),
    SetTolerance(f32),
    /// Any other settings change (the panel's less common switches).
    SetSettings(Box<RenderSettings>),
    SetTemporal(bool),
    /// Time-budget mode: the photon grid (and tolerance) follows a frame time in ms; None: off.
    SetBudget(Option<f64>),
    SetLight(usize, Light),
    SetObjectTransform(usize, Affine3A),
    /// The index of refraction of dielectric material `material`.
    SetIor {
        material: usize,
        ior: f32,
    },
    /// The participating medium's scattering and absorption coefficients (1/m) and phase
    /// function; its box and density grid stay as loaded.
    SetMedium {
        sigma_s: glam::Vec3,
        sigma_a: glam::Vec3,
        phase: caustics::scene::Phase,
    },
    /// Turn the environment light to this many degrees about +Y (its directional lights turn
    /// with it, no re-segmentation).
    SetEnvironmentRotation(f32),
    /// Pose the animated objects (`waves`) at this time (seconds).
    SetTime(f32),
    /// Play the animation (time follows the wall clock from where it is) or pause it.
    Play(bool),
    /// Write the current image (PNG tone-mapped, EXR linear, by extension).
    Screenshot(PathBuf),
    /// Write the current image as the next numbered PNG + EXR pair in the screenshot folder.
    ScreenshotPair,
    SetViewMode(ViewMode),
    /// Start the CPU reference of the current view now.
    StartReference,
    CancelReference,
    /// HDR-FLIP of the GPU frame against the reference of this view (blocking, about a second).
    ComputeFlip,
    /// Open another scene file (JSON, `.gltf`, `.glb`): a file dropped on the window.
    Open(PathBuf),
}

/// What the view area shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ViewMode {
    /// The GPU renderer's image.
    #[default]
    Gpu,
    /// The CPU reference of the same view.
    Reference,
    /// GPU on the left, reference on the right of a divider.
    Split,
    /// The difference heat map.
    Difference,
}

impl ViewMode {
    pub const ALL: [ViewMode; 4] = [ViewMode::Gpu, ViewMode::Reference, ViewMode::Split, ViewMode::Difference];
    pub fn name(self) -> &'static str {
        match self {
            ViewMode::Gpu => "GPU",
            ViewMode::Reference => "CPU reference",
            ViewMode::Split => "A/B split",
            ViewMode::Difference => "difference",
        }
    }
}
