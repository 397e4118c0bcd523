//! The extra images a render writes beside its output (`--pass NAME`, `OUT.NAME.png`): read
//! off the film's buffers, the saliency map and the facets, drawn for people to look at
//! (colours) or for compositing (16-bit facet ids).

use glam::{DVec2, Vec3};
use image::{ImageBuffer, Luma, RgbaImage};

use crate::facets::FacetMap;
use crate::film::Film;
use crate::imprecision::FacetAim;
use crate::util::files::Gray16;
use crate::util::rng::splitmix64;

/// Extra images written beside the output (`out.<pass>.png`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pass {
    /// The per-pixel saliency map, grey.
    Saliency,
    /// Facet ids as colours, with facet centres and saliency centres marked.
    Facets,
    /// Facet ids as 16-bit grey values (for compositing).
    FacetIds,
    /// The final facet layout as colours (Segment faceting's Fig. 4.5 f).
    Segments,
    /// Object ids as colours.
    Objects,
    /// Shading normals as colours.
    Normals,
    /// Hit distance, grey, near = white.
    Depth,
    /// Screen motion from the previous frame and to the next (animation frames: `motion`).
    Motion,
}

impl Pass {
    /// The pass's name in file names (`OUT.<name>.png`).
    pub fn as_str(self) -> &'static str {
        match self {
            Pass::Saliency => "saliency",
            Pass::Facets => "facets",
            Pass::FacetIds => "facet-ids",
            Pass::Segments => "segments",
            Pass::Objects => "objects",
            Pass::Normals => "normals",
            Pass::Depth => "depth",
            Pass::Motion => "motion",
        }
    }

    /// How the pass's image is written: `grey` (8-bit, R = G = B: saliency, depth), `grey16`
    /// (16-bit grey: facet ids), `rgba16` (16-bit colour: motion) or `rgb` (8-bit colour).
    pub fn format(self) -> &'static str {
        match self {
            Pass::Motion => "rgba16",
            Pass::Saliency | Pass::Depth => "grey",
            Pass::FacetIds => "grey16",
            Pass::Facets | Pass::Segments | Pass::Objects | Pass::Normals => "rgb",
        }
    }
}

/// Facet ids as 16-bit grey values (layouts hold at most `facets::MAX_FACETS` facets).
pub fn facet_ids_pass(map: &FacetMap) -> Gray16 {
    ImageBuffer::from_fn(map.width, map.height, |x, y| Luma([map.ids[(y * map.width + x) as usize] as u16]))
}

/// The saliency map in grey tinted by facet colours (plain colours without saliency), facet
/// borders dark, each facet centre a yellow dot and saliency centre a red dot, with a red line from the facet centre to the
/// point the facet is aimed at (the thesis's Fig. 4.6 left).
pub fn facets_pass(map: &FacetMap, aims: &[FacetAim], saliency: Option<&[f32]>, scale: f64) -> RgbaImage {
    let (w, h) = (map.width, map.height);
    let mut img = RgbaImage::new(w, h);
    for (i, px) in img.pixels_mut().enumerate() {
        let id = map.ids[i];
        let c = splitmix64(id as u64 ^ 0x5eed);
        let base = [(c >> 8) as u8 as f32, (c >> 24) as u8 as f32, (c >> 40) as u8 as f32];
        // Saliency as grey (Fig. 4.6 left), tinted by the facet's colour.
        let tint = |c: f32| 60.0 + 0.7 * c;
        let rgb = match saliency {
            Some(s) => {
                let grey = 25.0 + 230.0 * s.get(i).copied().unwrap_or(0.0).clamp(0.0, 1.0);
                base.map(|c| 0.4 * tint(c) + 0.6 * grey)
            }
            None => base.map(tint),
        };
        let shade = if map.is_border(i) { 0.35 } else { 1.0 };
        px.0 = [(rgb[0] * shade) as u8, (rgb[1] * shade) as u8, (rgb[2] * shade) as u8, 255];
    }
    let r = (4.0 * scale).round().max(2.0);
    for a in aims {
        let Some(fc) = a.fc else { continue };
        if let Some(sc) = a.sc.filter(|sc| *sc != fc) {
            draw_line(&mut img, fc, sc, [230, 30, 30, 255]);
        }
        if let Some(sc) = a.sc_raw {
            draw_disc(&mut img, sc, r, [230, 30, 30, 255]);
        }
        draw_disc(&mut img, fc, r * 0.8, [255, 215, 0, 255]);
    }
    img
}

fn draw_disc(img: &mut RgbaImage, c: DVec2, r: f64, colour: [u8; 4]) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let (x0, x1) = (((c.x - r).floor() as i64).max(0), ((c.x + r).ceil() as i64).min(w - 1));
    let (y0, y1) = (((c.y - r).floor() as i64).max(0), ((c.y + r).ceil() as i64).min(h - 1));
    for y in y0..=y1 {
        for x in x0..=x1 {
            if (DVec2::new(x as f64 + 0.5, y as f64 + 0.5) - c).length() <= r {
                img.put_pixel(x as u32, y as u32, image::Rgba(colour));
            }
        }
    }
}

fn draw_line(img: &mut RgbaImage, a: DVec2, b: DVec2, colour: [u8; 4]) {
    let steps = (b - a).abs().max_element().ceil().max(1.0) as usize;
    for k in 0..=steps {
        let p = a + (b - a) * (k as f64 / steps as f64);
        let (x, y) = (p.x.floor() as i64, p.y.floor() as i64);
        if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
            img.put_pixel(x as u32, y as u32, image::Rgba(colour));
        }
    }
}

/// Passes read straight off the hit buffers (and the saliency map, when computed).
pub fn geometry_pass(film: &Film, pass: Pass) -> Option<RgbaImage> {
    let mut img = RgbaImage::new(film.width, film.height);
    match pass {
        Pass::Objects => {
            for (px, h) in img.pixels_mut().zip(&film.hits) {
                px.0 = if h.is_hit() {
                    let c = splitmix64(h.object as u64 + 1);
                    [(c >> 16) as u8 | 0x30, (c >> 24) as u8 | 0x30, (c >> 32) as u8 | 0x30, 255]
                } else {
                    [0, 0, 0, 255]
                };
            }
        }
        Pass::Normals => {
            for (px, h) in img.pixels_mut().zip(&film.hits) {
                let n = h.normal * 0.5 + Vec3::splat(0.5);
                px.0 = if h.is_hit() {
                    [(n.x * 255.0) as u8, (n.y * 255.0) as u8, (n.z * 255.0) as u8, 255]
                } else {
                    [0, 0, 0, 255]
                };
            }
        }
        Pass::Depth => {
            let (lo, hi) = film
                .hits
                .iter()
                .filter(|h| h.is_hit())
                .fold((f32::INFINITY, 0.0f32), |(lo, hi), h| (lo.min(h.t), hi.max(h.t)));
            for (px, h) in img.pixels_mut().zip(&film.hits) {
                let g = if h.is_hit() && hi > lo {
                    255.0 * (1.0 - (h.t - lo) / (hi - lo)) * 0.9 + 25.0
                } else if h.is_hit() {
                    255.0
                } else {
                    0.0
                };
                px.0 = [g as u8, g as u8, g as u8, 255];
            }
        }
        Pass::Saliency => {
            let map = film.saliency.as_ref()?;
            return Some(crate::saliency::saliency_image(map, film.width, film.height));
        }
        _ => return None,
    }
    Some(img)
}
