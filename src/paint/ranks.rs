//! Luminance ranks: the painted pixels' luminances as sortable keys and their histograms, and
//! the rank mappings (contrast-limited quantiles, tables) the palette and quantisation read.

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

/// The quantile of every key: the middle of the key's share of the contrast-limited
/// histogram. Non-decreasing in the key, and Lipschitz: neighbouring keys' quantiles differ
/// by at most (`limit` + 1) / `histogram.len()` (the clip bounds each key's count at `limit`
/// x the uniform height, the spread excess adds at most the uniform height, and the clipped
/// histogram still sums to the pixel count), on any image.
pub fn rank_quantiles(histogram: &[u32], total: u64, limit: f64) -> Vec<f64> {
    let hist = clipped_histogram(histogram, total, limit);
    let n: f64 = hist.iter().sum();
    let mut before = 0.0f64;
    hist.iter()
        .map(|&h| {
            let q = if n > 0.0 { (before + h * 0.5) / n } else { 0.0 };
            before += h;
            q
        })
        .collect()
}

/// The level index (of `levels` levels) of every key present in `histogram`: its
/// `rank_quantiles` quantile (0 for absent keys).
pub fn rank_table(histogram: &[u32], total: u64, limit: f64, levels: usize) -> Vec<u32> {
    rank_quantiles(histogram, total, limit)
        .iter()
        .zip(histogram)
        .map(|(q, &count)| if count > 0 { ((q * levels as f64) as usize).min(levels - 1) as u32 } else { 0 })
        .collect()
}

/// Share of the painted pixels at or below the luminance the keys' top stands for: the
/// brightest 1 / 1000 share the top key (see `StableKeys`).
pub const TOP_QUANTILE: f64 = 0.999;

/// The painted pixels' luminances as sortable keys, as `LuminanceKeys` (sqrt(L / L_top) in
/// 16 bits, monotone, ties shared), but scaled by a robust top: L_top is the luminance at
/// `TOP_QUANTILE` of the painted pixels (`luminance_quantile`), not the brightest pixel's,
/// and brighter pixels take the top key.
///
/// Why: the brightest pixel is one sample's worth of the picture (a
/// specular glint, a grazing normal brightened by chiaroscuro), and changes with the number
/// of samples; every key is divided by it, and the contrast-limited histogram spreads its
/// excess evenly over the keys, so the whole picture's mapping moved with that one pixel:
/// 4 and 64 spp renders of venus_11k differed by ~3/255 everywhere (36 dB). A quantile
/// moves only as much as the pixels around it do.
pub struct StableKeys {
    pub keys: Vec<u32>,
    pub histogram: Vec<u32>,
    /// Number of painted pixels.
    pub total: u64,
}

impl StableKeys {
    /// Keys of `lum` (negative = not painted).
    pub fn from_luminances(lum: &[f32]) -> StableKeys {
        let top = luminance_quantile(lum, TOP_QUANTILE);
        let scale = if top > 0.0 && top.is_finite() { 1.0 / top } else { 0.0 };
        let last = (KEY_LEVELS - 1) as f32;
        let key = |l: f32| if l < 0.0 { UNPAINTED } else { ((l * scale).min(1.0).sqrt() * last + 0.5) as u32 };
        // The keys and their histogram in one pass (`count`'s chunks).
        let mut keys = vec![0u32; lum.len()];
        let (histogram, total) = keys
            .par_chunks_mut(COUNT_CHUNK)
            .zip(lum.par_chunks(COUNT_CHUNK))
            .map(|(keys, lum)| {
                let mut c = vec![0u32; KEY_LEVELS];
                let mut n = 0u64;
                for (k, &l) in keys.iter_mut().zip(lum) {
                    *k = key(l);
                    if *k != UNPAINTED {
                        c[*k as usize] += 1;
                        n += 1;
                    }
                }
                (c, n)
            })
            .reduce(|| (vec![0u32; KEY_LEVELS], 0), add_counts);
        StableKeys { keys, histogram, total }
    }
}

/// Counts of `bucket(v)` over `values` (None = not counted) in `buckets` bins, and the number
/// counted: chunks counted in parallel and summed (integers: the same on any thread count).
fn count<T: Copy + Sync>(values: &[T], buckets: usize, bucket: impl Fn(T) -> Option<usize> + Sync) -> (Vec<u32>, u64) {
    values
        .par_chunks(COUNT_CHUNK)
        .map(|chunk| {
            let mut c = vec![0u32; buckets];
            let mut n = 0u64;
            for b in chunk.iter().filter_map(|&v| bucket(v)) {
                c[b] += 1;
                n += 1;
            }
            (c, n)
        })
        .reduce(|| (vec![0u32; buckets], 0), add_counts)
}

