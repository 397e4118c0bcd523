//! Facet centres (eq 4.4) and saliency centres (eq 4.5, corrected), the discontinuity limit
//! and the random imprecision baseline: where each facet is aimed, in pixel positions.

use glam::DVec2;
use rayon::prelude::*;

use crate::distance::squared_distance_to_features;
use crate::error::{Error, Result};
use crate::facets::{FacetMap, FacetPixels};
use crate::util::rng::rand01;

const RANDOM_STREAM: u64 = 0x7261_6e64_6f6d;

/// Rows per parallel work item of the per-pixel sums below.
const BAND_ROWS: usize = 64;

/// Eq 4.4: the mean pixel position of each facet (None for a facet with no pixel). Summed as
/// integers by bands of rows in parallel: the same bits as summing the f64 pixel centres in
/// any order (those sums are exact: halves well below 2^53).
pub fn facet_centres(map: &FacetMap) -> Vec<Option<DVec2>> {
    let n = map.facet_count as usize;
    let w = map.width.max(1) as usize;
    let zero = || vec![(0u64, 0u64, 0u64); n];
    let sum = map
        .ids
        .par_chunks(w * BAND_ROWS)
        .enumerate()
        .fold(zero, |mut sum, (b, band)| {
            for (r, row) in band.chunks(w).enumerate() {
                let y = (b * BAND_ROWS + r) as u64;
                for (x, &id) in row.iter().enumerate() {
                    let s = &mut sum[id as usize];
                    s.0 += x as u64;
                    s.1 += y;
                    s.2 += 1;
                }
            }
            sum
        })
        .reduce(zero, |mut a, b| {
            for (p, q) in a.iter_mut().zip(b) {
                (p.0, p.1, p.2) = (p.0 + q.0, p.1 + q.1, p.2 + q.2);
            }
            a
        });
    sum.iter()
        .map(|&(x, y, c)| {
            let (c, half) = (c as f64, 0.5 * c as f64);
            (c > 0.0).then(|| DVec2::new((x as f64 + half) / c, (y as f64 + half) / c))
        })
        .collect()
}

/// Eq 4.5, corrected: the saliency-weighted mean position of each facet's pixels plus,
/// when `neighborhood` > 0, every pixel within that distance (pixels) of the facet. The
/// thesis divides by |F|, which is not a centroid; we divide by the sum of the weights. A facet
/// with no saliency keeps sc = fc.
pub fn saliency_centres(
    map: &FacetMap,
    saliency: &[f32],
    fc: &[Option<DVec2>],
    neighborhood: f64,
) -> Vec<Option<DVec2>> {
    saliency_centres_with(map, &map.facet_pixels(), saliency, fc, neighborhood)
}

/// `saliency_centres` with the facets' pixels (`FacetMap::facet_pixels`) made already. Each
/// facet's sums run over its pixels in ascending order, facets in parallel: the same bits as
/// one pass over the image.
pub fn saliency_centres_with(
    map: &FacetMap,
    by_facet: &FacetPixels,
    saliency: &[f32],
    fc: &[Option<DVec2>],
    neighborhood: f64,
) -> Vec<Option<DVec2>> {
    let n = map.facet_count as usize;
    let w = map.width as usize;
    let weight = |i: usize| saliency.get(i).copied().filter(|s| s.is_finite() && *s > 0.0).unwrap_or(0.0) as f64;
    let sums: Vec<(f64, f64, f64)> = (0..n)
        .into_par_iter()
        .map(|f| {
            let own = by_facet.of(f);
            if neighborhood > 0.0 {
                return neighbourhood_sum(map, own, neighborhood, &weight);
            }
            let mut t = (0.0, 0.0, 0.0);
            for &i in own {
                let i = i as usize;
                let s = weight(i);
                if s > 0.0 {
                    t.0 += s * ((i % w) as f64 + 0.5);
                    t.1 += s * ((i / w) as f64 + 0.5);
                    t.2 += s;
                }
            }
            t
        })
        .collect();
    sums.iter().zip(fc).map(|(&(x, y, s), c)| c.map(|c| if s > 0.0 { DVec2::new(x / s, y / s) } else { c })).collect()
}

