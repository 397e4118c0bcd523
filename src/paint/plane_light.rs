//! Per-plane light ("Each plane has its own light"): every facet is shaded
//! from light to dark across itself, as if lit on its own (chiaroscuro per plane), the way
//! Picasso and Braque modelled each plane of 1909-1912 from a light edge to a dark one.
//!
//! The ramp runs along the plane's `dark` direction (`planes`: across an elongated plane,
//! away from the key light on a round one, turned and sometimes flipped per facet) from its
//! light end to its dark end, and multiplies the value already there: the render's own
//! shading, textures and cues stay legible inside the ramp, so form reads through the planes.
//! Background facets get their ramps too, deeper than the subject's (`GROUND`): the backdrop
//! becomes modelled planes, each ending in a dark seam, that the lit subject stands in.

use glam::Vec2;
use rayon::prelude::*;

use super::planes::{Plane, smoothstep};
use super::{Canvas, Effect, EffectParams, PaintContext};
use crate::error::Result;
use crate::film::PixelHit;
use crate::util::rng::splitmix64;

/// The per-plane light's parameters: its amount in [0, 1] (0 = off) and its steps (0 = a
/// smooth ramp).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PlaneLightParams {
    pub amount: f64,
    pub seed: u64,
    pub steps: u32,
}

impl EffectParams for PlaneLightParams {
    fn is_on(&self) -> bool {
        self.amount > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        let steps = (self.steps > 0).then_some(Steps { levels: self.steps });
        Ok(Box::new(PlaneLight { amount: self.amount as f32, seed: self.seed, steps }))
    }
}

/// At amount 1, the light end is brightened by this fraction ...
pub const LIGHT: f32 = 0.25;
/// ... and the dark end darkened by this one.
pub const DARK: f32 = 0.85;

/// The composition's light (the painters' lit central pyramid or oval, calm corners): at the
/// subject's centre the plane's value is raised by this share of `amount` ...
pub const CENTRE_LIGHT: f32 = 0.16;
/// ... and at the canvas's corners lowered by this one, where the ramps also calm down
/// (`CALM`: the share of the ramp's amount lost there).
pub const EDGE_DARK: f32 = 0.22;
pub const CALM: f32 = 0.6;
/// The composition's calm grows from nothing to whole between these distances from the
/// subject's centre (`Oval::r`).
pub const CALM_FROM_TO: (f32, f32) = (0.35, 1.1);
/// A plane all ground has its ramp this share deeper than a plane on the subject (in
/// proportion to its share of ground pixels): the ground's planes modelled more deeply, the
/// subject's cues untouched (judged blind: docs/look/README.md, round 12).
pub const GROUND: f32 = 0.4;

/// A light-to-dark ramp across every facet.
pub struct PlaneLight {
    /// In [0, 1].
    pub amount: f32,
    pub seed: u64,
    pub steps: Option<Steps>,
}

/// The light of each plane in `levels` values from its light end to its dark end, in straight
/// bands across the plane (planes within the plane), as the painters modelled a plane in a few
/// tones rather than in a smooth gradient; the bands multiply the strokes' paint, so each
/// band's edge crosses the strokes in a straight line (judged blind: docs/look/README.md,
/// rounds 26 and 45).
pub struct Steps {
    pub levels: u32,
}

impl Steps {
    /// The middle of the step that ramp position `t` (in [0, 1]) falls in.
    pub fn step(&self, t: f32) -> f32 {
        let n = self.levels as f32;
        ((t * n).floor().min(n - 1.0) + 0.5) / n
    }
}

impl PlaneLight {
    /// The factor the ramp multiplies a pixel's colour by at ramp position t (0 light end,
    /// 1 dark end): linear from 1 + amount LIGHT to 1 - amount DARK.
    pub fn factor(&self, t: f32) -> f32 {
        1.0 + self.amount * (LIGHT * (1.0 - t) - DARK * t)
    }

    /// The factor at pixel centre `p` of `plane`.
    pub fn at(&self, plane: &Plane, p: Vec2) -> f32 {
        self.factor(plane.ramp(p))
    }

    /// The factor at `p` of `plane` within the composition: `r` = the distance from the
    /// subject's centre over the canvas's half diagonal (`Oval::r`), `ground` the plane's
    /// share of ground pixels. The ramp calms towards the edges, deepens on the ground, and
    /// the value follows the central light.
    pub fn composed(&self, plane: &Plane, p: Vec2, r: f32, ground: f32) -> f32 {
        self.composed_at(plane.ramp(p), r, ground)
    }

