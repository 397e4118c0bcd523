//! Value range ("value carrying the form"): a fixed curve on each painted pixel's value that
//! deepens the darks and raises the lights about a middle value, so the planes' dark seams go
//! down towards umber-black and the lit subject stands out of a mid-toned ground, as on the
//! 1910 canvases, instead of every value sitting in the middle of the range.
//!
//! The curve is the same on every picture (a power about `PIVOT`, no statistic of the
//! picture), so an animation's frames keep their values where the scene holds still and a
//! pixel's result depends on that pixel alone. It runs after passage, before the canvas grain.

use rayon::prelude::*;

use super::{Canvas, Effect, EffectParams, PaintContext, luminance};
use crate::error::Result;

/// The value range's parameters: how far the values spread about the middle, in [0, 1]
/// (0 = off): a pixel's value (linear luminance) L becomes PIVOT (L / PIVOT)^(1 + contrast).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ValueParams {
    pub contrast: f64,
}

/// The value the curve keeps (linear luminance; about the middle of the ochre palette's ground).
pub const PIVOT: f32 = 0.1;

impl EffectParams for ValueParams {
    fn is_on(&self) -> bool {
        self.contrast > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Values { power: (1.0 + self.contrast) as f32 }))
    }
}

/// The value curve: `power` > 1 spreads the values about `PIVOT`.
pub struct Values {
    pub power: f32,
}

impl Values {
    /// The factor a colour of value `l` is multiplied by (hue and saturation kept).
    pub fn factor(&self, l: f32) -> f32 {
        let l = l.max(1e-6);
        PIVOT * (l / PIVOT).powf(self.power) / l
    }
}

impl Effect for Values {
    fn name(&self) -> &'static str {
        "values"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, _ctx: &PaintContext) -> Result<()> {
        let (coverage, px) = canvas.coverage_and_pixels();
        px.par_iter_mut().enumerate().for_each(|(i, p)| {
            if coverage.is_painted(i) {
                let c = p.truncate();
                *p = (c * self.factor(luminance(c))).extend(p.w);
            }
        });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pivot_is_kept_darks_deepen_and_lights_rise() {
        let v = Values { power: 1.3 };
        assert!((v.factor(PIVOT) - 1.0).abs() < 1e-6);
        assert!(v.factor(0.5 * PIVOT) < 1.0 && v.factor(2.0 * PIVOT) > 1.0);
        // Monotone: a darker pixel never comes out lighter than a lighter one.
        let out = |l: f32| l * v.factor(l);
        let mut last = 0.0;
        for k in 1..=1000 {
            let o = out(k as f32 / 1000.0);
            assert!(o.is_finite() && o > last, "{k}: {o} after {last}");
            last = o;
        }
        assert!(out(0.0).is_finite() && out(0.0) >= 0.0);
    }
}
