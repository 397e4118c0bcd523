//! Segment faceting (Segment; thesis 4.3.1, Fig. 4.5): the pre-render is
//! segmented at several levels by normalized cuts, salient segments become quadrilateral
//! facets drawn in ascending saliency over the level-1 segments.
//!
//! The thesis used Cour, Benezit and Shi's multiscale Ncut on pixel colour and calls it slow.
//! Here: SLIC superpixels on colour *and* the ray tracer's exact geometric buffers (normal,
//! depth, object id, saliency) -> their region adjacency graph, whose normalized cut is the
//! pixel graph's restricted to superpixel unions (`graph`) -> one eigendecomposition shared by
//! all levels, Yu-Shi discretisation, then exactly N connected segments per level (`ncut`)
//! -> selection, quads and draw order (`select`). About 0.19 s of CPU for 1000 x 1000
//! (docs/segment.md; the thesis's pipeline was its slow step).

pub mod graph;
pub mod inspection;
pub mod ncut;
pub mod quality;
pub mod select;
pub mod superpixels;

use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::facets::{FacetLayout, LabelImage};
use crate::film::Film;
use crate::util::rng::splitmix64;

use graph::RegionGraph;
use ncut::Shortfall;
use select::{LevelInput, SegmentStats};
use superpixels::Features;

/// Weights of the cues in the segmentation's affinity (and in the superpixels' distance): the
/// squared feature distance is sum_k w_k (delta_k / scale_k)^2 with the scales of
/// `superpixels` (8 CIELAB units, 0.25 normal length, 5% relative depth, 0.1 saliency), and
/// two adjacent regions' affinity is exp(-distance) x (1 - object) across object boundaries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SegmentWeights {
    /// Pixel colour, the only cue the thesis had. Default 1.
    pub colour: f32,
    /// Surface orientation: facets follow the form. Default 1.
    pub normal: f32,
    /// Relative depth (ln t): self-occlusion edges on one object. Default 0.5.
    pub depth: f32,
    /// In [0, 1]: 0 ignores object ids; 1 is a hard wall (superpixels and segments never cross
    /// an object boundary, so a level with fewer segments than object pieces gets more than
    /// N). Default 0.9: object boundaries are 10x cheaper to cut, but a small object may share
    /// a large facet when N is small (level 1 has 5 segments; the still life has 12 objects).
    pub object: f32,
    /// Saliency differences: segments hug salient features, which the selection then keeps.
    /// Default 0.5.
    pub saliency: f32,
}

impl SegmentWeights {
    /// Whether objects separate superpixels (any positive object weight).
    pub fn separates_objects(&self) -> bool {
        self.object > 0.0
    }

    /// Whether object boundaries are hard walls for the segments.
    pub fn hard_objects(&self) -> bool {
        self.object >= 1.0
    }
}

/// The superpixel count used when `superpixels` is 0: about one per 600 pixels (1667 at
/// 1000 x 1000; see the benchmark's time-against-quality table), at least 6 per segment of
/// the finest level, at most one per 16 pixels.
pub fn auto_superpixels(width: u32, height: u32, max_segments: u32) -> usize {
    let pixels = width as usize * height as usize;
    let by_area = pixels / 600;
    by_area.max(6 * max_segments as usize).min(pixels / 16).max(1)
}

/// Most eigenvector work the normalized cut may take: superpixels x (largest level's
/// segments)^2. The embedding computes that many eigenvectors over the superpixel graph, in
/// time about proportional to this (1.25e9, 500 segments over 5000 superpixels, took two
/// minutes on two cores). The default 5,30,120 at 8192 x 8192 is 1.6e9.
pub const MAX_EIGEN_WORK: f64 = 4e9;

/// A clear error up front instead of an hour-long segmentation.
pub fn check_work(width: u32, height: u32, params: &SegmentParams) -> Result<()> {
    let max_n = params.segments.iter().copied().max().unwrap_or(1);
    let pixels = width as usize * height as usize;
    let superpixels = match params.superpixels {
        0 => auto_superpixels(width, height, max_n),
        k => k as usize,
    }
    .min(pixels);
    let work = superpixels as f64 * max_n as f64 * max_n as f64;
    if work > MAX_EIGEN_WORK {
        return Err(Error::setting(
            "segments",
            format!(
                "{max_n} segments over {superpixels} superpixels is {work:.1e} units of eigenvector work, more than \
                 the limit of {MAX_EIGEN_WORK:.0e} (hours): fewer segments, superpixels or pixels"
            ),
        ));
    }
    Ok(())
}

/// What the Segment faceting needs besides the pre-render.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentParams {
    /// Segments N per level, coarsest first.
    pub segments: Vec<u32>,
    /// Mean-saliency threshold per level, in [0, 1].
    pub thresholds: Vec<f64>,
    /// Superpixels the normalized cut groups; 0 = `auto_superpixels`.
    pub superpixels: u32,
    pub weights: SegmentWeights,
    pub seed: u64,
}

/// One segmentation level.
#[derive(Clone, Debug)]
pub struct SegmentLevel {
    /// N asked for.
    pub requested: u32,
    /// Segments made (N unless the image does not allow it; see `shortfall`).
    pub count: u32,
    pub threshold: f64,
    /// Segment per pixel at the pre-render's resolution.
    pub labels: LabelImage,
    pub stats: Vec<SegmentStats>,
    /// Whether each segment's mean saliency reached the threshold.
    pub selected: Vec<bool>,
    /// Each segment's quad in normalised coordinates (selected or not).
    pub quads: Vec<[[f64; 2]; 4]>,
    pub shortfall: Option<Shortfall>,
}

