//! Exact Euclidean distance transform in linear time (Felzenszwalb and Huttenlocher, "Distance
//! transforms of sampled functions", 2012): the p_d of thesis eq 4.8 for every pixel at once,
//! instead of the thesis's per-pixel circle search, and the pixels within the neighbourhood
//! radius of a facet.
//!
//! Hand-written: it is two short passes, and the crates that have one (imageproc) would pull
//! a large dependency tree for a single-threaded f64 version; this one runs its rows on rayon.

use rayon::prelude::*;

/// Euclidean distance (between pixel centres) from every pixel to the nearest pixel where
/// `is_feature(index)` holds. Exact below `limit`; pixels at `limit` or farther get some value
/// not below it (`f32::INFINITY` when no feature is that close). Pass `f32::INFINITY` for the
/// full transform. Separable lower envelope of parabolas, O(width x height); the limit
/// only skips work (a feature closer than it is also closer than it along its column).
pub fn distance_to_features(
    width: u32,
    height: u32,
    limit: f32,
    is_feature: impl Fn(usize) -> bool + Sync,
) -> Vec<f32> {
    let (w, h) = (width as usize, height as usize);
    let mut g = column_distances(w, h, &is_feature);
    // Pass 2: per row, the lower envelope of the parabolas (x - q)^2 + g(q)^2, leaving out
    // columns whose nearest feature is `limit` or farther.
    g.par_chunks_mut(w).for_each_init(
        || (Vec::with_capacity(w), Vec::with_capacity(w + 1), Vec::with_capacity(w)),
        |(v, z, f): &mut (Vec<usize>, Vec<f64>, Vec<f64>), row| {
            if row.iter().all(|&d| d >= limit) {
                row.fill(f32::INFINITY);
                return;
            }
            f.clear();
            f.extend(row.iter().map(|&d| if d < limit { (d as f64) * (d as f64) } else { f64::INFINITY }));
            envelope(f, v, z, |x, d2, _| row[x] = d2.sqrt() as f32);
        },
    );
    g
}

/// Squared Euclidean distance from every pixel to the nearest pixel where `is_feature(index)`
/// holds, exact (integers in f64; infinite when there is no feature). For the neighbourhood
/// test `d^2 <= r^2` of the saliency centres, which must not round.
pub fn squared_distance_to_features(
    width: usize,
    height: usize,
    is_feature: impl Fn(usize) -> bool + Sync,
) -> Vec<f64> {
    let (w, h) = (width, height);
    let g = column_distances(w, h, &is_feature);
    let mut out = vec![f64::INFINITY; w * h];
    let (mut v, mut z, mut f) = (Vec::with_capacity(w), Vec::with_capacity(w + 1), Vec::with_capacity(w));
    for (row, col) in out.chunks_mut(w).zip(g.chunks(w)) {
        f.clear();
        f.extend(col.iter().map(|&d| (d as f64) * (d as f64)));
        envelope(&f, &mut v, &mut z, |x, d2, _| row[x] = d2);
    }
    out
}

/// Pass 1 of both transforms: per column, the distance to the nearest feature in that column
/// (two sweeps, row by row so the inner loop runs along memory); integers, exact in f32.
fn column_distances(w: usize, h: usize, is_feature: &(impl Fn(usize) -> bool + Sync)) -> Vec<f32> {
    let mut g = vec![f32::INFINITY; w * h];
    g.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, v) in row.iter_mut().enumerate() {
            if is_feature(y * w + x) {
                *v = 0.0;
            }
        }
    });
    for y in 1..h {
        let (above, rest) = g.split_at_mut(y * w);
        let prev = &above[(y - 1) * w..];
        for (v, p) in rest[..w].iter_mut().zip(prev) {
            *v = v.min(p + 1.0);
        }
    }
    for y in (0..h.saturating_sub(1)).rev() {
        let (head, below) = g.split_at_mut((y + 1) * w);
        let row = &mut head[y * w..];
        for (v, n) in row.iter_mut().zip(&below[..w]) {
            *v = v.min(n + 1.0);
        }
    }
    g
}