/// Most pixels the neighbourhood sums of `saliency_centres` may visit (about 10 s on 2 cores).
pub const NEIGHBOURHOOD_BUDGET: f64 = 1e9;

/// Pixels the neighbourhood sums visit: each facet's bounding box grown by `radius`, clipped to
/// the image. Tiny facets with a large neighbourhood cost (facets) x (image): 65536 facets
/// and 200 px at 1000 x 1000 would take an hour.
pub fn neighbourhood_work(map: &FacetMap, radius: f64) -> f64 {
    if radius <= 0.0 {
        return 0.0;
    }
    let (w, h) = (map.width as i64, map.height as i64);
    // Bounding boxes by rows in parallel, joined by min and max.
    let empty = vec![(i64::MAX, i64::MAX, i64::MIN, i64::MIN); map.facet_count as usize];
    let boxes = map
        .ids
        .par_chunks(map.width.max(1) as usize)
        .enumerate()
        .fold(
            || empty.clone(),
            |mut boxes, (y, row)| {
                for (x, &id) in row.iter().enumerate() {
                    let (x, y) = (x as i64, y as i64);
                    let b = &mut boxes[id as usize];
                    *b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y));
                }
                boxes
            },
        )
        .reduce_with(|mut a, b| {
            for (p, q) in a.iter_mut().zip(b) {
                *p = (p.0.min(q.0), p.1.min(q.1), p.2.max(q.2), p.3.max(q.3));
            }
            a
        })
        .unwrap_or(empty);
    let r = radius.ceil().min((w + h) as f64) as i64;
    boxes
        .iter()
        .filter(|b| b.0 <= b.2)
        .map(|&(x0, y0, x1, y1)| {
            let bw = (x1 + r).min(w - 1) - (x0 - r).max(0) + 1;
            let bh = (y1 + r).min(h - 1) - (y0 - r).max(0) + 1;
            bw as f64 * bh as f64
        })
        .sum()
}

/// A clear error instead of an hour-long computation when the neighbourhood sums would visit
/// more than `NEIGHBOURHOOD_BUDGET` pixels. `radius` in this image's pixels.
pub fn check_neighbourhood(map: &FacetMap, radius: f64) -> Result<()> {
    let work = neighbourhood_work(map, radius);
    if work > NEIGHBOURHOOD_BUDGET {
        return Err(Error::setting(
            "neighborhood",
            format!(
                "{radius:.0} px around each of {} facets means {work:.1e} pixel visits (budget {NEIGHBOURHOOD_BUDGET:.0e}): lower the neighborhood or use fewer facets",
                map.used_facets()
            ),
        ));
    }
    Ok(())
}