/// Everything the Segment faceting computed, for inspection (`--pass segments`) and benchmarks.
#[derive(Clone, Debug)]
pub struct SegmentLevels {
    pub superpixels: LabelImage,
    pub superpixel_count: usize,
    pub levels: Vec<SegmentLevel>,
    /// Step durations in order: features, superpixels, graph, eigenvectors, each level's
    /// cut, pixel labels and statistics ("ncut N"; levels run in parallel, so these overlap),
    /// the wall time of all levels ("levels (wall)"), selection.
    pub timings: Vec<(String, Duration)>,
    /// Levels that got another segment count than asked, said in words.
    pub warnings: Vec<String>,
}

/// The Segment faceting of a pre-render: the layout (base = level-1 segments, polygons = the
/// selected segments' quads in ascending mean saliency) and every level for inspection.
/// `film.saliency` None counts as zero saliency everywhere (only level 1, threshold 0,
/// is then selected). Deterministic for `params.seed` on any thread count.
pub fn layout(film: &Film, params: &SegmentParams) -> Result<(FacetLayout, SegmentLevels)> {
    let n = film.pixel_count();
    if film.width == 0 || film.height == 0 || film.color.len() != n || film.hits.len() != n {
        return Err(Error::Internal(format!(
            "segment faceting: the pre-render's buffers do not match its {}x{} size",
            film.width, film.height
        )));
    }
    if film.saliency.as_ref().is_some_and(|s| s.len() != n) {
        return Err(Error::Internal("segment faceting: the saliency map does not match the pre-render's size".into()));
    }
    if params.segments.is_empty() || params.segments.contains(&0) {
        return Err(Error::setting("segments", "needs one or more levels, each of at least 1 segment"));
    }
    if params.thresholds.len() != params.segments.len() {
        return Err(Error::setting(
            "thresholds",
            format!("{} thresholds given for {} segment levels", params.thresholds.len(), params.segments.len()),
        ));
    }
    let weights = params.weights;
    let max_n = *params.segments.iter().max().unwrap_or(&1);
    let want = match params.superpixels {
        0 => auto_superpixels(film.width, film.height, max_n),
        k => k as usize,
    }
    .min(n);
    let mut timings = Vec::new();
    let mut clock = Instant::now();
    let mut lap = |name: String, timings: &mut Vec<(String, Duration)>| {
        let now = Instant::now();
        timings.push((name, now - clock));
        clock = now;
    };

    let features = Features::new(film, &weights);
    lap("features".into(), &mut timings);
    let seed = splitmix64(params.seed ^ 0x005E_6EE7);
    let sp = superpixels::slic(&features, want, weights.separates_objects(), seed);
    lap("superpixels".into(), &mut timings);
    let graph = RegionGraph::build(&sp, &features, &weights);
    lap("graph".into(), &mut timings);
    let no_convergence =
        |_| Error::Internal("segment faceting: the eigensolver did not converge on this image's region graph".into());
    let embedding = ncut::embed(&graph, None, max_n as usize, seed).map_err(no_convergence)?;
    lap("eigenvectors".into(), &mut timings);

    let (w, h) = (film.width, film.height);
    // Levels are independent given the embedding: cut in parallel, collected in order.
    let level_specs: Vec<(usize, u32, f64)> =
        params.segments.iter().zip(&params.thresholds).enumerate().map(|(i, (&n, &t))| (i, n, t)).collect();
    let results: Vec<Result<(SegmentLevel, Duration)>> = level_specs
        .par_iter()
        .map(|&(li, requested, threshold)| {
            let t = Instant::now();
            let part =
                ncut::partition(&graph, &embedding, requested as usize, weights.hard_objects(), seed ^ li as u64)
                    .map_err(no_convergence)?;
            let labels = LabelImage {
                width: w,
                height: h,
                labels: sp.labels.iter().map(|&s| part.labels[s as usize]).collect(),
            };
            let stats = select::segment_stats(&labels, part.count, &features.saliency);
            let selected: Vec<bool> = stats.iter().map(|s| s.area > 0 && s.mean_saliency() >= threshold).collect();
            let quads = stats.iter().map(|s| s.quad(w, h)).collect();
            let level = SegmentLevel {
                requested,
                count: part.count as u32,
                threshold,
                labels,
                stats,
                selected,
                quads,
                shortfall: part.shortfall,
            };
            Ok((level, t.elapsed()))
        })
        .collect();
    let mut levels = Vec::new();
    let mut warnings = Vec::new();
    for (li, r) in results.into_iter().enumerate() {
        let (level, time) = r?;
        match level.shortfall {
            Some(Shortfall::TooFewRegions) => warnings.push(format!(
                "segment level {}: {} segments asked for but only {} superpixels (raise `superpixels`)",
                li + 1,
                level.requested,
                level.count
            )),
            Some(Shortfall::ObjectWalls) => warnings.push(format!(
                "segment level {}: {} segments asked for, {} made: with weight_object 1 no segment crosses an object boundary and the image has more object pieces",
                li + 1,
                level.requested,
                level.count
            )),
            None => {}
        }
        timings.push((format!("ncut {}", level.requested), time));
        levels.push(level);
    }
    lap("levels (wall)".into(), &mut timings);
    let inputs: Vec<LevelInput> =
        levels.iter().map(|l| LevelInput { labels: &l.labels, stats: &l.stats, threshold: l.threshold }).collect();
    let selection = select::select(&inputs);
    lap("selection".into(), &mut timings);
    let superpixels = LabelImage { width: w, height: h, labels: sp.labels };
    Ok((selection.layout, SegmentLevels { superpixels, superpixel_count: sp.count, levels, timings, warnings }))
}

#[cfg(test)]
mod tests;
