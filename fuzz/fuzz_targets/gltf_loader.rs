//! Malformed glTF/GLB: `Scene::from_slice` must return a clean `Err` or a scene that every
//! later stage can take (flatten, BVH, camera framing, a tiny trace), never panic, hang or
//! allocate without bound.
#![no_main]

use cubist::pipeline::{Prepared, render};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::{CameraKind, Preset, Settings};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let scene = match Scene::from_slice(data) {
        Ok(scene) => scene,
        Err(e) => {
            // The loader turns a panic inside the gltf crate or itself into this generic
            // error: report it as a crash, so that it is found and fixed properly.
            let msg = e.to_string();
            assert!(!msg.contains("the parser failed"), "panic inside the loader: {msg}");
            assert!(!msg.contains('\n'), "multi-line error: {msg}");
            return;
        }
    };
    let prep = Prepared::new(scene);
    for camera in [CameraKind::Auto, CameraKind::Perspective] {
        let mut s = Settings::preset(Preset::Plain);
        s.camera = camera;
        s.width = 8;
        s.height = 6;
        s.spp = 1;
        if let Ok(r) = render(&prep, &s, &Progress::silent()) {
            assert!(r.film.color.iter().all(|c| c.is_finite()), "NaN pixel");
        }
    }
});