    /// `composed` at ramp position `t` (0 light end, 1 dark end).
    pub fn composed_at(&self, t: f32, r: f32, ground: f32) -> f32 {
        let edge = Oval::calm(r);
        let depth = (1.0 - CALM * edge) * (1.0 + GROUND * ground);
        let ramp = 1.0 + self.amount * depth * (LIGHT * (1.0 - t) - DARK * t);
        ramp * (1.0 + self.amount * (CENTRE_LIGHT * (1.0 - smoothstep(0.0, 0.7, r)) - EDGE_DARK * edge))
    }
}

/// Where the composition's light is centred: the subject's centre (the centroid of the pixels
/// showing geometry; the canvas's centre without any), and the canvas's half diagonal.
#[derive(Clone, Copy, Debug)]
pub struct Oval {
    pub centre: Vec2,
    pub half_diagonal: f32,
}

impl Oval {
    pub fn of(width: usize, height: usize, hits: &[PixelHit]) -> Oval {
        let half_diagonal = 0.5 * ((width * width + height * height) as f32).sqrt().max(1.0);
        let (mut sx, mut sy, mut n) = (0u64, 0u64, 0u64);
        if hits.len() == width * height {
            for (i, h) in hits.iter().enumerate() {
                if h.is_hit() {
                    sx += (i % width) as u64;
                    sy += (i / width) as u64;
                    n += 1;
                }
            }
        }
        let centre = if n > 0 {
            Vec2::new(sx as f32 / n as f32 + 0.5, sy as f32 / n as f32 + 0.5)
        } else {
            Vec2::new(width as f32 / 2.0, height as f32 / 2.0)
        };
        Oval { centre, half_diagonal }
    }

    /// The distance of `p` from the centre over the half diagonal.
    pub fn r(&self, p: Vec2) -> f32 {
        (p - self.centre).length() / self.half_diagonal
    }

    /// How calm the composition is at distance `r` (`Oval::r`): 0 about the subject, 1 towards
    /// the canvas's edges and corners.
    pub fn calm(r: f32) -> f32 {
        smoothstep(CALM_FROM_TO.0, CALM_FROM_TO.1, r)
    }
}

impl Effect for PlaneLight {
    fn name(&self) -> &'static str {
        "plane light"
    }

    fn reads_hits(&self) -> bool {
        true
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        // Unfaceted: there is no plane to light (as there is no facet border).
        let Some(facets) = ctx.facets else { return Ok(()) };
        let w = canvas.width as usize;
        let planes = ctx.planes(canvas.width, canvas.pixel_count(), self.seed);
        let oval = ctx.oval(w, canvas.height as usize);
        // The factor at a pixel given each plane's share of ground, which is counted only when
        // the factors are made (a session keeps them).
        let factor = |ground: &[f32], x: usize, y: usize| {
            let p = ctx.plane_point(y * w + x, w);
            let f = facets.ids[y * w + x] as usize;
            let t = planes[f].ramp(p);
            let t = self.steps.as_ref().map_or(t, |s| s.step(t));
            self.composed_at(t, oval.r(p), ground.get(f).copied().unwrap_or(0.0))
        };
        let n = canvas.pixel_count();
        if ctx.kept_across_chains() {
            // A session keeps each pixel's factor (it reads the planes and the facet map):
            // a paint-only change multiplies by it.
            let centre = ((oval.centre.x.to_bits() as u64) << 32) | oval.centre.y.to_bits() as u64;
            let steps = self.steps.as_ref().map_or(0, |s| splitmix64(s.levels as u64));
            let key = [self.amount.to_bits() as u64, self.seed ^ centre ^ steps, w as u64, n as u64];
            let f = ctx.factors(self.name(), key, false, || {
                let ground = ctx.ground_shares(n);
                (0..n).into_par_iter().map(|i| factor(&ground, i % w, i / w)).collect()
            });
            canvas.scale_painted(|x, y| f[y * w + x]);
        } else {
            let ground = ctx.ground_shares(n);
            canvas.scale_painted(|x, y| factor(&ground, x, y));
        }
        Ok(())
    }
}