/// The 1-D squared distance transform of `f` (infinite = no parabola there): `put(x, d^2, q)`
/// for every x, q being the position whose parabola is lowest there. `v` and `z` are scratch
/// buffers.
fn envelope(f: &[f64], v: &mut Vec<usize>, z: &mut Vec<f64>, mut put: impl FnMut(usize, f64, usize)) {
    v.clear();
    z.clear();
    for (q, &fq) in f.iter().enumerate() {
        if !fq.is_finite() {
            continue;
        }
        // Drop parabolas that the new one hides everywhere to the right of their boundary.
        loop {
            match v.last() {
                None => {
                    v.push(q);
                    z.push(f64::NEG_INFINITY);
                    break;
                }
                Some(&p) => {
                    let qf = q as f64;
                    let pf = p as f64;
                    let s = ((fq + qf * qf) - (f[p] + pf * pf)) / (2.0 * (qf - pf));
                    if s <= *z.last().unwrap() {
                        v.pop();
                        z.pop();
                    } else {
                        v.push(q);
                        z.push(s);
                        break;
                    }
                }
            }
        }
    }
    if v.is_empty() {
        (0..f.len()).for_each(|x| put(x, f64::INFINITY, usize::MAX));
        return;
    }
    let mut k = 0;
    for x in 0..f.len() {
        let xf = x as f64;
        while k + 1 < v.len() && z[k + 1] < xf {
            k += 1;
        }
        let d = xf - v[k] as f64;
        put(x, d * d + f[v[k]], v[k]);
    }
}

/// A pixel with no feature within the limit of `nearest_features`.
pub const NO_FEATURE: u32 = u32::MAX;

