//! Facet borders (SPEC eq 4.8): Picasso and Braque defined facets boldly, so pixels darken as
//! they near a facet border, with p_d from an exact distance transform.

use rayon::prelude::*;

use super::border_profile::darkening;
use super::passage::BorderStyle;
use super::{Canvas, Effect, EffectParams, PaintContext, darken};
use crate::distance::distance_to_features;
use crate::error::Result;
use crate::util::grid::Grid;

/// The facet borders' parameters: `width` (md of eq 4.8) in pixels at 1000 px (this image's
/// pixels: times `scale`), 0 = off; `strength` in [0, 1]; how they are drawn: symmetric here,
/// as passage later in the chain (`passage::PassageParams`, which reads the `seed`); the
/// regions passage follows join the planes left whole across the outline when `open_planes`
/// (`PaintParams::open_planes`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BorderParams {
    pub width: f64,
    pub strength: f64,
    pub style: BorderStyle,
    pub scale: f64,
    pub seed: u64,
    pub open_planes: bool,
}

impl BorderParams {
    /// Whether there are borders to draw, in either style.
    pub fn drawn(&self) -> bool {
        self.width > 0.0 && self.strength > 0.0
    }
}

impl EffectParams for BorderParams {
    fn is_on(&self) -> bool {
        self.drawn() && self.style == BorderStyle::Symmetric
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Borders { width: (self.width * self.scale) as f32, strength: self.strength as f32 }))
    }
}

/// A pixel lies on a facet border when one of its 4-neighbours belongs to another facet (the
/// first pixel the thesis's circle search stops at); p_d is the Euclidean distance between
/// pixel centres to the nearest border pixel, so both sides of a border darken alike.
pub fn border_pixels(width: u32, height: u32, ids: &[u32]) -> impl Fn(usize) -> bool + Sync + '_ {
    let grid = Grid::new(width, height);
    move |i| grid.on_border(ids, i)
}

/// Darkens pixels near facet borders (eq 4.8).
pub struct Borders {
    /// md, pixels of this image.
    pub width: f32,
    /// In [0, 1].
    pub strength: f32,
}

impl Effect for Borders {
    fn name(&self) -> &'static str {
        "borders"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        // One facet has no border.
        let Some(facets) = ctx.facets else { return Ok(()) };
        let pd = distance_to_features(
            canvas.width,
            canvas.height,
            self.width,
            border_pixels(facets.width, facets.height, &facets.ids),
        );
        let (md, s, transparent) = (self.width, self.strength, canvas.transparent);
        canvas.px.par_iter_mut().zip(&pd).for_each(|(p, &d)| {
            if d < md {
                darken(p, darkening(d, md, s), transparent);
            }
        });
        Ok(())
    }
}
