//! Stroke seeds anchored to the surfaces (Meier 1996: strokes on particles placed on the
//! surfaces, so they move with them), for animation frames.
//!
//! Every triangle owns an endless sequence of seeds at fixed barycentrics (a low-discrepancy
//! sequence, rotated per triangle), seed k with a threshold k + u_k (u_k seeded in [0, 1)).
//! A frame shows seed k where the triangle's on-screen area holds more than its threshold of
//! strokes (area / cell^2), fully from `DENSITY_FADE` above: as a surface turns away or
//! recedes its seeds fade out one by one, as it turns towards the camera they fade in, and
//! the strokes keep about one per cell on screen (flat: the strokes' size stays the
//! brushwork's, in pixels, whatever the surface's angle).
//!
//! Where a seed is this frame comes from the renderer's own hits, not from a projection
//! alone: the point is projected through the frame's camera (`Camera::project`), moved by the
//! mean offset between the triangle's pixels and the projections of their hits (a facet
//! re-aimed by imprecision shows its surfaces shifted), and the pixels around that place are
//! searched for one whose hit lies on the same triangle within a few pixels' width of the
//! point. None: the point is hidden (or off the picture) and the seed is not shown. Seeds near
//! an occlusion edge (another object, the background, or a depth jump) fade over `fade_px`
//! pixels, so a stroke fades in as its surface comes out from behind another and fades out as
//! it goes behind.
//!
//! Given the picture the sequence's hatching is laid on (`LaidOn`: the key frame's geometry and
//! camera), each seed also says where its point was there and the triangle's map from there
//! to this frame (`Laid`): the brushwork hatches it there, so the rows are the key frame's,
//! carried with the surface.
//!
//! Background pixels (no hit) keep the still's grid seeds (`grid_seeds`): fixed on the canvas,
//! and hatched as a still's.
//!
//! Deterministic: every seed is a function of the frame's hits, scene and camera alone, listed
//! in triangle order; no frame before it is read, so a frame rendered alone has the same
//! seeds as in a sequence, on any thread count.

use glam::{DMat2, DVec2, DVec3, Vec2, Vec3};
use rayon::prelude::*;

use super::{Laid, SeedSource, StrokeSeed, grid_seeds};
use crate::camera::Camera;
use crate::facets::FacetMap;
use crate::film::{NO_HIT, PixelHit};
use crate::scene::World;
use crate::util::rng::{splitmix64, unit_f64};

/// The threshold's width, in strokes: seed k goes from invisible to full opacity as the
/// triangle's share of strokes goes from its threshold to this much above it.
pub const DENSITY_FADE: f64 = 0.5;
/// A hit this many pixel widths from a seed's point still shows it.
pub const FOUND_WITHIN_PX: f64 = 2.5;
/// Relative depth change between neighbouring pixels of different triangles counted as an
/// occlusion edge.
pub const DEPTH_JUMP: f32 = 0.03;
/// Salt of the surface seeds' ids.
const SALT: u64 = 0x7375_7266_6163_6573; // "surfaces"
/// The plastic constant's low-discrepancy steps (Roberts' R2 sequence).
const R2: (f64, f64) = (0.754_877_666_246_692_8, 0.569_840_290_998_053_3);

/// The picture a sequence's hatching is laid on: the key frame's triangle corners (render
/// space, by triangle id) and camera, at the frames' size.
#[derive(Clone, Copy)]
pub struct LaidOn<'a> {
    pub positions: &'a [[Vec3; 3]],
    pub camera: &'a dyn Camera,
}

/// One frame's seeds: what they are read from.
pub struct SurfaceSeeds<'a> {
    hits: &'a [PixelHit],
    width: usize,
    height: usize,
    world: &'a World,
    camera: &'a dyn Camera,
    facets: Option<&'a FacetMap>,
    fade_px: f32,
    laid_on: Option<LaidOn<'a>>,
    /// Per pixel, the facet of the ground there, under the subject too (a still ground's), if
    /// known: the canvas's seeds under the subject paint it (`StrokeSeed::ground`).
    ground: Option<&'a [u32]>,
    /// The triangles shown, each with the mean offset (pixels) of its pixels from their hits'
    /// projections, sorted by triangle.
    shown: Vec<(u32, DVec2)>,
    /// Distance of each pixel to the nearest occlusion edge (up to `fade_px`).
    edge_dist: Vec<f32>,
}

