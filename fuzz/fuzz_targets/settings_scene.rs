//! Settings and a scene together (issue 18): the input is a settings JSON object and a glTF
//! document, split at the first NUL byte. Whatever settings validate are rendered on whatever
//! scene loads (images kept tiny): a clean one-line `Err` or a finite image, never a panic, a
//! hang or unbounded memory.
#![no_main]

use std::path::Path;

use cubist::pipeline::{Prepared, render};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::Settings;
use libfuzzer_sys::fuzz_target;
use serde_json::{Map, Value};

fuzz_target!(|data: &[u8]| {
    let (settings, scene) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let Ok(Value::Object(mut map)) = serde_json::from_slice::<Value>(settings) else { return };
    // Tiny images: the point is the combination, not the time.
    for (k, max) in [("width", 24u64), ("height", 24), ("spp", 2)] {
        if map.get(k).and_then(Value::as_u64).is_none_or(|v| v > max) {
            map.insert(k.into(), Value::from(max.min(16)));
        }
    }
    // Files are not this target's business (the settings_json and layout_file targets).
    for k in ["facets", "save_facets", "facet_map", "palette_image", "saliency_cache"] {
        map.remove(k);
    }
    let settings = match Settings::from_layers(Some((Path::new("fuzz.json"), Value::Object(map))), Map::new()) {
        Ok(s) => s,
        Err(e) => {
            assert!(!e.to_string().contains('\n'), "multi-line error: {e}");
            return;
        }
    };
    let prep = if scene.is_empty() {
        Prepared::new(Scene::default_scene())
    } else {
        match Scene::from_slice(scene) {
            Ok(s) => Prepared::new(s),
            Err(e) => {
                let msg = e.to_string();
                assert!(!msg.contains("the parser failed"), "panic inside the loader: {msg}");
                assert!(!msg.contains('\n'), "multi-line error: {msg}");
                return;
            }
        }
    };
    match render(&prep, &settings, &Progress::silent()) {
        Ok(r) => assert!(r.film.color.iter().all(|c| c.is_finite()), "NaN pixel"),
        Err(e) => assert!(!e.to_string().contains('\n'), "multi-line error: {e}"),
    }
});
