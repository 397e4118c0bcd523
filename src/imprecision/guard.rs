//! The guard on what a facet may show: background facets keep the backdrop (no ghosts),
//! and a re-aimed facet's view shift stays within its own width (cues kept).
//!
//! The thesis re-aims every facet at its saliency centre. A facet that shows mostly backdrop
//! has its saliency centre on the little geometry it touches (or none), so its rays turn
//! towards the subject and the whole facet fills with a smooth, unfaceted, magnified copy of it:
//! a ghost, up to 40% of the canvas with large Segment leftovers. The painters' backgrounds are
//! planes of the backdrop, each with its own light, meeting the figure in passage; they are not
//! second, enlarged views of the figure. So a facet is re-aimed only when at least
//! `aim_min_coverage` of its pixels showed geometry in the pre-render: background facets keep
//! the backdrop as the pre-render saw it (its planes are read from their borders and, with the
//! painterly stage, their own light), and the subject's facets are re-aimed as the thesis says.
//! With the planes faceting, whose facets are cut along the subject's outlines, almost every
//! facet is all subject or all backdrop, so the rule rarely has to weigh a mixed one.

use glam::DVec2;
use rayon::prelude::*;

use super::cues::CueVertices;
use super::{AimContext, AimParams, FacetAim, FacetProjection};
use crate::facets::{FacetMap, FacetPixels};
use crate::film::Film;
use crate::util::grid::Grid;

/// Each facet's share of pixel coverage (the fraction of samples that hit geometry, averaged
/// over its pixels) in the pre-render whose per-pixel coverage is `coverage`. Facets in
/// parallel, each summed over its pixels in ascending order (`by_facet`): one serial pass's bits.
pub fn facet_coverage(by_facet: &FacetPixels, coverage: impl Fn(usize) -> f32 + Sync) -> Vec<f64> {
    (0..by_facet.facet_count())
        .into_par_iter()
        .map(|f| {
            let own = by_facet.of(f);
            let c: f64 = own.iter().fold(0.0, |c, &i| c + coverage(i as usize).clamp(0.0, 1.0) as f64);
            if own.is_empty() { 0.0 } else { c / own.len() as f64 }
        })
        .collect()
}

/// Undoes the re-aim of every facet whose pre-render coverage is below `min_coverage`; returns
/// how many facets were held. `min_coverage` 0 holds none (the thesis's behaviour).
pub fn hold_background(aims: &mut [FacetAim], coverage: &[f64], min_coverage: f64) -> usize {
    if min_coverage <= 0.0 {
        return 0;
    }
    let mut held = 0;
    for (aim, &c) in aims.iter_mut().zip(coverage) {
        if c < min_coverage && aim.moved() {
            aim.reaim = None;
            aim.linear = None;
            aim.sc = aim.fc;
            aim.target = None;
            held += 1;
        }
    }
    held
}

/// Each facet's mean width, pixels: twice its area over its perimeter (pixel edges facing
/// another facet or the image's edge); 0 for a facet with no pixel. Counted by bands of rows
/// in parallel (integers: the same on any thread count).
pub fn facet_widths(map: &FacetMap) -> Vec<f64> {
    const BAND_ROWS: usize = 64;
    let (w, h) = (map.width as usize, map.height as usize);
    let n = map.facet_count as usize;
    let grid = Grid::new(map.width, map.height);
    let zero = || (vec![0u64; n], vec![0u64; n]);
    let (area, perimeter) = (0..h.div_ceil(BAND_ROWS))
        .into_par_iter()
        .fold(zero, |(mut area, mut perimeter), b| {
            for i in b * BAND_ROWS * w..((b + 1) * BAND_ROWS).min(h) * w {
                let id = map.ids[i];
                area[id as usize] += 1;
                // A side on the image's edge counts as on another facet.
                perimeter[id as usize] += 4 - grid.neighbours4(i).filter(|&j| map.ids[j] == id).count() as u64;
            }
            (area, perimeter)
        })
        .reduce(zero, |(mut a, mut p), (b, q)| {
            a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
            p.iter_mut().zip(q).for_each(|(x, y)| *x += y);
            (a, p)
        });
    area.iter().zip(&perimeter).map(|(&a, &p)| if p > 0 { 2.0 * a as f64 / p as f64 } else { 0.0 }).collect()
}

