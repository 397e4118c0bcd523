//! Screen-space motion of what each pixel shows (the `motion` pass of animation frames): the
//! surface point a pixel's hit names (its triangle and barycentrics, the renderer's own hit,
//! not an estimate from the pictures) is put where the same triangle is at the previous and at
//! the next frame (the scene posed then) and projected through those frames' cameras; the
//! motion is the change of its projection, in pixels.
//!
//! Projections go through each frame's camera model (`Camera::project`, the exact inverse of
//! its rays). A facet re-aimed by imprecision shows its points through its own rays, offset
//! from the camera's projection by an amount that changes slowly from frame to frame: the
//! difference of two projections of the same camera carries the surface's motion, which is
//! what the pass is for (the offset cancels).
//!
//! Encoding (`motion_pass`): a 16-bit RGBA PNG, each channel `32768 + 32 v` for a motion `v`
//! in pixels (1/32 px steps, +-1024 px), rounded and clamped: R, G = the motion from the
//! previous frame to this one (x right, y up), B, A = from this frame to the next, as the
//! Vector pass of Blender's renderers lays its four components out. A pixel that shows no
//! surface, or whose point is outside the other frame's view, has no motion (32768).

use glam::{DVec2, Vec4};
use image::{ImageBuffer, Rgba};
use rayon::prelude::*;

use crate::camera::Camera;
use crate::film::PixelHit;
use crate::scene::World;

/// Steps per pixel of the 16-bit encoding.
pub const STEPS_PER_PIXEL: f32 = 32.0;
/// The encoding's zero.
pub const ZERO: u16 = 32768;

pub use crate::util::files::Rgba16;

/// One frame's scene as the motion reads it: its triangles (render space, the same ids in
/// every frame) and its camera.
pub struct FrameView<'a> {
    pub world: &'a World,
    pub camera: &'a dyn Camera,
}

/// Where a surface point of triangle `tri` at barycentrics (u, v) lands on a `width x height`
/// picture of `view`, in pixels (x right, y down, the top-left corner at 0); None where the
/// triangle is gone or the point leaves the camera's view.
pub fn pixel_of(view: &FrameView, tri: u32, u: f32, v: f32, width: u32, height: u32) -> Option<DVec2> {
    if tri as usize >= view.world.triangle_count() {
        return None;
    }
    let c = view.world.triangle(tri);
    let p = c[0] * (1.0 - u - v) + c[1] * u + c[2] * v;
    let seen = view.camera.project(p.as_dvec3())?;
    seen.in_view().then(|| screen_to_pixel(seen.screen, width, height))
}

/// A screen point (x in [-0.5, 0.5] left to right, y in [-0.5, 0.5] bottom to top) in pixels.
pub fn screen_to_pixel(s: DVec2, width: u32, height: u32) -> DVec2 {
    DVec2::new((s.x + 0.5) * width as f64, (0.5 - s.y) * height as f64)
}

/// Per pixel: (previous -> this frame, this -> next frame) motion in pixels, x right and y
/// down; zero where the pixel shows no surface or the point is not in the other frame's view
/// (or there is no such frame).
pub fn motion_vectors(
    hits: &[PixelHit],
    width: u32,
    height: u32,
    this: &FrameView,
    previous: Option<&FrameView>,
    next: Option<&FrameView>,
) -> Vec<Vec4> {
    hits.par_iter()
        .map(|h| {
            if !h.is_hit() {
                return Vec4::ZERO;
            }
            let Some(here) = pixel_of(this, h.tri, h.u, h.v, width, height) else { return Vec4::ZERO };
            let delta = |other: Option<&FrameView>, sign: f64| {
                other
                    .and_then(|o| pixel_of(o, h.tri, h.u, h.v, width, height))
                    .map_or(DVec2::ZERO, |there| (here - there) * sign)
            };
            let from_previous = delta(previous, 1.0);
            let to_next = delta(next, -1.0);
            Vec4::new(from_previous.x as f32, from_previous.y as f32, to_next.x as f32, to_next.y as f32)
        })
        .collect()
}

/// One motion component in the pass's 16 bits (see the module doc).
pub fn encode(v: f32) -> u16 {
    if !v.is_finite() {
        return ZERO;
    }
    (ZERO as f32 + (v * STEPS_PER_PIXEL).round()).clamp(0.0, u16::MAX as f32) as u16
}

/// The inverse of `encode`: pixels.
pub fn decode(c: u16) -> f32 {
    (c as f32 - ZERO as f32) / STEPS_PER_PIXEL
}

/// The `motion` pass image of `motion_vectors`' output: y flipped to point up (see the module
/// doc).
pub fn motion_pass(vectors: &[Vec4], width: u32, height: u32) -> Rgba16 {
    ImageBuffer::from_fn(width, height, |x, y| {
        let m = vectors[(y * width + x) as usize];
        Rgba([encode(m.x), encode(-m.y), encode(m.z), encode(-m.w)])
    })
}

/// `motion_pass` read back: per pixel (previous -> this, this -> next) in pixels, y down.
pub fn read_pass(img: &Rgba16) -> Vec<Vec4> {
    img.pixels().map(|p| Vec4::new(decode(p.0[0]), -decode(p.0[1]), decode(p.0[2]), -decode(p.0[3]))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encoding_round_trips_at_a_thirty_second_of_a_pixel_and_clamps() {
        for v in [0.0f32, 1.0, -1.0, 0.03125, -12.5, 1023.0, -1024.0] {
            assert_eq!(decode(encode(v)), v);
        }
        assert!((decode(encode(0.3)) - 0.3).abs() <= 0.5 / STEPS_PER_PIXEL);
        assert_eq!(encode(5000.0), u16::MAX);
        assert_eq!(encode(-5000.0), 0);
        assert_eq!(encode(f32::NAN), ZERO);
    }

    #[test]
    fn the_pass_points_y_up_and_reads_back() {
        let v = vec![Vec4::new(1.0, 2.0, -3.0, 4.5), Vec4::ZERO];
        let img = motion_pass(&v, 2, 1);
        assert_eq!(img.get_pixel(0, 0).0, [ZERO + 32, ZERO - 64, ZERO - 96, ZERO - 144]);
        assert_eq!(img.get_pixel(1, 0).0, [ZERO; 4]);
        assert_eq!(read_pass(&img), v);
    }
}
