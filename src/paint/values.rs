//! Value range ("value carrying the form"): a fixed curve on each painted pixel's value that
//! deepens the darks and raises the lights about a middle value, so the planes' dark seams go
//! down towards umber-black and the lit subject stands out of a mid-toned ground, as on the
//! 1910 canvases, instead of every value sitting in the middle of the range.
//!
//! Then a lift: every value times one factor, the whole picture in a lighter key (the
//! silvery middle tones of 1910-11 rather than umber murk), the values' order and ratios kept
//! below white (a channel lifted past it clips in the encoding).
//!
//! The curve is the same on every picture (a power about `PIVOT`, no statistic of the
//! picture), so an animation's frames keep their values where the scene holds still and a
//! pixel's result depends on that pixel alone. It runs after passage, before the canvas grain.

use rayon::prelude::*;

use super::{Canvas, Effect, EffectParams, PaintContext, luminance};
use crate::error::Result;

/// The value range's parameters: how far the values spread about the middle, in [0, 1]
/// (0 = off): a pixel's value (linear luminance) L becomes PIVOT (L / PIVOT)^(1 + contrast);
/// then times `lift` (1 = off).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ValueParams {
    pub contrast: f64,
    pub lift: f64,
}

/// The value the curve keeps (linear luminance; about the middle of the ochre palette's ground).
pub const PIVOT: f32 = 0.1;

impl EffectParams for ValueParams {
    fn is_on(&self) -> bool {
        self.contrast > 0.0 || self.lift != 1.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Values { power: (1.0 + self.contrast) as f32, lift: self.lift as f32 }))
    }
}

/// The value curve: `power` > 1 spreads the values about `PIVOT`; `lift` multiplies them after.
pub struct Values {
    pub power: f32,
    pub lift: f32,
}

impl Values {
    /// The curve's factor for a colour of value `l` (hue and saturation kept); the lift is
    /// applied after it.
    pub fn factor(&self, l: f32) -> f32 {
        if self.power == 1.0 {
            return 1.0;
        }
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
                *p = (c * self.factor(luminance(c)) * self.lift).extend(p.w);
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
        let v = Values { power: 1.3, lift: 1.0 };
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

    #[test]
    fn the_lift_multiplies_every_value_alone_or_after_the_curve() {
        use crate::paint::EffectParams;
        use crate::paint::tests::{frame_with, run};
        assert!(!ValueParams { contrast: 0.0, lift: 1.0 }.is_on());
        assert!(ValueParams { contrast: 0.0, lift: 1.4 }.is_on());
        let colour = |x: u32, _| glam::Vec3::new(0.02, 0.015, 0.01) * (1 + 10 * x) as f32;
        for power in [1.0, 1.3] {
            let paint = |lift| {
                let mut film = frame_with(4, 1, glam::Vec3::ZERO, colour, |_, _| true);
                run(Box::new(Values { power, lift }), &mut film, None, false);
                film.color
            };
            for (a, b) in paint(1.0).iter().zip(paint(1.4)) {
                assert!((b.truncate() - a.truncate() * 1.4).abs().max_element() < 1e-6, "{a} lifted to {b}");
            }
        }
    }
}