/// Keeps each re-aimed facet's view shift within `share` of its mean width: the aim point sc
/// moves back towards fc until |sc - fc| <= share x width, and the facet is re-aimed again.
/// Why: a thin plane (an arm, a guitar's neck, a finger) re-aimed by more than its width shows
/// the ground beside the part instead of the part, and the cue is lost. A
/// shift within a fraction of the plane keeps what the plane showed recognisably its own.
pub fn limit_shift(aims: &mut [FacetAim], widths: &[f64], share: f64, ctx: &AimContext) {
    if share <= 0.0 {
        return;
    }
    // Each facet on its own (a re-aim traces a ray): in parallel.
    aims.par_iter_mut().zip(widths).for_each(|(aim, &width)| {
        let (Some(fc), Some(sc)) = (aim.fc, aim.sc) else { return };
        if aim.reaim.is_none() {
            return;
        }
        let limit = share * width;
        let d = (sc - fc).length();
        if d <= limit {
            return;
        }
        super::cues::reaim_at(aim, ctx, fc, fc + (sc - fc) * (limit / d));
    });
}

/// Share of the pixels showing geometry `keep_cues` guards (the top of the pre-render's
/// saliency map): wider than the "top 5% of mesh saliency", since a top vertex
/// is seen through the pixels of all its triangles, whose interpolated saliency is lower.
pub const CUE_PIXEL_SHARE: f64 = 0.15;

/// Shrinks a re-aimed facet's view shift (by halves, then none) until every one of its
/// most salient pixels stays in view: a re-aimed facet shows at pixel p what the pre-render
/// showed near p + (sc - fc), so a salient pixel q of the facet stays shown only when
/// q - (sc - fc) still lies in the facet. Why: a cue at a plane's edge (an eye, a beak, the
/// tip of an ear) shifted out of its plane is lost (the most salient vertices
/// shown at least as often as in the unfaceted render). The salient pixels are the top
/// `CUE_PIXEL_SHARE` of `saliency` over the pixels that show geometry.
/// `by_facet`: the facets' pixels (`FacetMap::facet_pixels`).
pub fn keep_cues(aims: &mut [FacetAim], ctx: &AimContext, map: &FacetMap, by_facet: &FacetPixels, saliency: &[f32]) {
    let Some(threshold) = cue_threshold(saliency).filter(|_| saliency.len() == map.ids.len()) else { return };
    // Each facet on its own: in parallel.
    aims.par_iter_mut().enumerate().for_each(|(f, aim)| {
        let (Some(fc), Some(sc)) = (aim.fc, aim.sc) else { return };
        if aim.reaim.is_none() {
            return;
        }
        let salient: Vec<u32> = by_facet.of(f).iter().copied().filter(|&i| saliency[i as usize] >= threshold).collect();
        let scale = shift_scale_keeping(map, &salient, f, sc - fc);
        if scale == 1.0 {
            return;
        }
        super::cues::reaim_at(aim, ctx, fc, fc + (sc - fc) * scale);
    });
}

/// The saliency of the least salient cue pixel: the top `CUE_PIXEL_SHARE` of `saliency` over
/// the pixels that show geometry. None when no pixel is salient.
pub fn cue_threshold(saliency: &[f32]) -> Option<f32> {
    // (The k-th smallest value is the same whatever order the values are gathered in.)
    let mut values: Vec<f32> = saliency.par_iter().copied().filter(|&v| v > 0.0).collect();
    if values.is_empty() {
        return None;
    }
    let k = ((values.len() as f64 * (1.0 - CUE_PIXEL_SHARE)) as usize).min(values.len() - 1);
    let (_, &mut threshold, _) = values.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    Some(threshold)
}

/// The largest of 1, 1/2, 1/4 (else 0) such that facet `f`'s view shifted by that much of
/// `shift` keeps every pixel of `salient` (pixel indices of `f`) in view: q - shift in `f`.
pub fn shift_scale_keeping(map: &FacetMap, salient: &[u32], f: usize, shift: DVec2) -> f64 {
    let (w, h) = (map.width as usize, map.height as usize);
    let keeps = |shift: DVec2| {
        salient.iter().all(|&i| {
            let q = DVec2::new((i as usize % w) as f64 + 0.5, (i as usize / w) as f64 + 0.5) - shift;
            q.x >= 0.0
                && q.y >= 0.0
                && (q.x as usize) < w
                && (q.y as usize) < h
                && map.ids[q.y as usize * w + q.x as usize] as usize == f
        })
    };
    [1.0, 0.5, 0.25].into_iter().find(|&t| keeps(shift * t)).unwrap_or(0.0)
}

