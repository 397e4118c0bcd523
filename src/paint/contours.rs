//! Drawn contours: the subject's inner contours (where one part meets another, a depth step
//! within it, a crease of its surface) drawn as a firm, broken dark line, as the painters drew
//! the cues that carry a subject inside their planes (an eye's rim, a soundhole, a joint).
//!
//! Two neighbouring pixels of one facet, both showing the subject (not the scene's setting),
//! are split by a contour when they show different objects, depths further apart than
//! `DEPTH_STEP` of the nearer, or normals more than `CREASE_DEG` apart. Facet borders and the
//! outline against the ground get no contour (the join lines and passage draw those), nor do
//! thin parts (strings, spokes, whiskers: a surface running on less than `THIN` line widths
//! past the contour), whose two lines would read as beads; nor does a contour found only here
//! and there (a rim whose step comes and goes pixel by pixel). The line is dark over half its
//! width either side of the contour and fades over as much again. It is broken: the surface is
//! divided into cubes of `BREAK_CELL` render units and the line left out where its contour
//! lies in one of the `1 - KEEP` share of them, so the gaps stay on the surface when the
//! camera moves.

use rayon::prelude::*;

use super::{Canvas, Effect, EffectParams, PaintContext, darken};
use crate::distance::{NO_FEATURE, nearest_features};
use crate::error::{Error, Result};
use crate::film::PixelHit;
use crate::scene::World;
use crate::util::rng::splitmix64;

/// The contours' parameters: the line's `width` in pixels at 1000 px (this image's pixels:
/// times `scale`), 0 = off; its `strength` in [0, 1].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ContourParams {
    pub width: f64,
    pub strength: f64,
    pub scale: f64,
    pub seed: u64,
}

impl EffectParams for ContourParams {
    fn is_on(&self) -> bool {
        self.width > 0.0 && self.strength > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        let width = (self.width * self.scale) as f32;
        Ok(Box::new(Contours { width, strength: self.strength as f32, seed: self.seed }))
    }
}

/// Neighbours whose depths differ by more than this share of the nearer are split by a contour.
pub const DEPTH_STEP: f32 = 0.02;
/// Neighbours whose normals turn by more than this (degrees) are split by a contour (a crease).
pub const CREASE_DEG: f32 = 35.0;
/// A contour whose surface on either side runs on less than this many line widths past it (a
/// string, a spoke) draws no line.
pub const THIN: f32 = 1.5;
/// A contour pixel is kept when the square of this side about it holds `RUN` contour pixels or
/// more (itself included): a line, not a bead.
pub const RUN_SIDE: usize = 5;
pub const RUN: usize = 4;
/// The side of the cubes the line's breaks are drawn by, render units (the scene's radius 1).
pub const BREAK_CELL: f32 = 0.1;
/// The share of the cubes where the line is drawn.
pub const KEEP: f32 = 0.85;

/// Draws the subject's inner contours.
pub struct Contours {
    /// The line's width, pixels of this image.
    pub width: f32,
    /// In [0, 1].
    pub strength: f32,
    pub seed: u64,
}

impl Contours {
    /// Whether the neighbours `i` and `j = i + step` (step 1: across; the width: down) are
    /// split by a contour: same facet, both on the subject, both sides `thin` pixels wide.
    /// `room`: whether the image holds `thin` more pixels before `i` and after `j`.
    #[allow(clippy::too_many_arguments)]
    fn splits(
        &self,
        world: &World,
        hits: &[PixelHit],
        facet: impl Fn(usize) -> u32,
        i: usize,
        step: usize,
        thin: usize,
        room: (bool, bool),
    ) -> bool {
        let j = i + step;
        let (p, q) = (&hits[i], &hits[j]);
        let subject = |h: &PixelHit| h.is_hit() && !world.is_setting(h.object as usize);
        if !subject(p) || !subject(q) || facet(i) != facet(j) {
            return false;
        }
        // Each side's surface runs on `thin` pixels further along the step: the same object
        // and facet, at a depth within `DEPTH_STEP` (a part cut off by the image's edge counts
        // as thin).
        let reach = thin * step;
        let wide = |k: usize, h: &PixelHit| {
            hits[k].object == h.object
                && facet(k) == facet(i)
                && (hits[k].t - h.t).abs() <= DEPTH_STEP * hits[k].t.min(h.t)
        };
        if !(room.0 && wide(i - reach, p) && room.1 && wide(j + reach, q)) {
            return false;
        }
        p.object != q.object
            || (p.t - q.t).abs() > DEPTH_STEP * p.t.min(q.t)
            || p.normal.dot(q.normal) < CREASE_DEG.to_radians().cos()
    }

