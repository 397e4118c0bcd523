//! Counter-based random numbers: every random choice of a render is a hash of (seed, what,
//! index), never a shared generator's state, so results do not depend on evaluation order or
//! thread count (same image on any thread count, any machine).

/// SplitMix64 (Steele, Lea and Flood 2014): a tiny, well-mixed hash used as a counter-based RNG.
#[inline]
pub fn splitmix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A uniform number in [0, 1) from a hash (its top 53 bits).
#[inline]
pub fn unit_f64(h: u64) -> f64 {
    (h >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A seeded uniform number in [0, 1) for (seed, stream, index): `stream` names the use (a
/// faceting method, the random imprecision), `index` the draw within it.
pub fn rand01(seed: u64, stream: u64, index: u64) -> f64 {
    unit_f64(splitmix64(splitmix64(seed ^ stream.wrapping_mul(0xA24B_AED4_963E_E407)) ^ splitmix64(index)))
}

/// The seed of one use of randomness (a painterly effect, say): the render's seed mixed with
/// the use's salt.
pub fn sub_seed(seed: u64, salt: u64) -> u64 {
    splitmix64(seed ^ splitmix64(salt))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_numbers_are_in_the_unit_interval_and_seeded() {
        for i in 0..1000 {
            let u = rand01(3, 7, i);
            assert!((0.0..1.0).contains(&u));
        }
        assert_eq!(rand01(3, 7, 5), rand01(3, 7, 5));
        assert_ne!(rand01(3, 7, 5), rand01(4, 7, 5));
        assert_ne!(rand01(3, 7, 5), rand01(3, 8, 5));
        assert_eq!(unit_f64(0), 0.0);
        assert!(unit_f64(u64::MAX) < 1.0);
    }
}
