//! Malformed settings JSON (the `--config` file and the Blender add-on's contract):
//! `Settings::from_layers` must return a clean `Err` or settings that validate and that a
//! camera can be framed with, never panic or hang.
#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use cubist::camera::frame_camera;
use cubist::pipeline::params;
use cubist::pipeline::{Prepared, render};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::Settings;
use libfuzzer_sys::fuzz_target;
use serde_json::{Map, Value};

fn scene() -> &'static Prepared {
    static PREP: OnceLock<Prepared> = OnceLock::new();
    PREP.get_or_init(|| Prepared::new(Scene::default_scene()))
}

fn check(settings: Settings) {
    settings.validate().expect("from_layers returned settings that do not validate");
    let prep = scene();
    let _ = frame_camera(&params::framing(&settings), &prep.world, &prep.accel);
    // Trace only tiny images: the point is the parameters, not the time.
    if settings.width as u64 * settings.height as u64 * settings.spp as u64 <= 256 {
        if let Ok(r) = render(prep, &settings, &Progress::silent()) {
            assert!(r.film.color.iter().all(|c| c.is_finite()), "NaN pixel");
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Ok(value) = serde_json::from_slice::<Value>(data) else { return };
    if let Ok(s) = Settings::from_layers(Some((Path::new("fuzz.json"), value.clone())), Map::new()) {
        check(s);
    }
    // The same object as the flags layer (what the CLI builds from its options).
    if let Value::Object(flags) = value {
        if let Ok(s) = Settings::from_layers(None, flags) {
            check(s);
        }
    }
});
