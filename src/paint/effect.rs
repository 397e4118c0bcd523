//! The `Effect` trait: one painterly effect of the chain.

use super::context::{Canvas, PaintContext};
use super::palette;
use crate::error::Result;

/// One painterly effect. `apply` must be deterministic (no thread-dependent order) and must
/// keep the canvas's alpha conventions (see the module doc).
pub trait Effect: Send + Sync {
    fn name(&self) -> &'static str;
    /// Whether it reads the film's hits (`PaintContext::hits`) besides the regions.
    fn reads_hits(&self) -> bool {
        false
    }
    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()>;
    /// A colour transfer's luminance mapping for this canvas, to hold for a sequence
    /// (`Painter::palette_key`); None for every other effect.
    fn palette_key(&self, _canvas: &Canvas<'_>) -> Option<palette::PaletteKey> {
        None
    }
}
