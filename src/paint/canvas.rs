//! Canvas grain ("Visible brushwork": "the canvas grain shows through thin paint"):
//! the last effect, a plain-weave linen texture modulating the value of the whole painting.
//!
//! The weave: vertical (warp) and horizontal (weft) threads `period` pixels apart, crossing
//! over and under each other in a checkerboard; the thread on top is bright along its middle
//! and dark in the gaps, each thread a little thicker or thinner (seeded). How much of it
//! shows varies slowly over the canvas (thinner and thicker paint). The period is given at
//! 1000 px like every pixel size; when it falls under a few pixels the weave would alias, so
//! it fades out, as a canvas photographed from further away.

use rayon::prelude::*;

use super::noise::{Grid2, lattice1};
use super::{Canvas, Effect, EffectParams, PaintContext};
use crate::error::Result;
use crate::util::rng::sub_seed;

/// The canvas grain's parameters: its amount in [0, 1] (0 = off); the weave's period is
/// `PERIOD` pixels at 1000 px (this image's pixels: times `scale`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CanvasGrainParams {
    pub amount: f64,
    pub scale: f64,
    pub seed: u64,
}

impl EffectParams for CanvasGrainParams {
    fn is_on(&self) -> bool {
        self.amount > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        let period = (PERIOD as f64 * self.scale) as f32;
        Ok(Box::new(CanvasGrain { amount: self.amount as f32, period, seed: self.seed }))
    }
}

const SALT: u64 = 0x6361_6e76_6173_3031; // "canvas01"
/// Value change of the weave at amount 1 (peak to peak).
pub const DEPTH: f32 = 0.22;
/// Thread period at 1000 px, pixels.
pub const PERIOD: f32 = 4.0;
/// The weave fades out between these periods (pixels of the image).
const FADE: (f32, f32) = (1.8, 3.0);
/// How slowly the paint's thickness varies: share of sqrt(w h) per noise cell.
const THICKNESS_PERIOD: f32 = 0.08;

/// A linen weave showing through the paint.
pub struct CanvasGrain {
    /// In [0, 1].
    pub amount: f32,
    /// Thread period, pixels of this image.
    pub period: f32,
    pub seed: u64,
}

/// One thread crossing a row or column: its profile across it (bright in the middle, dark in
/// the gap; a thicker thread is flatter) and its along-thread dip at the crossings.
#[derive(Clone, Copy)]
struct Thread {
    /// Index of the thread (its parity decides the weave's over and under).
    index: i64,
    profile: f32,
    dip: f32,
}

impl CanvasGrain {
    /// The threads crossing `n` pixel centres along one axis (`seed` per axis): the weave is
    /// separable, so the per-pixel work is a table look-up per axis.
    fn threads(&self, seed: u64, n: usize) -> Vec<Thread> {
        (0..n)
            .map(|x| {
                let f = (x as f32 + 0.5) / self.period;
                let index = f.floor() as i64;
                let t = f - index as f32;
                let s = (std::f32::consts::PI * t).sin().max(0.0);
                // Thickness 0.7 .. 1.3: the profile s^(0.6 / thickness).
                let thick = 0.7 + 0.6 * lattice1(seed, index);
                Thread { index, profile: s.powf(0.6 / thick), dip: 0.75 + 0.25 * s }
            })
            .collect()
    }

    /// The weave's brightness, in [0, 1], where column thread `x` crosses row thread `y`.
    fn weave(x: &Thread, y: &Thread) -> f32 {
        if (x.index + y.index).rem_euclid(2) == 0 { x.profile * y.dip } else { y.profile * x.dip }
    }
}

impl Effect for CanvasGrain {
    fn name(&self) -> &'static str {
        "canvas grain"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let fade = ((self.period - FADE.0) / (FADE.1 - FADE.0)).clamp(0.0, 1.0);
        let depth = DEPTH * self.amount * fade;
        if !(depth > 0.0) {
            return Ok(());
        }
        let (w, h) = (canvas.width as usize, canvas.height as usize);
        let seed = sub_seed(self.seed, SALT);
        let (columns, rows) = (self.threads(seed, w), self.threads(seed ^ 0xfeed, h));
        // The weave's mean (half the crossings show a column thread, half a row thread):
        // subtracted, so the painting's value is kept on average.
        let mean = |t: &[Thread], f: fn(&Thread) -> f32| t.iter().map(f).sum::<f32>() / t.len().max(1) as f32;
        let mean = 0.5
            * (mean(&columns, |t| t.profile) * mean(&rows, |t| t.dip)
                + mean(&rows, |t| t.profile) * mean(&columns, |t| t.dip));
        let thickness = (THICKNESS_PERIOD * ((w * h) as f32).sqrt()).max(8.0);
        let grid = Grid2::new(seed ^ 1, (0.0, w as f32 / thickness), (0.0, h as f32 / thickness));
        let factor = |x: usize, y: usize| {
            let shows = 0.5 + grid.value2(seed ^ 1, (x as f32 + 0.5) / thickness, (y as f32 + 0.5) / thickness);
            1.0 + depth * shows * (CanvasGrain::weave(&columns[x], &rows[y]) - mean)
        };
        if ctx.kept_across_chains() {
            // A session keeps each pixel's factor: it depends on the image size and these
            // settings alone, so it serves every later paint (`PaintInputs::kept_for_changes_after`).
            let key =
                [w as u64, h as u64, ((self.amount.to_bits() as u64) << 32) | self.period.to_bits() as u64, self.seed];
            let f = ctx
                .factors(self.name(), key, true, || (0..w * h).into_par_iter().map(|i| factor(i % w, i / w)).collect());
            canvas.scale_painted(|x, y| f[y * w + x]);
        } else {
            canvas.scale_painted(factor);
        }
        Ok(())
    }
}
