//! Silhouettes (thesis 4.4): the border darkening of eq 4.8 applied to the background by its
//! distance to the foreground, so objects stand out from the ground.

use rayon::prelude::*;

use super::borders::darkening;
use super::distance::distance_to_features;
use super::{Canvas, Effect, PaintContext};
use crate::error::Result;

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

    fn apply(&self, canvas: &mut Canvas, _ctx: &PaintContext) -> Result<()> {
        // The foreground: pixels any sample of which hit geometry. A partly covered pixel's
        // background part touches the foreground (p_d = 0).
        let px = &canvas.px;
        let dist = distance_to_features(canvas.width, canvas.height, self.width, |i| px[i].coverage > 0.0);
        let (md, s, bg, transparent) = (self.width, self.strength, canvas.background, canvas.transparent);
        canvas.px.par_iter_mut().zip(&dist).for_each(|(p, &d)| {
            // Partly covered pixels are foreground pixels too: d = 0 for their background part.
            if p.coverage < 1.0 && d < md {
                p.darken_background(darkening(d, md, s), bg, transparent);
            }
        });
        Ok(())
    }
}
