//! The settings in sections: JSON names, defaults, keys set by path, errors by field path.

use caustics::render::{
    BeamVolume, DistantSource, Emission, LocalSource, RenderSettings, SpillFaces, SplatMode, Tracer, VolumeSource,
};
use serde_json::json;

/// Every choice reads and writes as JSON by its command-line name.
#[test]
fn choices_read_and_write_by_their_names() {
    fn check<T: serde::Serialize + serde::de::DeserializeOwned + PartialEq + std::fmt::Debug>(
        all: &[T],
        name: impl Fn(&T) -> &'static str,
    ) {
        for v in all {
            assert_eq!(serde_json::to_value(v).unwrap(), json!(name(v)));
            assert_eq!(&serde_json::from_value::<T>(json!(name(v))).unwrap(), v);
        }
    }
    check(&Emission::ALL, |t| t.name());
    check(&Tracer::ALL, |t| t.name());
    check(&SplatMode::ALL, |t| t.name());
    check(&SpillFaces::ALL, |t| t.name());
    check(&LocalSource::ALL, |t| t.name());
    check(&DistantSource::ALL, |t| t.name());
    check(&VolumeSource::ALL, |t| t.name());
    check(&BeamVolume::ALL, |t| t.name());
}

#[test]
fn json_round_trips_and_keys_left_out_keep_their_defaults() {
    let d = RenderSettings::default();
    let v = d.to_json();
    for section in ["photons", "adaptive", "shading", "medium", "environment", "beams", "testing"] {
        assert!(v[section].is_object(), "{section}");
    }
    assert_eq!(RenderSettings::from_json("<test>", &v.to_string()).unwrap(), d);
    let s =
        RenderSettings::from_json("<test>", r#"{ "photons": { "count": 256 }, "medium": { "steps": 8 } }"#).unwrap();
    assert_eq!(s.photons.count, 256);
    assert_eq!(s.medium.steps, 8);
    assert_eq!(s.photons.emission, d.photons.emission);
    assert_eq!(s.beams, d.beams);
    let e = RenderSettings::from_json("s.json", r#"{ "beams": { "grid": 4, "gird": 2 } }"#).unwrap_err();
    let msg = e.to_string();
    assert!(e.is_input() && msg.contains("s.json") && msg.contains("gird"), "{msg}");
    let e = RenderSettings::from_json("s.json", r#"{ "photons": { "count": "many" } }"#).unwrap_err();
    assert!(e.to_string().contains("photons.count"), "{e}");
}

#[test]
fn set_by_path_names_the_known_keys() {
    let mut s = RenderSettings::default();
    s.set("beams.grid", json!(8)).unwrap();
    s.set("photons.emission", json!("adaptive-error")).unwrap();
    s.set("sources.local", json!("beams")).unwrap();
    s.set("shading.tessellation.sphere_segments", json!(64)).unwrap();
    assert_eq!((s.beams.grid, s.photons.emission), (8, Emission::AdaptiveError));
    assert_eq!(s.sources.local, LocalSource::Beams);
    assert_eq!(s.shading.tessellation.sphere_segments, 64);
    let e = s.set("beams.gird", json!(8)).unwrap_err().to_string();
    assert!(e.contains("beams.gird") && e.contains("known keys") && e.contains("grid") && e.contains("levels"), "{e}");
    let e = s.set("nope", json!(1)).unwrap_err().to_string();
    assert!(e.contains("photons") && e.contains("medium") && !e.contains("testing"), "{e}");
    let e = s.set("beams", json!(1)).unwrap_err().to_string();
    assert!(e.contains("section"), "{e}");
    let e = s.set("photons.count", json!("many")).unwrap_err().to_string();
    assert!(e.contains("photons.count"), "{e}");
    // A failed set leaves the settings as they were.
    assert_eq!(s.beams.grid, 8);
}

/// Each section checks its own ranges and names the field by its path.
#[test]
fn sections_validate_by_field_path() {
    assert_eq!(RenderSettings::default().validate_sections(), Ok(()));
    let bad = |f: &dyn Fn(&mut RenderSettings), path: &str| {
        let mut s = RenderSettings::default();
        f(&mut s);
        let (field, msg) = s.validate_sections().unwrap_err();
        assert_eq!(field, path, "{msg}");
    };
    bad(&|s| s.photons.count = 8, "photons.count");
    bad(&|s| s.photons.max_depth = 0, "photons.max_depth");
    bad(&|s| s.photons.splat_sigma = 0.0, "photons.splat_sigma");
    bad(&|s| s.photons.memory = 16, "photons.memory");
    bad(&|s| s.adaptive.error_tolerance = -1.0, "adaptive.error_tolerance");
    bad(&|s| s.adaptive.quad_linearity = 1.0, "adaptive.quad_linearity");
    bad(&|s| s.shading.tessellation.sphere_segments = 4, "shading.tessellation.sphere_segments");
    bad(&|s| s.medium.steps = 0, "medium.steps");
    bad(&|s| s.medium.bounce_grid = 65, "medium.bounce_grid");
    bad(&|s| s.environment.lights = 0, "environment.lights");
    bad(&|s| s.environment.taps = 1000, "environment.taps");
    bad(&|s| s.beams.grid = 0, "beams.grid");
    bad(&|s| s.beams.cutoff = -1.0, "beams.cutoff");
}
