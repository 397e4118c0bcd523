//! Gradient overlays (thesis 4.4, Fig. 4.9): "gradient overlays appearing on the corners or
//! edges of some facets". A seeded fraction of the facets gets a smooth darkening (or, less
//! often, a lightening) that is strongest at one of the facet's corners and fades out at the
//! facet's centre, the way the painters modelled each plane from one edge.

use glam::{DVec2, Vec2, Vec3};
use rayon::prelude::*;

use super::{Canvas, Effect, EffectParams, PaintContext};
use crate::error::Result;
use crate::util::rng::{splitmix64, sub_seed, unit_f64};

/// The gradient overlays' parameters: the fraction of facets with one (0 = off).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GradientParams {
    pub fraction: f64,
    pub seed: u64,
}

impl EffectParams for GradientParams {
    fn is_on(&self) -> bool {
        self.fraction > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Gradients { fraction: self.fraction, seed: self.seed }))
    }
}

const SALT: u64 = 0x6772_6164_6965_6e74; // "gradient"
/// Share of the chosen facets that darken (the rest lighten).
const DARK_SHARE: f64 = 0.7;
/// Strength range at the corner: a darkening multiplies by 1 - s, a lightening mixes s x 0.6
/// of white in.
const STRENGTH: (f64, f64) = (0.35, 0.65);
/// Facets smaller than this (pixels) get no overlay: too small to read as a gradient.
const MIN_PIXELS: u64 = 16;

/// Overlays gradients on a fraction of the facets.
pub struct Gradients {
    /// Fraction of facets, in [0, 1].
    pub fraction: f64,
    pub seed: u64,
}

/// One facet's overlay: weight 1 at `corner`, 0 from the facet centre on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Overlay {
    pub corner: Vec2,
    /// (centre - corner) / |centre - corner|^2, so t = (p - corner) . axis is 0 at the corner
    /// and 1 at the centre.
    pub axis: Vec2,
    pub dark: bool,
    pub strength: f32,
}

impl Overlay {
    /// The overlay's weight at pixel centre `p`: smoothstep of 1 - t.
    pub fn weight(&self, p: Vec2) -> f32 {
        let w = (1.0 - (p - self.corner).dot(self.axis)).clamp(0.0, 1.0);
        w * w * (3.0 - 2.0 * w)
    }

    pub fn apply(&self, rgb: Vec3, p: Vec2) -> Vec3 {
        let w = self.weight(p) * self.strength;
        if self.dark { rgb * (1.0 - w) } else { rgb.lerp(Vec3::ONE, 0.6 * w) }
    }
}

/// A facet's pixel count, sum of pixel centres and extreme pixels (score, centre).
type Shape = (u64, DVec2, [(i64, Vec2); 4]);

/// Pixel count, coordinate sums and the four extreme pixels (along the diagonals: top-left,
/// top-right, bottom-right, bottom-left) of every facet; ties go to the first in scan order.
fn facet_shapes(width: u32, ids: &[u32], count: usize) -> Vec<Shape> {
    const DIRS: [(i64, i64); 4] = [(-1, -1), (1, -1), (1, 1), (-1, 1)];
    let mut shapes: Vec<Shape> = vec![(0, DVec2::ZERO, [(i64::MIN, Vec2::ZERO); 4]); count];
    let w = width as usize;
    for (i, &id) in ids.iter().enumerate() {
        let (x, y) = ((i % w) as i64, (i / w) as i64);
        let s = &mut shapes[id as usize];
        s.0 += 1;
        s.1 += DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        for (c, (dx, dy)) in s.2.iter_mut().zip(DIRS) {
            let score = dx * x + dy * y;
            if score > c.0 {
                *c = (score, Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            }
        }
    }
    shapes
}

impl Gradients {
    /// The overlay of every facet (None for facets not chosen). Seeded per facet, so a facet's
    /// choice does not depend on the others or on the image size.
    pub fn overlays(&self, width: u32, ids: &[u32], count: usize) -> Vec<Option<Overlay>> {
        let seed = sub_seed(self.seed, SALT);
        facet_shapes(width, ids, count)
            .into_iter()
            .enumerate()
            .map(|(f, (n, sum, corners))| {
                let h = splitmix64(seed ^ splitmix64(f as u64));
                if n < MIN_PIXELS || unit_f64(h) >= self.fraction {
                    return None;
                }
                let h2 = splitmix64(h);
                let corner = corners[(h2 >> 32) as usize % 4].1;
                let centre = (sum / n as f64).as_vec2();
                let a = centre - corner;
                if a.length_squared() < 4.0 {
                    return None;
                }
                let h3 = splitmix64(h2);
                let strength = STRENGTH.0 + (STRENGTH.1 - STRENGTH.0) * unit_f64(splitmix64(h3));
                Some(Overlay {
                    corner,
                    axis: a / a.length_squared(),
                    dark: unit_f64(h3) < DARK_SHARE,
                    strength: strength as f32,
                })
            })
            .collect()
    }
}

impl Effect for Gradients {
    fn name(&self) -> &'static str {
        "gradients"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let w = canvas.width;
        // Without facets there is no facet corner to shade (as there is no facet border).
        let Some(facets) = ctx.facets else { return Ok(()) };
        let ids = &facets.ids[..];
        let overlays = self.overlays(w, ids, ctx.facet_count());
        if overlays.iter().all(Option::is_none) {
            return Ok(());
        }
        let (coverage, px) = canvas.coverage_and_pixels();
        px.par_chunks_mut(w as usize).enumerate().for_each(|(y, row)| {
            for (x, p) in row.iter_mut().enumerate() {
                let i = y * w as usize + x;
                if !coverage.is_painted(i) {
                    continue;
                }
                if let Some(o) = &overlays[ids[i] as usize] {
                    *p = o.apply(p.truncate(), Vec2::new(x as f32 + 0.5, y as f32 + 0.5)).extend(p.w);
                }
            }
        });
        Ok(())
    }
}