impl<'a> SurfaceSeeds<'a> {
    /// The seeds of a frame of `width x height` pixels whose hits are `hits`, of `world` seen
    /// through `camera`; `fade_px`: how far from an occlusion edge a seed is shown fully;
    /// `laid_on`: where the hatching is laid, if anywhere.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        hits: &'a [PixelHit],
        width: usize,
        height: usize,
        world: &'a World,
        camera: &'a dyn Camera,
        facets: Option<&'a FacetMap>,
        fade_px: f32,
        laid_on: Option<LaidOn<'a>>,
    ) -> SurfaceSeeds<'a> {
        debug_assert_eq!(hits.len(), width * height);
        let (w, h) = (width as u32, height as u32);
        // Each shown pixel's offset from its hit's projection, grouped by triangle.
        let mut pixels: Vec<(u32, u32)> =
            hits.iter().enumerate().filter(|(_, p)| p.is_hit()).map(|(i, p)| (p.tri, i as u32)).collect();
        pixels.par_sort_unstable();
        let offsets: Vec<Option<DVec2>> = pixels
            .par_iter()
            .map(|&(tri, i)| {
                let hit = &hits[i as usize];
                let here = DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                point(world, tri, hit.u as f64, hit.v as f64)
                    .and_then(|p| camera.project(p))
                    .map(|s| here - crate::motion::screen_to_pixel(s.screen, w, h))
            })
            .collect();
        let mut shown: Vec<(u32, DVec2)> = Vec::new();
        let mut k = 0;
        while k < pixels.len() {
            let tri = pixels[k].0;
            let (mut sum, mut n) = (DVec2::ZERO, 0.0);
            while k < pixels.len() && pixels[k].0 == tri {
                if let Some(o) = offsets[k] {
                    sum += o;
                    n += 1.0;
                }
                k += 1;
            }
            shown.push((tri, if n > 0.0 { sum / n } else { DVec2::ZERO }));
        }
        let edge = |i: usize, j: usize| {
            let (a, b) = (&hits[i], &hits[j]);
            if a.object != b.object || a.is_hit() != b.is_hit() {
                return true;
            }
            a.is_hit() && a.tri != b.tri && (a.t - b.t).abs() > DEPTH_JUMP * a.t.min(b.t)
        };
        let is_edge = |i: usize| {
            let (x, y) = (i % width, i / width);
            (x > 0 && edge(i, i - 1))
                || (x + 1 < width && edge(i, i + 1))
                || (y > 0 && edge(i, i - width))
                || (y + 1 < height && edge(i, i + width))
        };
        let (edge_dist, _) = crate::distance::nearest_features(w, h, fade_px.max(1.0), is_edge);
        SurfaceSeeds { hits, width, height, world, camera, facets, fade_px, laid_on, ground: None, shown, edge_dist }
    }

    /// With the ground's facet at every pixel (`ground`): the canvas's seeds under the subject
    /// paint the ground there (`StrokeSeed::ground`); without, they have no stroke.
    pub fn with_ground(self, ground: Option<&'a [u32]>) -> SurfaceSeeds<'a> {
        SurfaceSeeds { ground, ..self }
    }

    /// Seed `k` of triangle `tri`'s sequence: its barycentrics and its threshold.
    fn nth(seed: u64, layer: u64, tri: u32, k: u64) -> (f64, f64, f64, u64) {
        let base = splitmix64(seed ^ splitmix64(SALT ^ layer) ^ splitmix64(tri as u64));
        let (o1, o2) = (unit_f64(splitmix64(base ^ 1)), unit_f64(splitmix64(base ^ 2)));
        let (mut a, mut b) = ((o1 + k as f64 * R2.0).fract(), (o2 + k as f64 * R2.1).fract());
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let id = splitmix64(base ^ splitmix64(k + 3));
        (a, b, k as f64 + unit_f64(splitmix64(id ^ 0x7468)), id)
    }

    /// Where the point (a, b) of triangle `tri` is shown this frame, if it is.
    fn find(&self, tri: u32, offset: DVec2, p: DVec3, pixel_size: f64) -> Option<Vec2> {
        let (w, h) = (self.width, self.height);
        let seen = self.camera.project(p)?;
        let at = crate::motion::screen_to_pixel(seen.screen, w as u32, h as u32) + offset;
        let (cx, cy) = (at.x.floor(), at.y.floor());
        if !(cx >= -1.0 && cy >= -1.0 && cx <= w as f64 && cy <= h as f64) {
            return None;
        }
        let (cx, cy) = (cx as i64, cy as i64);
        let mut best: Option<(f64, usize)> = None;
        for y in (cy - 1).max(0)..=(cy + 1).min(h as i64 - 1) {
            for x in (cx - 1).max(0)..=(cx + 1).min(w as i64 - 1) {
                let i = y as usize * w + x as usize;
                let hit = &self.hits[i];
                if hit.tri != tri {
                    continue;
                }
                let Some(q) = point(self.world, tri, hit.u as f64, hit.v as f64) else { continue };
                let d = q.distance(p);
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, i));
                }
            }
        }
        let (d, i) = best?;
        if d > FOUND_WITHIN_PX * pixel_size {
            return None;
        }
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        // The projected place when its pixel shows the same surface as the pixel found (that
        // pixel, or a neighbouring triangle at the same depth), so a seed moves by fractions
        // of a pixel; else the found pixel's centre.
        let (ax, ay) = (at.x.floor(), at.y.floor());
        let same_surface = ax >= 0.0 && ay >= 0.0 && ax < w as f64 && ay < h as f64 && {
            let (a, b) = (&self.hits[ay as usize * w + ax as usize], &self.hits[i]);
            a.object == b.object && (a.tri == b.tri || (a.t - b.t).abs() <= DEPTH_JUMP * a.t.min(b.t))
        };
        let pos = if same_surface { at } else { DVec2::new(x + 0.5, y + 0.5) };
        Some(pos.as_vec2())
    }
}

