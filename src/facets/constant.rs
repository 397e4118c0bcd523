//! Constant faceting (thesis 4.3.1): a facet map image drawn by the user
//! (the thesis traced Picasso's *Le Guitariste*), each distinct colour a facet, scaled to the
//! output nearest-neighbour when the layout is rasterised.

use std::collections::HashMap;
use std::hash::Hash;
use std::path::Path;

use super::{FacetLayout, LabelImage, MAX_FACETS};
use crate::error::{Error, Result};

/// Labels the distinct values of `pixels` in order of first appearance (row-major).
pub fn label_distinct<T: Eq + Hash + Copy>(pixels: impl Iterator<Item = T>) -> (Vec<u32>, u32) {
    let mut ids: HashMap<T, u32> = HashMap::new();
    let labels = pixels
        .map(|p| {
            let n = ids.len() as u32;
            *ids.entry(p).or_insert(n)
        })
        .collect();
    (labels, ids.len() as u32)
}

/// Decodes an image into a label image, one facet per distinct colour (alpha included).
pub fn labels_from_image(img: &image::DynamicImage, path: &Path) -> Result<LabelImage> {
    let (width, height) = (img.width(), img.height());
    if width == 0 || height == 0 {
        return Err(Error::input(path, "the facet map is empty"));
    }
    let (labels, count) = match img {
        image::DynamicImage::ImageRgba16(_)
        | image::DynamicImage::ImageRgb16(_)
        | image::DynamicImage::ImageLuma16(_)
        | image::DynamicImage::ImageLumaA16(_) => label_distinct(img.to_rgba16().pixels().map(|p| p.0)),
        _ => label_distinct(img.to_rgba8().pixels().map(|p| p.0)),
    };
    if count > MAX_FACETS {
        return Err(Error::input(
            path,
            format!(
                "{count} distinct colours: a facet map needs flat colours, one per facet (at most {MAX_FACETS}); \
                 an anti-aliased or photographic image is not a facet map"
            ),
        ));
    }
    Ok(LabelImage { width, height, labels })
}

/// Reads an image file (PNG or JPEG) with a one-line error naming it, within the image limits
/// (`util::files::read_image`: a regular file, its size checked before decoding).
pub fn read_image(path: &Path) -> Result<image::DynamicImage> {
    crate::util::files::read_image(path, crate::util::limits::MAX_IMAGE_PIXELS)
}

/// The layout of a facet map image: its colours as the base label image.
pub fn layout(path: &Path) -> Result<FacetLayout> {
    let img = read_image(path)?;
    let base = labels_from_image(&img, path)?;
    let facet_count = base.labels.iter().max().map_or(1, |m| m + 1);
    Ok(FacetLayout { facet_count, base: Some(base), sites: Vec::new(), polygons: Vec::new() })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distinct_colours_in_first_appearance_order() {
        let (l, n) = label_distinct([5u8, 5, 9, 5, 2, 9].into_iter());
        assert_eq!(l, vec![0, 0, 1, 0, 2, 1]);
        assert_eq!(n, 3);
    }

    #[test]
    fn map_image_scales_nearest_neighbour() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("map.png");
        let mut img = image::RgbImage::new(4, 2);
        for (x, y, p) in img.enumerate_pixels_mut() {
            p.0 = if x < 2 {
                [255, 0, 0]
            } else if y == 0 {
                [0, 255, 0]
            } else {
                [0, 0, 255]
            };
        }
        img.save(&path).unwrap();
        let l = layout(&path).unwrap();
        assert_eq!(l.facet_count, 3);
        let m = l.rasterize(8, 4);
        assert_eq!(&m.ids[0..8], &[0, 0, 0, 0, 1, 1, 1, 1]);
        assert_eq!(&m.ids[3 * 8..4 * 8], &[0, 0, 0, 0, 2, 2, 2, 2]);
    }

    #[test]
    fn bad_maps_give_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nope.png");
        let e = layout(&missing).unwrap_err().to_string();
        assert!(e.contains("nope.png") && e.contains("cannot open"), "{e}");
        let junk = dir.path().join("junk.png");
        std::fs::write(&junk, b"not a png at all").unwrap();
        let e = layout(&junk).unwrap_err().to_string();
        assert!(e.contains("junk.png"), "{e}");
        // A gradient: 65536 + distinct colours.
        let noisy = dir.path().join("noisy.png");
        let img =
            image::RgbImage::from_fn(300, 300, |x, y| image::Rgb([x as u8, y as u8, (x / 256 + y / 256 * 2) as u8]));
        img.save(&noisy).unwrap();
        let e = layout(&noisy).unwrap_err().to_string();
        assert!(e.contains("distinct colours"), "{e}");
    }
}