/// The rules, as `params` set them, on the aims `aim_facets` decided from the pre-render
/// `film` (its coverage, saliency map and samples): background held, shifts within the facet's
/// width, salient pixels kept in view, and (with `cues`, the most salient vertices) every such
/// vertex the pre-render showed still shown (`cues::keep_cue_vertices`). Returns the centre
/// hits the cue check traced through the aims kept, for the re-trace (`cues::CentreHits`).
pub fn apply(
    aims: &mut [FacetAim],
    ctx: &AimContext,
    map: &FacetMap,
    by_facet: &FacetPixels,
    film: &Film,
    cues: Option<&CueVertices>,
    params: &AimParams,
) -> Option<super::cues::CentreHits> {
    if params.min_coverage > 0.0 {
        let c = facet_coverage(by_facet, |i| film.color[i].w);
        hold_background(aims, &c, params.min_coverage);
    }
    if params.width_share > 0.0 && params.projection == FacetProjection::Converging {
        limit_shift(aims, &facet_widths(map), params.width_share, ctx);
        // Only when re-aiming reads the saliency map anyway (what the aims depend on stays
        // what `reads_saliency` says: the session's stage cache keys on it).
        if let Some(s) = film.saliency.as_deref().filter(|_| params.reads_saliency()) {
            keep_cues(aims, ctx, map, by_facet, s);
            if let Some(c) = cues {
                return super::cues::keep_cue_vertices_traced(aims, ctx, map, by_facet, film, c).1;
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};

    use crate::imprecision::Reaim;

    #[test]
    fn background_facets_keep_their_view() {
        // Facet 0: all background; facet 1: 3 of 4 pixels on geometry.
        let map = FacetMap { width: 4, height: 2, ids: vec![0, 0, 1, 1, 0, 0, 1, 1], facet_count: 2 };
        let cov = [0.0, 0.0, 1.0, 1.0, 0.0, 0.2, 1.0, 0.0];
        let c = facet_coverage(&map.facet_pixels(), |i| cov[i]);
        assert!((c[0] - 0.05).abs() < 1e-6 && (c[1] - 0.75).abs() < 1e-6, "{c:?}");
        let moved = FacetAim {
            fc: Some(DVec2::ONE),
            sc_raw: Some(DVec2::ZERO),
            sc: Some(DVec2::ZERO),
            target: Some(DVec3::ZERO),
            reaim: Some(Reaim { turn: DVec3::X * 0.1, focus: 1.0 }),
            linear: None,
            turn: None,
        };
        let mut aims = vec![moved, moved];
        assert_eq!(hold_background(&mut aims.clone(), &c, 0.0), 0);
        assert_eq!(hold_background(&mut aims, &c, 0.5), 1);
        assert!(!aims[0].moved() && aims[0].sc == aims[0].fc);
        assert!(aims[1].moved());
    }

    #[test]
    fn a_salient_pixel_at_a_facets_edge_limits_its_shift() {
        // Facet 0 = pixels 0-3 of one row, facet 1 = pixels 4-7. A facet shifted by s shows
        // at p what lay at p + s: salient pixel 2 (centre 2.5) stays shown while 2.5 - s.x
        // lies in facet 0.
        let map = FacetMap { width: 8, height: 1, ids: vec![0, 0, 0, 0, 1, 1, 1, 1], facet_count: 2 };
        // s = -2: 4.5 is in facet 1; half of it, 3.5, is in facet 0.
        assert_eq!(shift_scale_keeping(&map, &[2], 0, DVec2::new(-2.0, 0.0)), 0.5);
        // s = -6: 8.5, 5.5 out; a quarter, 4.0, still out (pixel 4): none.
        assert_eq!(shift_scale_keeping(&map, &[2], 0, DVec2::new(-6.0, 0.0)), 0.0);
        // s = +2: 0.5, in facet 0: the whole shift.
        assert_eq!(shift_scale_keeping(&map, &[2], 0, DVec2::new(2.0, 0.0)), 1.0);
        // Out of the image: no shift at all.
        assert_eq!(shift_scale_keeping(&map, &[0], 0, DVec2::new(8.0, 0.0)), 0.0);
        assert_eq!(shift_scale_keeping(&map, &[1, 2], 0, DVec2::new(1.0, 0.0)), 1.0);
        // No salient pixel: any shift.
        assert_eq!(shift_scale_keeping(&map, &[], 0, DVec2::new(-9.0, 0.0)), 1.0);
    }
}
