//! The film's colour as an 8-bit sRGB image.

use image::RgbaImage;
use rayon::prelude::*;

use crate::film::Film;
use crate::scene::srgb::Srgb8;

/// Encodes a film's colour. Opaque: the background is already blended in. Transparent: the
/// background is un-blended using the coverage alpha, so edges composite correctly. Rows in
/// parallel (each pixel alone: the same bytes on any thread count).
pub fn encode(film: &Film, background: [f32; 3], transparent: bool) -> RgbaImage {
    let bg = glam::Vec3::from(background);
    let mut img = RgbaImage::new(film.width, film.height);
    let raw: &mut [u8] = &mut img;
    let lut = Srgb8::get();
    let srgb8 = |v: f32| lut.code(v);
    raw.par_chunks_mut(4 * 1024).zip(film.color.par_chunks(1024)).for_each(|(out, colour)| {
        for (px, c) in out.chunks_exact_mut(4).zip(colour) {
            let (rgb, a) = if transparent {
                let a = c.w;
                let rgb = if a > 0.0 { (c.truncate() - bg * (1.0 - a)) / a } else { glam::Vec3::ZERO };
                (rgb, a)
            } else {
                (c.truncate(), 1.0)
            };
            px.copy_from_slice(&[srgb8(rgb.x), srgb8(rgb.y), srgb8(rgb.z), (a.clamp(0.0, 1.0) * 255.0 + 0.5) as u8]);
        }
    });
    img
}