/// The point at barycentrics (u, v) of triangle `tri`, render space.
fn point(world: &World, tri: u32, u: f64, v: f64) -> Option<DVec3> {
    if tri == NO_HIT || tri as usize >= world.triangle_count() {
        return None;
    }
    let c: [Vec3; 3] = world.triangle(tri);
    let c = c.map(|p| p.as_dvec3());
    Some(c[0] * (1.0 - u - v) + c[1] * u + c[2] * v)
}

/// Triangle `tri` on the picture the hatching is laid on (its corners, pixels) and the affine
/// map from there to this frame's picture, where its corners are `q`; None where it is not
/// seen there or is degenerate (edge-on).
fn laid_map(laid_on: LaidOn, tri: u32, q: &[DVec2], w: u32, h: u32) -> Option<([DVec2; 3], DMat2)> {
    let corners = laid_on.positions.get(tri as usize)?;
    let mut k = [DVec2::ZERO; 3];
    for (out, p) in k.iter_mut().zip(corners) {
        *out = crate::motion::screen_to_pixel(laid_on.camera.project(p.as_dvec3())?.screen, w, h);
    }
    let from = DMat2::from_cols(k[1] - k[0], k[2] - k[0]);
    let det = from.determinant();
    // Edge-on there (under a hundredth of a square pixel): no map.
    if !(det.abs() > 1e-2) {
        return None;
    }
    Some((k, DMat2::from_cols(q[1] - q[0], q[2] - q[0]) * from.inverse()))
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl SeedSource for SurfaceSeeds<'_> {
    fn seeds(&self, seed: u64, layer: u64, cell: f32, width: usize, height: usize) -> Vec<StrokeSeed> {
        debug_assert_eq!((width, height), (self.width, self.height));
        let (w, h) = (self.width as u32, self.height as u32);
        let cell2 = (cell as f64).powi(2);
        // Never more seeds on one triangle than cells on the picture.
        let most = (4.0 * (w as f64) * (h as f64) / cell2).ceil();
        let surface: Vec<Vec<StrokeSeed>> = self
            .shown
            .par_iter()
            .map(|&(tri, offset)| {
                let c = self.world.triangle(tri).map(|p| p.as_dvec3());
                let world_area = 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
                let on_screen: Option<Vec<DVec2>> = c
                    .iter()
                    .map(|&p| self.camera.project(p).map(|s| crate::motion::screen_to_pixel(s.screen, w, h)))
                    .collect();
                let Some(q) = on_screen else { return Vec::new() };
                let area = 0.5 * (q[1] - q[0]).perp_dot(q[2] - q[0]).abs();
                if !(area > 0.0 && world_area > 0.0) {
                    return Vec::new();
                }
                let pixel_size = (world_area / area).sqrt();
                let laid = self.laid_on.and_then(|l| laid_map(l, tri, &q, w, h));
                let strokes = (area / cell2).min(most);
                let mut out = Vec::new();
                for k in 0..strokes.ceil() as u64 {
                    let (a, b, threshold, id) = Self::nth(seed, layer, tri, k);
                    let density = ((strokes - threshold) / DENSITY_FADE).clamp(0.0, 1.0) as f32;
                    if density <= 0.0 {
                        continue;
                    }
                    let p = c[0] * (1.0 - a - b) + c[1] * a + c[2] * b;
                    let Some(pos) = self.find(tri, offset, p, pixel_size) else { continue };
                    let i = (pos.y as usize).min(self.height - 1) * self.width + (pos.x as usize).min(self.width - 1);
                    let fade = smoothstep(0.0, self.fade_px, self.edge_dist[i]);
                    let opacity = density * fade;
                    if opacity > 0.0 {
                        let plane = self.facets.map(|f| f.ids[i]);
                        let laid = laid.map(|(corners, to_frame)| Laid {
                            at: (corners[0] * (1.0 - a - b) + corners[1] * a + corners[2] * b).as_vec2(),
                            to_frame: to_frame.as_mat2(),
                        });
                        out.push(StrokeSeed { pos, id, plane, opacity, carried: true, laid, ground: false });
                    }
                }
                out
            })
            .collect();
        // The canvas's seeds: on the ground as a still's; under the subject, the ground's
        // strokes there (`StrokeSeed::ground`) when the ground's facets are known.
        let (hits, ground) = (self.hits, self.ground);
        let mut seeds = grid_seeds(seed, layer, cell, self.width, self.height, |p| {
            ground.is_some() || !hits[p.y as usize * self.width + p.x as usize].is_hit()
        });
        if let Some(ground) = ground {
            for s in &mut seeds {
                let i = s.pos.y as usize * self.width + s.pos.x as usize;
                if hits[i].is_hit() {
                    (s.plane, s.ground) = (Some(ground[i]), true);
                }
            }
        }
        seeds.extend(surface.into_iter().flatten());
        seeds
    }
}
