//! Inspection images of the Segment faceting, after the thesis's Fig. 4.5: the superpixels over
//! the pre-render, each level's segmentation with its selected segments and their quads, and
//! the final layout (the "final filter").

use image::{Rgba, RgbaImage};

use super::SegmentLevels;
use crate::facets::{FacetLayout, FacetMap};
use crate::util::grid::Grid;
use crate::util::rng::splitmix64;

/// A distinct, light colour per id.
pub fn id_colour(id: u32, salt: u64) -> [u8; 3] {
    let c = splitmix64(id as u64 ^ salt.wrapping_mul(0x9E37_79B9));
    [(c >> 8) as u8 / 2 + 100, (c >> 24) as u8 / 2 + 100, (c >> 40) as u8 / 2 + 100]
}

const EDGE: [u8; 4] = [20, 20, 24, 255];

/// Darkens pixels whose right or lower neighbour has another id.
fn draw_edges(img: &mut RgbaImage, ids: &[u32]) {
    let grid = Grid::new(img.width(), img.height());
    for p in 0..ids.len() {
        if grid.on_border_forward(ids, p) {
            img.put_pixel((p % grid.width) as u32, (p / grid.width) as u32, Rgba(EDGE));
        }
    }
}

/// A line between two points in pixel coordinates (clipped to the image).
fn draw_line(img: &mut RgbaImage, a: (f64, f64), b: (f64, f64), c: [u8; 4]) {
    let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
    for s in 0..=steps {
        let t = s as f64 / steps as f64;
        let (x, y) = (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t);
        if x >= 0.0 && y >= 0.0 && (x as u32) < img.width() && (y as u32) < img.height() {
            img.put_pixel(x as u32, y as u32, Rgba(c));
        }
    }
}

/// The superpixels: their boundaries drawn over `view` (the pre-render).
pub fn superpixel_image(levels: &SegmentLevels, view: &RgbaImage) -> RgbaImage {
    let mut img = view.clone();
    draw_edges(&mut img, &levels.superpixels.labels);
    img
}

/// Level `i`: each segment in its own colour, unselected ones greyed, selected ones with
/// their quad outlined in white (Fig. 4.5 c-e).
pub fn level_image(levels: &SegmentLevels, i: usize) -> RgbaImage {
    let level = &levels.levels[i];
    let (w, h) = (level.labels.width, level.labels.height);
    let mut img = RgbaImage::new(w, h);
    for (px, &l) in img.pixels_mut().zip(&level.labels.labels) {
        let c = id_colour(l, i as u64 + 1);
        px.0 = if level.selected[l as usize] {
            [c[0], c[1], c[2], 255]
        } else {
            let g = |v: u8| (v as u16 * 2 / 5 + 40) as u8;
            [g(c[0]), g(c[1]), g(c[2]), 255]
        };
    }
    draw_edges(&mut img, &level.labels.labels);
    for (s, quad) in level.quads.iter().enumerate() {
        if level.selected[s] {
            for k in 0..4 {
                let (a, b) = (quad[k], quad[(k + 1) % 4]);
                let p = |q: [f64; 2]| (q[0] * w as f64, q[1] * h as f64);
                draw_line(&mut img, p(a), p(b), [255, 255, 255, 255]);
            }
        }
    }
    img
}

/// The final layout rasterised at `width` x `height`: facets in their colours with dark borders
/// (Fig. 4.5 f).
pub fn layout_image(layout: &FacetLayout, width: u32, height: u32) -> RgbaImage {
    map_image(&layout.rasterize(width, height))
}

/// A rasterised layout as facet colours with dark borders (the `segments` pass of a render).
pub fn map_image(map: &FacetMap) -> RgbaImage {
    let mut img = RgbaImage::new(map.width, map.height);
    for (px, &id) in img.pixels_mut().zip(&map.ids) {
        let c = id_colour(id, 0);
        px.0 = [c[0], c[1], c[2], 255];
    }
    draw_edges(&mut img, &map.ids);
    img
}

/// Every inspection image with its pass name: `superpixels`, `level1`.., `layout`.
pub fn images(levels: &SegmentLevels, layout: &FacetLayout, view: &RgbaImage) -> Vec<(String, RgbaImage)> {
    let mut out = vec![("superpixels".to_string(), superpixel_image(levels, view))];
    for i in 0..levels.levels.len() {
        out.push((format!("level{}", i + 1), level_image(levels, i)));
    }
    out.push(("layout".to_string(), layout_image(layout, view.width(), view.height())));
    out
}
