//! Per-plane light (ART.md "Each plane has its own light", issue 13): every facet is shaded
//! from light to dark across itself, as if lit on its own (chiaroscuro per plane), the way
//! Picasso and Braque modelled each plane of 1909-1912 from a light edge to a dark one.
//!
//! The ramp runs along the plane's `dark` direction (`planes`: across an elongated plane,
//! away from the key light on a round one, turned and sometimes flipped per facet) from its
//! light end to its dark end, and multiplies the value already there: the render's own
//! shading, textures and cues stay legible inside the ramp, so form reads through the planes.
//! Background facets get their ramps too: the backdrop becomes lit planes, not a flat ground.

use glam::Vec2;
use rayon::prelude::*;

use super::planes::Plane;
use super::{Canvas, Effect, PaintContext};
use crate::error::Result;

/// At amount 1, the light end is brightened by this fraction ...
pub const LIGHT: f32 = 0.25;
/// ... and the dark end darkened by this one.
pub const DARK: f32 = 0.85;

/// A light-to-dark ramp across every facet.
pub struct PlaneLight {
    /// In [0, 1].
    pub amount: f32,
    pub seed: u64,
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
}

impl Effect for PlaneLight {
    fn name(&self) -> &'static str {
        "plane light"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        // Unfaceted: there is no plane to light (as there is no facet border).
        let Some(facets) = ctx.facets else { return Ok(()) };
        let w = canvas.width as usize;
        let planes = ctx.planes(canvas.width, canvas.pixel_count(), self.seed);
        let factor = |x: usize, y: usize| {
            self.at(&planes[facets.ids[y * w + x] as usize], Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
        };
        if ctx.kept_across_chains() {
            // A session keeps each pixel's factor (it reads the planes and the facet map):
            // a paint-only change multiplies by it.
            let n = canvas.pixel_count();
            let key = [self.amount.to_bits() as u64, self.seed, w as u64, n as u64];
            let f =
                ctx.factors(self.name(), key, false, || (0..n).into_par_iter().map(|i| factor(i % w, i / w)).collect());
            canvas.scale_painted(|x, y| f[y * w + x]);
        } else {
            canvas.scale_painted(factor);
        }
        Ok(())
    }
}
