//! 8-bit sRGB codes of linear values by a table, not a power per channel: what the encoder
//! writes and what anti-aliasing compares (a leaf module, so both can use it).

use super::texture::linear_to_srgb;

/// The 8-bit sRGB code of a linear value by the formula (`linear_to_srgb`, rounded).
fn srgb8_formula(v: f32) -> u8 {
    (linear_to_srgb(v) * 255.0 + 0.5) as u8
}

/// The least value in [0, 1] of each code 1..=255 (`srgb8_formula`), by bisection on the
/// bit patterns of the non-negative floats (ordered as the integers).
fn srgb8_thresholds() -> &'static [f32; 255] {
    static T: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        std::array::from_fn(|k| {
            let want = k as u8 + 1;
            let (mut lo, mut hi) = (0u32, 1.0f32.to_bits());
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if srgb8_formula(f32::from_bits(mid)) >= want { hi = mid } else { lo = mid + 1 }
            }
            f32::from_bits(lo)
        })
    })
}

/// Bits of a float dropped to index `srgb8_starts`: the buckets are 2^-7 of an octave wide.
const BUCKET_SHIFT: u32 = 16;

/// For each bucket of positive floats below 1 (`bits >> BUCKET_SHIFT`), the number of code
/// thresholds below its least float: where `srgb8`'s count starts.
fn srgb8_starts() -> &'static [u8] {
    static S: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
    S.get_or_init(|| {
        let t = srgb8_thresholds();
        (0..=1.0f32.to_bits() >> BUCKET_SHIFT)
            .map(|b| {
                let least = f32::from_bits(b << BUCKET_SHIFT);
                t.partition_point(|&t| t <= least) as u8
            })
            .collect()
    })
}

/// `srgb8_formula(v)` without a power per channel: the number of code thresholds at or below
/// `v`, counted from its bucket's start (`srgb8_starts`; a bucket holds at most one threshold,
/// `a_bucket_holds_at_most_one_threshold`). The same code wherever the rounded formula is
/// monotone (`srgb_codes_match_the_formula` checks every float near every threshold); NaN and
/// values at or below 0 give 0.
pub fn srgb8(v: f32) -> u8 {
    Srgb8::get().code(v)
}

/// `srgb8`'s tables, fetched once for a loop over many values (the encoder's).
#[derive(Clone, Copy)]
pub struct Srgb8 {
    starts: &'static [u8],
    /// The thresholds, then +infinity (so the count needs no bound check).
    thresholds: &'static [f32; 256],
}

impl Srgb8 {
    pub fn get() -> Srgb8 {
        static T: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
        let thresholds = T.get_or_init(|| {
            let t = srgb8_thresholds();
            std::array::from_fn(|k| t.get(k).copied().unwrap_or(f32::INFINITY))
        });
        Srgb8 { starts: srgb8_starts(), thresholds }
    }

    /// `srgb8(v)`.
    #[inline]
    pub fn code(&self, v: f32) -> u8 {
        if !(v > 0.0) {
            return 0;
        }
        if v >= 1.0 {
            // Every threshold is at most 1.
            return 255;
        }
        let c = self.starts[(v.to_bits() >> BUCKET_SHIFT) as usize] as usize;
        (c + (self.thresholds[c] <= v) as usize) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bucket_holds_at_most_one_threshold() {
        let t = srgb8_thresholds();
        for w in t.windows(2) {
            assert!(w[0] < w[1], "{w:?}");
            assert_ne!(w[0].to_bits() >> BUCKET_SHIFT, w[1].to_bits() >> BUCKET_SHIFT, "{w:?}");
        }
    }

    #[test]
    fn srgb_codes_match_the_formula() {
        for &t in srgb8_thresholds() {
            let b = t.to_bits();
            for bits in b.saturating_sub(4096)..b + 4096 {
                let v = f32::from_bits(bits);
                assert_eq!(srgb8(v), srgb8_formula(v), "{v:e}");
            }
        }
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let v = (x >> 40) as f32 / (1u64 << 24) as f32 * 1.2 - 0.1;
            assert_eq!(srgb8(v), srgb8_formula(v), "{v:e}");
        }
        // Every bucket's least float and the float just below it.
        for b in 1..=1.0f32.to_bits() >> BUCKET_SHIFT {
            for v in [f32::from_bits(b << BUCKET_SHIFT), f32::from_bits((b << BUCKET_SHIFT) - 1)] {
                assert_eq!(srgb8(v), srgb8_formula(v), "{v:e}");
            }
        }
        assert!(srgb8_thresholds().iter().all(|&t| t <= 1.0));
        for v in [0.0, -0.0, -1.0, 1.0, 2.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::MIN_POSITIVE, 1e-45] {
            assert_eq!(srgb8(v), srgb8_formula(v), "{v:e}");
        }
    }
}