    /// The line's weight at contour point `hit` (see the module doc): None in a gap, else
    /// 0.7-1, varying cube to cube as a brush's pressure does.
    fn weight(&self, world: &World, hit: &PixelHit) -> Option<f32> {
        let cell = (world.point_at(hit.tri, hit.u, hit.v) / BREAK_CELL).floor().as_ivec3();
        let key = (cell.x as u32 as u64) ^ ((cell.y as u32 as u64) << 21) ^ ((cell.z as u32 as u64) << 42);
        let u = (splitmix64(self.seed ^ splitmix64(key)) >> 40) as f32 / (1u64 << 24) as f32;
        (u < KEEP).then(|| 0.7 + 0.3 * u / KEEP)
    }
}

impl Effect for Contours {
    fn name(&self) -> &'static str {
        "contours"
    }

    fn reads_hits(&self) -> bool {
        true
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        // The subject is told from the setting, and the breaks placed, by the rendered world.
        let Some(world) = ctx.lighting.map(|l| l.world) else {
            return Err(Error::Internal("contours: drawing them needs the rendered scene; none was given".into()));
        };
        let (w, h) = (canvas.width as usize, canvas.height as usize);
        let hits = ctx.hits;
        if hits.len() != w * h || w < 2 || h < 2 {
            return Ok(());
        }
        let facet = |i: usize| ctx.facet(i);
        let thin = (THIN * self.width).round().max(1.0) as usize;
        // A contour pixel: the pixel before a split across or down (the split between
        // pixel centres is drawn half a pixel off, the same for every line).
        let marks: Vec<bool> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let across = (x >= thin, x + 1 + thin < w);
                let down = (y >= thin, y + 1 + thin < h);
                (x + 1 < w && self.splits(world, hits, facet, i, 1, thin, across))
                    || (y + 1 < h && self.splits(world, hits, facet, i, w, thin, down))
            })
            .collect();
        // A contour found only every few pixels (a rim whose depth step comes and goes with
        // the sampling) would draw a row of beads: a mark with fewer than `RUN` marks in the
        // square of `RUN_SIDE` pixels about it is dropped. A drawn line holds at least `RUN`
        // there, one pixel per row or column it crosses.
        let r = (RUN_SIDE / 2) as isize;
        let marks: Vec<bool> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                if !marks[i] {
                    return false;
                }
                let (x, y) = ((i % w) as isize, (i / w) as isize);
                let mut n = 0;
                for yy in (y - r).max(0)..=(y + r).min(h as isize - 1) {
                    for xx in (x - r).max(0)..=(x + r).min(w as isize - 1) {
                        n += marks[yy as usize * w + xx as usize] as usize;
                    }
                }
                n >= RUN
            })
            .collect();
        let half = 0.5 * self.width;
        let reach = 2.0 * half;
        let (dist, nearest) = nearest_features(w as u32, h as u32, reach + 1.0, |i| marks[i]);
        let transparent = canvas.transparent;
        let (coverage, px) = canvas.coverage_and_pixels();
        px.par_iter_mut().enumerate().for_each(|(i, p)| {
            let (d, k) = (dist[i], nearest[i]);
            if k == NO_FEATURE || d >= reach || !coverage.is_painted(i) {
                return;
            }
            let Some(weight) = self.weight(world, &hits[k as usize]) else { return };
            let profile = if d <= half { 1.0 } else { 1.0 - (d - half) / (reach - half).max(1e-6) };
            darken(p, 1.0 - self.strength * weight * profile, transparent);
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use glam::{Vec3, Vec4};

    use super::*;
    use crate::facets::FacetMap;
    use crate::film::Film;
    use crate::paint::chiaroscuro::ViewAxes;
    use crate::paint::{Lighting, Painter};
    use crate::shading::LightRig;

    const W: u32 = 80;
    const H: u32 = 24;

    /// A world of 40 triangles in a row along x, 0.05 apart (cubes of `BREAK_CELL` hold two).
    fn row_of_triangles() -> World {
        let tris: Vec<[Vec3; 3]> = (0..40)
            .map(|k| {
                let x = 0.05 * k as f32 + 0.01;
                [Vec3::new(x, 0.01, 0.0), Vec3::new(x + 0.04, 0.01, 0.0), Vec3::new(x, 0.05, 0.0)]
            })
            .collect();
        World::from_triangles(&tris)
    }

    /// A white canvas all subject: column x shows triangle x / 2 at a corner, at depth 1
    /// above row `step` and `far` from it on (a depth step along the row), and a strip one
    /// pixel high at row `strip` shows a second object (a thin part: a string).
    fn film(step: u32, far: f32, strip: Option<u32>) -> Film {
        let mut film = Film::new(W, H, 1);
        for y in 0..H {
            for x in 0..W {
                let i = (y * W + x) as usize;
                film.color[i] = Vec4::ONE;
                let h = &mut film.hits[i];
                let object = (strip == Some(y)) as u32;
                (h.tri, h.object, h.normal, h.u, h.v) = (x / 2, object, Vec3::Z, 0.0, 0.0);
                h.t = if y >= step { far } else { 1.0 };
            }
        }
        film
    }

    fn draw(film: &mut Film, facets: Option<&FacetMap>, world: &World, seed: u64) {
        let rig = LightRig { lights: Vec::new(), ambient: 0.14, shadows: false };
        let view = ViewAxes { right: Vec3::X, up: Vec3::Y, forward: -Vec3::Z };
        let lighting = Lighting { world, rig: &rig, view };
        let c = Contours { width: 2.0, strength: 0.5, seed };
        Painter::from_effects(vec![Box::new(c)], [0.0; 3], false).apply(film, facets, Some(&lighting)).unwrap();
    }

    #[test]
    fn a_depth_step_is_drawn_as_a_broken_line_and_nothing_else_darkens() {
        let world = row_of_triangles();
        let mut f = film(12, 1.5, None);
        draw(&mut f, None, &world, 7);
        let (mut drawn, mut gaps) = (0, 0);
        for x in 0..W {
            let v = |y: u32| f.color[(y * W + x) as usize].x;
            // The contour lies between rows 11 and 12; marked at row 11, the line covers
            // rows 10-12 and is gone from row 13 and above row 10.
            for y in (0..10).chain(13..H) {
                assert_eq!(v(y), 1.0, "({x}, {y}) away from the contour");
            }
            if v(11) < 1.0 {
                drawn += 1;
                assert!((0.5..=0.65).contains(&v(11)), "core 1 - 0.5 x a weight of 0.7-1: {}", v(11));
            } else {
                gaps += 1;
                assert_eq!((v(10), v(12)), (1.0, 1.0), "a gap is a gap across the line");
            }
        }
        // Two columns a triangle, two triangles a cube: the breaks come in runs of 4 pixels.
        assert!(drawn >= 40 && gaps >= 4, "{drawn} drawn, {gaps} gaps");
        let mut again = film(12, 1.5, None);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap();
        pool.install(|| draw(&mut again, None, &world, 7));
        assert_eq!(f.color, again.color, "the same on any thread count");
        let mut other = film(12, 1.5, None);
        draw(&mut other, None, &world, 8);
        assert_ne!(f.color, other.color, "the breaks follow the seed");
    }

    #[test]
    fn facet_borders_small_steps_and_thin_parts_draw_no_line() {
        let world = row_of_triangles();
        let untouched = |f: &Film| f.color.iter().all(|c| *c == Vec4::ONE);
        // A depth step along a facet border: the join lines draw it.
        let ids = (0..W * H).map(|i| (i / W >= 12) as u32).collect();
        let facets = FacetMap { width: W, height: H, ids, facet_count: 2 };
        let mut f = film(12, 1.5, None);
        draw(&mut f, Some(&facets), &world, 7);
        assert!(untouched(&f), "along a facet border");
        // A step smaller than DEPTH_STEP of the nearer depth.
        let mut f = film(12, 1.0 + 0.5 * DEPTH_STEP, None);
        draw(&mut f, None, &world, 7);
        assert!(untouched(&f), "a small step");
        // A part one pixel high: its side of both contours is thin.
        let mut f = film(H, 1.5, Some(12));
        draw(&mut f, None, &world, 7);
        assert!(untouched(&f), "a thin part");
        // A ridge one pixel high on the same object, nearer than its surroundings.
        let mut f = film(0, 1.5, None);
        for h in &mut f.hits[(12 * W) as usize..(13 * W) as usize] {
            h.t = 1.0;
        }
        draw(&mut f, None, &world, 7);
        assert!(untouched(&f), "a thin ridge");
        // The ground: no hit, no line.
        let mut f = film(12, 1.5, None);
        for h in &mut f.hits[(12 * W) as usize..] {
            *h = PixelHit::MISS;
        }
        draw(&mut f, None, &world, 7);
        assert!(untouched(&f), "the outline against the ground");
    }

    #[test]
    fn a_contour_found_every_fourth_pixel_draws_no_beads() {
        let world = row_of_triangles();
        // The step below row 12 only in every fourth column: dots, not a line.
        let mut f = film(H, 1.5, None);
        for x in (0..W).step_by(4) {
            for y in 12..H {
                f.hits[(y * W + x) as usize].t = 1.5;
            }
        }
        draw(&mut f, None, &world, 7);
        assert!(f.color.iter().all(|c| *c == Vec4::ONE), "no beads");
    }

    #[test]
    fn without_the_rendered_scene_it_is_an_error() {
        let mut f = film(12, 1.5, None);
        let c = Contours { width: 2.0, strength: 0.5, seed: 1 };
        let e = Painter::from_effects(vec![Box::new(c)], [0.0; 3], false).apply(&mut f, None, None).unwrap_err();
        assert!(e.to_string().contains("contours"), "{e}");
    }
}