/// The nearest feature of every pixel: its index (`NO_FEATURE` when none is closer than
/// `limit`) and the Euclidean distance to it (between pixel centres; infinite when none).
/// The same transform as `distance_to_features`, keeping which feature each parabola comes
/// from (a feature transform): the passage borders need the pixel across the border, not
/// only how far it is. Ties go to one of the nearest features, the same on any thread count.
pub fn nearest_features(
    width: u32,
    height: u32,
    limit: f32,
    is_feature: impl Fn(usize) -> bool + Sync,
) -> (Vec<f32>, Vec<u32>) {
    let (w, h) = (width as usize, height as usize);
    // Pass 1: per column, the row of the nearest feature in that column (two sweeps).
    let mut rows = vec![NO_FEATURE; w * h];
    rows.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, r) in row.iter_mut().enumerate() {
            if is_feature(y * w + x) {
                *r = y as u32;
            }
        }
    });
    let closer = |y: usize, a: u32, b: u32| -> u32 {
        // The nearer of two candidate rows for row y (NO_FEATURE loses; ties to a).
        match (a, b) {
            (NO_FEATURE, b) => b,
            (a, NO_FEATURE) => a,
            (a, b) => {
                if (y as i64 - b as i64).abs() < (y as i64 - a as i64).abs() {
                    b
                } else {
                    a
                }
            }
        }
    };
    for y in 1..h {
        let (above, rest) = rows.split_at_mut(y * w);
        let prev = &above[(y - 1) * w..];
        for (r, p) in rest[..w].iter_mut().zip(prev) {
            *r = closer(y, *r, *p);
        }
    }
    for y in (0..h.saturating_sub(1)).rev() {
        let (head, below) = rows.split_at_mut((y + 1) * w);
        let row = &mut head[y * w..];
        for (r, n) in row.iter_mut().zip(&below[..w]) {
            *r = closer(y, *r, *n);
        }
    }
    // Pass 2: per row, the lower envelope over the columns' nearest features.
    let mut dist = vec![f32::INFINITY; w * h];
    let mut index = vec![NO_FEATURE; w * h];
    let limit2 = (limit as f64) * (limit as f64);
    dist.par_chunks_mut(w).zip(index.par_chunks_mut(w)).enumerate().for_each_init(
        || (Vec::with_capacity(w), Vec::with_capacity(w + 1), Vec::with_capacity(w)),
        |(v, z, f): &mut (Vec<usize>, Vec<f64>, Vec<f64>), (y, (drow, irow))| {
            f.clear();
            f.extend(rows[y * w..(y + 1) * w].iter().map(|&r| {
                if r == NO_FEATURE {
                    f64::INFINITY
                } else {
                    let d = y as f64 - r as f64;
                    if d * d < limit2 { d * d } else { f64::INFINITY }
                }
            }));
            envelope(f, v, z, |x, d2, q| {
                if q != usize::MAX && d2 < limit2 {
                    drow[x] = d2.sqrt() as f32;
                    irow[x] = rows[y * w + q] * w as u32 + q as u32;
                }
            });
        },
    );
    (dist, index)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute(w: usize, h: usize, feat: &[bool]) -> Vec<f32> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let mut best = f64::INFINITY;
                for (j, &f) in feat.iter().enumerate() {
                    if f {
                        let (fx, fy) = ((j % w) as f64, (j / w) as f64);
                        best = best.min(((x - fx).powi(2) + (y - fy).powi(2)).sqrt());
                    }
                }
                best as f32
            })
            .collect()
    }

    #[test]
    fn single_point_gives_euclidean_distances() {
        let (w, h) = (7usize, 5usize);
        let d = distance_to_features(w as u32, h as u32, f32::INFINITY, |i| i == 2 * w + 3);
        assert_eq!(d[2 * w + 3], 0.0);
        assert_eq!(d[2 * w + 6], 3.0);
        assert!((d[0] - (9.0f32 + 4.0).sqrt()).abs() < 1e-6);
    }

    #[test]
    fn squared_distances_are_exact() {
        let (w, h) = (13, 9);
        let feats = [(2usize, 3usize), (10, 1), (7, 8)];
        let f = squared_distance_to_features(w, h, |i| feats.contains(&(i % w, i / w)));
        for y in 0..h {
            for x in 0..w {
                let want = feats
                    .iter()
                    .map(|&(fx, fy)| (x as f64 - fx as f64).powi(2) + (y as f64 - fy as f64).powi(2))
                    .fold(f64::INFINITY, f64::min);
                assert_eq!(f[y * w + x], want, "({x}, {y})");
            }
        }
        assert!(squared_distance_to_features(4, 3, |_| false).iter().all(|v| v.is_infinite()));
    }

    #[test]
    fn no_features_is_infinite() {
        let d = distance_to_features(4, 3, f32::INFINITY, |_| false);
        assert!(d.iter().all(|v| v.is_infinite()));
    }

    proptest! {
        #[test]
        fn nearest_features_are_nearest(w in 1usize..24, h in 1usize..24, bits in proptest::collection::vec(0u8..16, 576), limit in 0.5f32..30.0) {
            let feat: Vec<bool> = (0..w * h).map(|i| bits[i] == 0).collect();
            let b = brute(w, h, &feat);
            let (d, idx) = nearest_features(w as u32, h as u32, limit, |i| feat[i]);
            for i in 0..w * h {
                if b[i] < limit {
                    let j = idx[i] as usize;
                    prop_assert!(j < w * h && feat[j], "pixel {} points at {}", i, j);
                    let dj = (((i % w) as f32 - (j % w) as f32).powi(2) + ((i / w) as f32 - (j / w) as f32).powi(2)).sqrt();
                    prop_assert!((dj - b[i]).abs() < 1e-4 && (d[i] - b[i]).abs() < 1e-4, "pixel {}: {} / {} vs {}", i, dj, d[i], b[i]);
                } else {
                    prop_assert_eq!(idx[i], NO_FEATURE);
                    prop_assert!(d[i].is_infinite());
                }
            }
        }

        #[test]
        fn matches_brute_force(w in 1usize..24, h in 1usize..24, bits in proptest::collection::vec(0u8..16, 576), limit in 0.5f32..30.0) {
            let feat: Vec<bool> = (0..w * h).map(|i| bits[i] == 0).collect();
            let b = brute(w, h, &feat);
            let d = distance_to_features(w as u32, h as u32, f32::INFINITY, |i| feat[i]);
            let near = distance_to_features(w as u32, h as u32, limit, |i| feat[i]);
            let sq = squared_distance_to_features(w, h, |i| feat[i]);
            for (i, &d2) in sq.iter().enumerate() {
                let want = (0..w * h)
                    .filter(|&j| feat[j])
                    .map(|j| ((i % w) as f64 - (j % w) as f64).powi(2) + ((i / w) as f64 - (j / w) as f64).powi(2))
                    .fold(f64::INFINITY, f64::min);
                prop_assert_eq!(d2, want, "squared, pixel {}", i);
            }
            for i in 0..w * h {
                prop_assert!(d[i] == b[i] || (d[i] - b[i]).abs() < 1e-4, "pixel {} got {} want {}", i, d[i], b[i]);
                if b[i] < limit {
                    prop_assert!((near[i] - b[i]).abs() < 1e-4, "limited: pixel {} got {} want {}", i, near[i], b[i]);
                } else {
                    prop_assert!(near[i] >= limit - 1e-4, "limited: pixel {} got {} beyond {}", i, near[i], limit);
                }
            }
        }
    }
}