/// Weighted position sums over a facet's pixels and the pixels within `radius` of them: an
/// exact Euclidean distance transform of the facet over its bounding box grown by `radius`.
fn neighbourhood_sum(map: &FacetMap, own: &[u32], radius: f64, weight: &dyn Fn(usize) -> f64) -> (f64, f64, f64) {
    if own.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    let (w, h) = (map.width as i64, map.height as i64);
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    for &i in own {
        let (x, y) = (i as i64 % w, i as i64 / w);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    // No wider than the image: a huge radius must not overflow the box arithmetic.
    let r = radius.ceil().clamp(0.0, (w + h) as f64) as i64;
    let (x0, y0, x1, y1) = ((x0 - r).max(0), (y0 - r).max(0), (x1 + r).min(w - 1), (y1 + r).min(h - 1));
    let (bw, bh) = ((x1 - x0 + 1) as usize, (y1 - y0 + 1) as usize);
    let mut is_own = vec![false; bw * bh];
    for &i in own {
        let (x, y) = (i as i64 % w - x0, i as i64 / w - y0);
        is_own[y as usize * bw + x as usize] = true;
    }
    let dist = squared_distance_to_features(bw, bh, |i| is_own[i]);
    let r2 = radius * radius;
    let mut t = (0.0, 0.0, 0.0);
    for by in 0..bh {
        for bx in 0..bw {
            if dist[by * bw + bx] <= r2 {
                let (x, y) = (bx as i64 + x0, by as i64 + y0);
                let s = weight((y * w + x) as usize);
                t.0 += s * (x as f64 + 0.5);
                t.1 += s * (y as f64 + 0.5);
                t.2 += s;
            }
        }
    }
    t
}

/// The discontinuity limit: sc moved onto the circle of radius `radius` around fc when it is
/// farther than that.
pub fn limit_discontinuity(fc: DVec2, sc: DVec2, radius: f64) -> DVec2 {
    let v = sc - fc;
    let len = v.length();
    if len > radius { fc + v * (radius / len) } else { sc }
}

/// Random imprecision (User Study I's baseline): a point uniform in the disc of `radius`
/// around fc, seeded by (seed, facet).
pub fn random_centre(fc: DVec2, radius: f64, seed: u64, facet: u32) -> DVec2 {
    let r = radius * rand01(seed, RANDOM_STREAM, 2 * facet as u64).sqrt();
    let a = std::f64::consts::TAU * rand01(seed, RANDOM_STREAM, 2 * facet as u64 + 1);
    fc + DVec2::new(a.cos(), a.sin()) * r
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The neighbourhood work, its boxes made by rows in parallel, equals the one
    /// pass over the image.
    #[test]
    fn neighbourhood_work_matches_one_pass() {
        for (w, h, facets) in [(1u32, 1u32, 1u32), (97, 61, 7), (300, 170, 23), (16, 500, 5)] {
            let ids: Vec<u32> = (0..w * h).map(|i| ((i % w) * 5 / w + (i / w) * 3 / h * 5) % facets).collect();
            let m = FacetMap { width: w, height: h, ids, facet_count: facets + 2 };
            let n = m.facet_count as usize;
            let wu = w as usize;
            let mut boxes = vec![(i64::MAX, i64::MAX, i64::MIN, i64::MIN); n];
            for (i, &id) in m.ids.iter().enumerate() {
                let (x, y) = ((i % wu) as i64, (i / wu) as i64);
                let b = &mut boxes[id as usize];
                *b = (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y));
            }
            let r = 9i64;
            let work: f64 = boxes
                .iter()
                .filter(|b| b.0 <= b.2)
                .map(|&(x0, y0, x1, y1)| {
                    let bw = (x1 + r).min(w as i64 - 1) - (x0 - r).max(0) + 1;
                    let bh = (y1 + r).min(h as i64 - 1) - (y0 - r).max(0) + 1;
                    bw as f64 * bh as f64
                })
                .sum();
            assert!(work > 0.0);
            assert_eq!(neighbourhood_work(&m, 9.0), work);
        }
    }

    use crate::facets::{FacetLayout, FacetPolygon};

    /// The centres in parallel (integer sums by bands of rows; saliency sums per facet) are
    /// the one serial pass's bits, on 1-3 threads: a large map of many bands, facets of every
    /// size, irregular saliency with zeros, NaN and negatives.
    #[test]
    fn parallel_centres_are_the_serial_passes_bits() {
        let (w, h) = (613u32, 389u32);
        let ids: Vec<u32> =
            (0..w * h).map(|i| if i % 11 == 0 { 2 } else { ((i % w) / 70 + 9 * ((i / w) / 60)) % 50 }).collect();
        let m = FacetMap { width: w, height: h, ids, facet_count: 53 };
        let s: Vec<f32> = (0..w * h)
            .map(|i| match i % 13 {
                0 => f32::NAN,
                1 => -0.5,
                2 | 3 => 0.0,
                k => ((i as f32 * 0.618).fract() + k as f32) / 7.0,
            })
            .collect();
        let (n, wu) = (m.facet_count as usize, w as usize);
        let (mut c, mut t) = (vec![(0.0f64, 0.0f64, 0u64); n], vec![(0.0f64, 0.0f64, 0.0f64); n]);
        for (i, &id) in m.ids.iter().enumerate() {
            let (x, y) = ((i % wu) as f64 + 0.5, (i / wu) as f64 + 0.5);
            let a = &mut c[id as usize];
            (a.0, a.1, a.2) = (a.0 + x, a.1 + y, a.2 + 1);
            let v = s[i];
            if v.is_finite() && v > 0.0 {
                let (v, b) = (v as f64, &mut t[id as usize]);
                (b.0, b.1, b.2) = (b.0 + v * x, b.1 + v * y, b.2 + v);
            }
        }
        let fc: Vec<Option<DVec2>> =
            c.iter().map(|&(x, y, k)| (k > 0).then(|| DVec2::new(x / k as f64, y / k as f64))).collect();
        let sc: Vec<Option<DVec2>> = t
            .iter()
            .zip(&fc)
            .map(|(&(x, y, v), c)| c.map(|c| if v > 0.0 { DVec2::new(x / v, y / v) } else { c }))
            .collect();
        assert!(fc[51].is_none() && fc[2].is_some());
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let (got_fc, got_sc) = pool.install(|| {
                let got = facet_centres(&m);
                let sc = saliency_centres(&m, &s, &got, 0.0);
                (got, sc)
            });
            assert_eq!(got_fc, fc, "{threads} threads");
            assert_eq!(got_sc, sc, "{threads} threads");
        }
    }

    fn map_of(ids: Vec<u32>, width: u32, facet_count: u32) -> FacetMap {
        let height = ids.len() as u32 / width;
        FacetMap { width, height, ids, facet_count }
    }

    #[test]
    fn eq_4_4_facet_centre_is_the_mean_pixel_position() {
        // 4x2: facet 0 = left column pair, facet 1 = the rest, facet 2 empty.
        let m = map_of(vec![0, 1, 1, 1, 0, 1, 1, 1], 4, 3);
        let fc = facet_centres(&m);
        assert_eq!(fc[0], Some(DVec2::new(0.5, 1.0)));
        assert_eq!(fc[1], Some(DVec2::new(2.5, 1.0)));
        assert_eq!(fc[2], None);
    }

    #[test]
    fn eq_4_5_divides_by_the_weights_and_zero_saliency_keeps_fc() {
        let m = map_of(vec![0, 0, 0, 1, 1, 1], 3, 2);
        // Facet 0: saliency only on its rightmost pixel -> sc is that pixel's centre (the
        // thesis's /|F| would give a point a third of the way there). Facet 1: none.
        let s = vec![0.0, 0.0, 0.6, 0.0, 0.0, 0.0];
        let fc = facet_centres(&m);
        let sc = saliency_centres(&m, &s, &fc, 0.0);
        assert_eq!(sc[0], Some(DVec2::new(2.5, 0.5)));
        assert_eq!(sc[1], fc[1]);
        // NaN or negative saliency counts as none.
        let s = vec![f32::NAN, -1.0, 0.0, 0.0, 0.0, 0.0];
        assert_eq!(saliency_centres(&m, &s, &fc, 0.0), fc);
    }

    #[test]
    fn neighbourhood_counts_pixels_outside_the_facet() {
        // 9x1: facet 0 = pixels 0..3, facet 1 = 3..9; saliency only at pixel 5.
        let m = map_of(vec![0, 0, 0, 1, 1, 1, 1, 1, 1], 9, 2);
        let mut s = vec![0.0; 9];
        s[5] = 1.0;
        let fc = facet_centres(&m);
        // Pixel 5 is 3 px from facet 0's last pixel (2): a neighbourhood of 2 misses it, 3 reaches it.
        assert_eq!(saliency_centres(&m, &s, &fc, 2.0)[0], fc[0]);
        assert_eq!(saliency_centres(&m, &s, &fc, 3.0)[0], Some(DVec2::new(5.5, 0.5)));
        assert_eq!(saliency_centres(&m, &s, &fc, 3.0)[1], Some(DVec2::new(5.5, 0.5)));
    }

    #[test]
    fn one_pixel_facets() {
        let m = map_of(vec![0, 1, 2, 3], 2, 4);
        let fc = facet_centres(&m);
        let sc = saliency_centres(&m, &[1.0, 0.0, 0.5, 1.0], &fc, 0.0);
        assert_eq!(fc[3], Some(DVec2::new(1.5, 1.5)));
        assert_eq!(sc, fc, "a one-pixel facet's saliency centre is its own centre");
    }

    #[test]
    fn facet_centre_outside_a_non_convex_facet() {
        // A ring: its centre is in the hole, owned by another facet; the centres are still
        // well defined, and the saliency centre is pulled towards the salient side.
        let ring = FacetPolygon {
            facet: 1,
            points: vec![
                [0.1, 0.1],
                [0.9, 0.1],
                [0.9, 0.9],
                [0.1, 0.9],
                [0.1, 0.1],
                [0.3, 0.3],
                [0.3, 0.7],
                [0.7, 0.7],
                [0.7, 0.3],
                [0.3, 0.3],
            ],
        };
        let l = FacetLayout { facet_count: 2, base: None, sites: vec![[0.5, 0.5]], polygons: vec![ring] };
        let m = l.rasterize(20, 20);
        let fc = facet_centres(&m);
        let c1 = fc[1].unwrap();
        assert!((c1 - DVec2::splat(10.0)).length() < 1e-9, "{c1}");
        assert_eq!(m.ids[10 * 20 + 10], 0, "the ring's centre belongs to the hole's facet");
        let s: Vec<f32> = (0..400).map(|i| if i % 20 < 5 { 1.0 } else { 0.0 }).collect();
        let sc = saliency_centres(&m, &s, &fc, 0.0)[1].unwrap();
        assert!(sc.x < 4.0 && (sc.y - 10.0).abs() < 1e-9, "{sc}");
    }

    #[test]
    fn discontinuity_limit_moves_sc_onto_the_circle() {
        let fc = DVec2::new(10.0, 10.0);
        assert_eq!(limit_discontinuity(fc, DVec2::new(13.0, 14.0), 10.0), DVec2::new(13.0, 14.0));
        let l = limit_discontinuity(fc, DVec2::new(40.0, 50.0), 10.0);
        assert!((l - DVec2::new(16.0, 18.0)).length() < 1e-12);
        assert_eq!(limit_discontinuity(fc, DVec2::new(40.0, 50.0), 0.0), fc);
    }

    #[test]
    fn random_centres_are_seeded_and_uniform_in_the_disc() {
        let fc = DVec2::new(0.0, 0.0);
        let pts: Vec<DVec2> = (0..20000).map(|f| random_centre(fc, 2.0, 9, f)).collect();
        assert!(pts.iter().all(|p| p.length() <= 2.0));
        assert_eq!(random_centre(fc, 2.0, 9, 5), pts[5]);
        assert_ne!(random_centre(fc, 2.0, 10, 5), pts[5]);
        // Uniform in area: a quarter of the points within half the radius.
        let inner = pts.iter().filter(|p| p.length() < 1.0).count() as f64 / pts.len() as f64;
        assert!((inner - 0.25).abs() < 0.02, "{inner}");
        let right = pts.iter().filter(|p| p.x > 0.0).count() as f64 / pts.len() as f64;
        assert!((right - 0.5).abs() < 0.02, "{right}");
    }
}