/// Values per chunk `count` counts alone.
const COUNT_CHUNK: usize = 1 << 17;

/// Two chunks' counts summed (`count`).
fn add_counts((mut a, na): (Vec<u32>, u64), (b, nb): (Vec<u32>, u64)) -> (Vec<u32>, u64) {
    a.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
    (a, na + nb)
}

/// The luminance at quantile `q` of the non-negative values of `lum` (negatives are left
/// out; 0 when there are none). Counted in 2^15 buckets of the float's bits (exponent and 7
/// mantissa bits: 1/128 relative width) and interpolated by count within the bucket, so it
/// is a continuous function of the values, the same on any thread count, in linear time.
pub fn luminance_quantile(lum: &[f32], q: f64) -> f32 {
    const SHIFT: u32 = 16;
    let (buckets, n) =
        count(lum, 1 << (31 - SHIFT), |l| (l >= 0.0 && l.is_finite()).then(|| (l.to_bits() >> SHIFT) as usize));
    if n == 0 {
        return 0.0;
    }
    let target = (q.clamp(0.0, 1.0) * n as f64).max(0.5);
    let mut before = 0.0f64;
    for (b, &c) in buckets.iter().enumerate() {
        let c = c as f64;
        if c > 0.0 && before + c >= target {
            let lo = f32::from_bits((b as u32) << SHIFT);
            let hi = f32::from_bits(((b as u32) + 1) << SHIFT);
            let t = ((target - before) / c).clamp(0.0, 1.0) as f32;
            return lo + (hi - lo) * t;
        }
        before += c;
    }
    f32::from_bits((buckets.len() as u32 - 1) << SHIFT)
}

/// Half-width, in keys, of each of the two box filters `clipped_histogram` smooths with
/// (a triangle reaching 2 x this far: 0.8% of the key range).
pub const SMOOTHING: usize = KEY_LEVELS / 256;

/// The histogram smoothed (`smooth_histogram`), clipped at `limit` x the uniform height and
/// the excess spread evenly over every key (one pass). An infinite limit returns the counts
/// as they are (plain ranks).
///
/// Why smoothed: a flat area is a spike of the histogram, and how much of
/// it the clip removes, spread over every key, depends on how wide the spike is. Sampling
/// noise widens or narrows spikes (a facet of one value at 64 spp spreads over a few keys at
/// 4), which moved the whole mapping. Clipping a histogram smoothed wider than that noise
/// removes about the same mass either way.
pub fn clipped_histogram(histogram: &[u32], total: u64, limit: f64) -> Vec<f64> {
    let cap = limit * total as f64 / histogram.len() as f64;
    if !cap.is_finite() {
        return histogram.iter().map(|&c| c as f64).collect();
    }
    let smooth = smooth_histogram(histogram, SMOOTHING);
    let excess: f64 = smooth.iter().map(|&c| (c - cap).max(0.0)).sum();
    let share = excess / histogram.len() as f64;
    smooth.iter().map(|&c| c.min(cap) + share).collect()
}

