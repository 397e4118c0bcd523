//! Luminance ranks: the painted pixels' luminances as sortable keys, which the rank-based
//! effects (palette, quantisation) sort into.

use glam::{Vec3, Vec4};
use rayon::prelude::*;

use super::context::{Canvas, Coverage};

/// Luminance of linear RGB (Rec. 709), as `shading::luminance`.
pub fn luminance(c: Vec3) -> f32 {
    crate::shading::luminance(c)
}

/// Number of luminance levels the rank-based effects sort into: far finer than the 8-bit
/// output, and a counting sort over them is linear time.
pub const KEY_LEVELS: usize = 1 << 16;

/// The painted pixels' luminances as sortable keys: `keys[i]` = sqrt(L / L_max) in 16 bits
/// (square root: more levels in the shadows, roughly perceptual), `UNPAINTED` for pixels the
/// effects do not paint, plus the histogram of keys. Monotone: L_a < L_b implies
/// key_a <= key_b, so mapping by key preserves luminance order; equal keys are ties and get
/// the same treatment (deterministic, and flat areas stay flat).
pub struct LuminanceKeys {
    pub keys: Vec<u32>,
    pub histogram: Vec<u32>,
    /// Number of painted pixels.
    pub total: u64,
}

/// The key of a pixel colour effects leave alone.
pub const UNPAINTED: u32 = u32::MAX;

impl LuminanceKeys {
    pub fn new(canvas: &Canvas) -> LuminanceKeys {
        let coverage = Coverage(canvas.coverage.as_deref());
        let lum = |(i, p): (usize, &Vec4)| if coverage.is_painted(i) { luminance(p.truncate()).max(0.0) } else { -1.0 };
        let max = canvas.px.par_iter().enumerate().map(lum).reduce(|| 0.0f32, f32::max);
        let scale = if max > 0.0 && max.is_finite() { 1.0 / max } else { 0.0 };
        let top = (KEY_LEVELS - 1) as f32;
        let keys: Vec<u32> = canvas
            .px
            .par_iter()
            .enumerate()
            .map(|ip| {
                let l = lum(ip);
                if l < 0.0 { UNPAINTED } else { ((l * scale).min(1.0).sqrt() * top + 0.5) as u32 }
            })
            .collect();
        let mut histogram = vec![0u32; KEY_LEVELS];
        let mut total = 0u64;
        for &k in &keys {
            if k != UNPAINTED {
                histogram[k as usize] += 1;
                total += 1;
            }
        }
        LuminanceKeys { keys, histogram, total }
    }
}
