//! Facet layout files (`--facets`, issue 18): arbitrary bytes as a JSON layout, and as a PNG
//! layout. Whatever loads is rasterised at two sizes and must give a facet id below its count
//! for every pixel: a clean error or a layout, never a panic, a hang or unbounded memory.
#![no_main]

use std::path::Path;

use cubist::facets::io;
use cubist::util::files::decode_image;
use cubist::util::limits::MAX_IMAGE_PIXELS;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let layout = if data.starts_with(b"\x89PNG") {
        let Ok(img) = decode_image(data, MAX_IMAGE_PIXELS) else { return };
        match io::from_image(&img, Path::new("fuzz.png")) {
            Ok(l) => l,
            Err(e) => return assert!(!e.to_string().contains('\n'), "multi-line error: {e}"),
        }
    } else {
        let Ok(text) = std::str::from_utf8(data) else { return };
        match io::from_json(text) {
            Ok(l) => l,
            Err(e) => return assert!(!e.contains('\n'), "multi-line error: {e}"),
        }
    };
    for (w, h) in [(17, 11), (64, 48)] {
        let map = layout.rasterize(w, h);
        assert_eq!(map.ids.len(), (w * h) as usize);
        assert!(map.ids.iter().all(|&id| id < layout.facet_count), "facet id past the count");
    }
});