/// `histogram` filtered twice by a box of half-width `radius` (a triangle), reflected at the
/// ends so no count is lost: the result sums to the same total. Prefix sums in f64 over
/// integer counts, in a fixed order: the same on any thread count.
pub fn smooth_histogram(histogram: &[u32], radius: usize) -> Vec<f64> {
    let mut h: Vec<f64> = histogram.iter().map(|&c| c as f64).collect();
    let n = h.len();
    if n == 0 || radius == 0 {
        return h;
    }
    let r = radius.min(n - 1);
    for _ in 0..2 {
        // Reflected index of j in [-r, n + r): -1 - j below, 2n - 1 - j above.
        let at = |j: isize| -> usize {
            if j < 0 {
                (-1 - j) as usize
            } else if j >= n as isize {
                2 * n - 1 - j as usize
            } else {
                j as usize
            }
        };
        let mut prefix = Vec::with_capacity(n + 2 * r + 1);
        prefix.push(0.0f64);
        for j in -(r as isize)..(n + r) as isize {
            let last = *prefix.last().unwrap();
            prefix.push(last + h[at(j)]);
        }
        let width = (2 * r + 1) as f64;
        h = (0..n).map(|k| (prefix[k + 2 * r + 1] - prefix[k]) / width).collect();
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::paint::palette::{CONTRAST_LIMIT, LEVELS};
    use crate::util::rng::{splitmix64, unit_f64};

    /// Deterministic pseudo-random luminances in [lo, hi).
    fn luminances(n: usize, seed: u64, lo: f32, hi: f32) -> Vec<f32> {
        (0..n as u64).map(|i| lo + (hi - lo) * unit_f64(splitmix64(seed ^ splitmix64(i))) as f32).collect()
    }

    #[test]
    fn the_quantile_is_the_values_and_ignores_unpainted_pixels() {
        // 0.000, 0.001, ..., 0.999 in any order, with unpainted pixels mixed in.
        let mut lum: Vec<f32> = (0..1000).map(|i| i as f32 / 1000.0).collect();
        lum.reverse();
        lum.extend([-1.0; 50]);
        for q in [0.1, 0.5, 0.9, 0.999] {
            let got = luminance_quantile(&lum, q);
            assert!((got - q as f32).abs() < 0.01, "quantile {q}: {got}");
        }
        assert_eq!(luminance_quantile(&[-1.0, -2.0], 0.5), 0.0);
        assert_eq!(luminance_quantile(&[], 0.5), 0.0);
        assert!(luminance_quantile(&[0.0, 0.0, 0.0], 0.999) < 1e-30);
    }

    #[test]
    fn the_quantile_moves_continuously_with_one_value() {
        // Sliding one value across the others moves the quantile by no more than the
        // neighbouring values' spacing, never by a bucket's jump.
        let base = luminances(4000, 3, 0.2, 0.8);
        let mut last = luminance_quantile(&base, 0.5);
        for k in 1..=200 {
            let mut lum = base.clone();
            lum[7] = 0.3 + 0.4 * k as f32 / 200.0;
            let q = luminance_quantile(&lum, 0.5);
            assert!((q - last).abs() < 2e-3, "step {k}: {last} -> {q}");
            last = q;
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]
        /// The rank mapping is monotone and its slope bounded by (limit + 1) per key width,
        /// whatever the histogram (flat areas make spikes; empty ranges make gaps).
        #[test]
        fn rank_quantiles_are_monotone_with_bounded_slope(
            spikes in proptest::collection::vec((0usize..KEY_LEVELS, 1u32..200_000), 1..40),
            spread in 0u32..4,
            limit in proptest::prop_oneof![proptest::prelude::Just(CONTRAST_LIMIT), 1.0f64..16.0],
        ) {
            let mut hist = vec![0u32; KEY_LEVELS];
            for (k, c) in &spikes {
                hist[*k] += c;
                for d in 1..=spread as usize {
                    hist[(k + d * 97) % KEY_LEVELS] += c / 8;
                }
            }
            let total: u64 = hist.iter().map(|&c| c as u64).sum();
            let q = rank_quantiles(&hist, total, limit);
            let bound = (limit + 1.0) / KEY_LEVELS as f64 * (1.0 + 1e-9);
            for w in q.windows(2) {
                proptest::prop_assert!(w[1] >= w[0], "not monotone: {} then {}", w[0], w[1]);
                proptest::prop_assert!(w[1] - w[0] <= bound, "slope {} > {bound}", w[1] - w[0]);
            }
            proptest::prop_assert!(q[0] >= 0.0 && q[KEY_LEVELS - 1] <= 1.0);
            let table = rank_table(&hist, total, limit, LEVELS);
            let present: Vec<u32> = (0..KEY_LEVELS).filter(|&k| hist[k] > 0).map(|k| table[k]).collect();
            proptest::prop_assert!(present.windows(2).all(|w| w[0] <= w[1]));
        }
    }

    #[test]
    fn smoothing_keeps_every_count() {
        let mut hist = vec![0u32; 1000];
        hist[0] = 500;
        hist[3] = 7;
        hist[500] = 1000;
        hist[999] = 250;
        let s = smooth_histogram(&hist, 40);
        assert!((s.iter().sum::<f64>() - 1757.0).abs() < 1e-6);
        assert!(s.iter().all(|&c| c >= 0.0));
        // A triangle: the spike at 500 spreads symmetrically over 500 +- 80.
        assert!((s[490] - s[510]).abs() < 1e-9 && s[500] > s[520] && s[581] == 0.0);
        assert_eq!(smooth_histogram(&hist, 0), hist.iter().map(|&c| c as f64).collect::<Vec<_>>());
    }
}
