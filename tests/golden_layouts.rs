//! Golden facet layouts: a seed's Voronoi and Patch layouts must not change between versions
//! or machines (an animation rendered on a farm, or resumed after an upgrade, relies on it).
//! The ids are compared exactly. `CUBIST_UPDATE_GOLDEN=1 cargo test --release --test
//! golden_layouts` rewrites the goldens after an intended change.

use std::path::PathBuf;

use cubist::facets::{FacetMap, patch, voronoi};
use image::{ImageBuffer, Luma};

fn golden(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden").join(name)
}

fn check(name: &str, map: &FacetMap) {
    let path = golden(name);
    let img: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_fn(map.width, map.height, |x, y| Luma([map.ids[(y * map.width + x) as usize] as u16]));
    if std::env::var_os("CUBIST_UPDATE_GOLDEN").is_some() {
        img.save(&path).unwrap();
        return;
    }
    let want = match image::open(&path) {
        Ok(image::DynamicImage::ImageLuma16(g)) => g,
        other => {
            panic!(
                "{}: missing or not 16-bit grey ({:?}); rewrite with CUBIST_UPDATE_GOLDEN=1",
                path.display(),
                other.err()
            )
        }
    };
    assert_eq!(want.dimensions(), img.dimensions(), "{name}");
    let differ = want.pixels().zip(img.pixels()).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{name}: {differ} pixels changed facet");
}

#[test]
fn voronoi_layout_is_stable() {
    check("voronoi_seed7_96x72.png", &voronoi::layout(150, 15, 4.0 / 3.0, 7).rasterize(96, 72));
}

#[test]
fn patch_layout_is_stable() {
    check("patch_seed7_96x72.png", &patch::layout(80, 3.0, 4.0 / 3.0, 7).unwrap().rasterize(96, 72));
}
