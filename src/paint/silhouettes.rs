//! Silhouettes (thesis 4.4): the border darkening of eq 4.8 applied to the background by its
//! distance to the foreground, so objects stand out from the ground.

use rayon::prelude::*;

use super::border_profile::darkening;
use super::{Canvas, Effect, EffectParams, PaintContext, darken_background};
use crate::distance::distance_to_features;
use crate::error::Result;

/// The silhouettes' parameters: `width` in pixels at 1000 px (this image's pixels: times
/// `scale`), 0 = off; `strength` in [0, 1].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SilhouetteParams {
    pub width: f64,
    pub strength: f64,
    pub scale: f64,
}

impl EffectParams for SilhouetteParams {
    fn is_on(&self) -> bool {
        self.width > 0.0 && self.strength > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Silhouettes { width: (self.width * self.scale) as f32, strength: self.strength as f32 }))
    }
}

/// Darkens the background near the foreground.
pub struct Silhouettes {
    /// The falloff distance md, pixels of this image.
    pub width: f32,
    /// In [0, 1].
    pub strength: f32,
}

impl Effect for Silhouettes {
    fn name(&self) -> &'static str {
        "silhouettes"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, _ctx: &PaintContext) -> Result<()> {
        // The foreground: pixels any sample of which hit geometry. A partly covered pixel's
        // background part touches the foreground (p_d = 0).
        let (w, h) = (canvas.width, canvas.height);
        let (md, s, bg, transparent) = (self.width, self.strength, canvas.background, canvas.transparent);
        let (coverage, px) = canvas.coverage_and_pixels();
        let dist = distance_to_features(w, h, self.width, |i| coverage.of(i, &px[i]) > 0.0);
        px.par_iter_mut().zip(&dist).enumerate().for_each(|(i, (p, &d))| {
            // Partly covered pixels are foreground pixels too: d = 0 for their background part.
            let c = coverage.of(i, p);
            if c < 1.0 && d < md {
                darken_background(p, c, darkening(d, md, s), bg, transparent);
            }
        });
        Ok(())
    }
}
