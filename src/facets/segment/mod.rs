//! Segment faceting (SPEC "Faceting", Segment; thesis 4.3.1, Fig. 4.5): the pre-render is
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

pub mod debug;
pub mod graph;
pub mod ncut;
pub mod quality;
pub mod select;
pub mod superpixels;

use std::time::{Duration, Instant};

use image::RgbaImage;

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::facets::{FacetLayout, LabelImage};
use crate::frame::Frame;
use crate::pipeline::Prepared;
use crate::progress::Progress;
use crate::render::splitmix64;
use crate::settings::{Faceting, Pass, Preset, Settings};

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

impl Default for SegmentWeights {
    fn default() -> Self {
        SegmentWeights::from_settings(&Settings::preset(crate::settings::Preset::Plain))
    }
}

impl SegmentWeights {
    pub fn from_settings(s: &Settings) -> SegmentWeights {
        SegmentWeights {
            colour: s.weight_colour as f32,
            normal: s.weight_normal as f32,
            depth: s.weight_depth as f32,
            object: s.weight_object as f32,
            saliency: s.weight_saliency as f32,
        }
    }

    /// Whether objects separate superpixels (any positive object weight).
    pub fn separates_objects(&self) -> bool {
        self.object > 0.0
    }

    /// Whether object boundaries are hard walls for the segments.
    pub fn hard_objects(&self) -> bool {
        self.object >= 1.0
    }
}

/// The superpixel count used when the settings say 0: about one per 600 pixels (1667 at
/// 1000 x 1000; see the benchmark's time-against-quality table), at least 6 per segment of
/// the finest level, at most one per 16 pixels.
pub fn auto_superpixels(width: u32, height: u32, max_segments: u32) -> usize {
    let pixels = width as usize * height as usize;
    let by_area = pixels / 600;
    by_area.max(6 * max_segments as usize).min(pixels / 16).max(1)
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
/// `frame.saliency` None counts as zero saliency everywhere (only level 1, threshold 0,
/// is then selected). Deterministic for `settings.seed` on any thread count.
pub fn layout(frame: &Frame, settings: &Settings) -> Result<(FacetLayout, SegmentLevels)> {
    let n = frame.pixel_count();
    if frame.width == 0 || frame.height == 0 || frame.color.len() != n || frame.hits.len() != n {
        return Err(Error::setting("width", "the pre-render's buffers do not match its size"));
    }
    if frame.saliency.as_ref().is_some_and(|s| s.len() != n) {
        return Err(Error::setting("faceting", "the saliency map does not match the pre-render's size"));
    }
    if settings.segments.is_empty() || settings.segments.contains(&0) {
        return Err(Error::setting("segments", "needs one or more levels, each of at least 1 segment"));
    }
    if settings.thresholds.len() != settings.segments.len() {
        return Err(Error::setting(
            "thresholds",
            format!("{} thresholds given for {} segment levels", settings.thresholds.len(), settings.segments.len()),
        ));
    }
    let weights = SegmentWeights::from_settings(settings);
    let max_n = *settings.segments.iter().max().unwrap_or(&1);
    let want = match settings.superpixels {
        0 => auto_superpixels(frame.width, frame.height, max_n),
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

    let features = Features::new(frame, &weights);
    lap("features".into(), &mut timings);
    let seed = splitmix64(settings.seed ^ 0x005E_6EE7);
    let sp = superpixels::slic(&features, want, weights.separates_objects(), seed);
    lap("superpixels".into(), &mut timings);
    let graph = RegionGraph::build(&sp, &features, &weights);
    lap("graph".into(), &mut timings);
    let no_convergence =
        |_| Error::setting("segments", "the eigensolver did not converge on this image's region graph");
    let embedding = ncut::embed(&graph, None, max_n as usize, seed).map_err(no_convergence)?;
    lap("eigenvectors".into(), &mut timings);

    let (w, h) = (frame.width, frame.height);
    // Levels are independent given the embedding: cut in parallel, collected in order.
    let level_specs: Vec<(usize, u32, f64)> =
        settings.segments.iter().zip(&settings.thresholds).enumerate().map(|(i, (&n, &t))| (i, n, t)).collect();
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

/// What `cubist facets` shows: the pre-render, the layout and the inspection images.
pub struct Inspection {
    /// The pre-render (Fig. 4.5 a).
    pub view: RgbaImage,
    /// (pass name, image): `layout` always; with `--pass segments` also `superpixels`,
    /// `level1`.. and the render's saliency pass; any other pass the settings ask for.
    pub images: Vec<(String, RgbaImage)>,
    pub layout: FacetLayout,
    pub levels: SegmentLevels,
    /// Pre-render stages, then "segment" for the whole faceting.
    pub timings: Vec<(String, Duration)>,
    pub warnings: Vec<String>,
}

/// Settings whose render stops where faceting would start: unfaceted, unpainted, with the
/// saliency map (its pass is added), so the render's frame is what the render pipeline's
/// faceting stage sees. Passes that need facets are dropped.
pub fn prerender_settings(settings: &Settings) -> Settings {
    let mut pre = settings.clone();
    pre.faceting = Faceting::None;
    (pre.facets, pre.save_facets) = (None, None);
    let plain = Settings::preset(Preset::Plain);
    pre.border_width = plain.border_width;
    pre.silhouette_width = plain.silhouette_width;
    pre.palette = plain.palette;
    pre.palette_image = None;
    pre.colors = plain.colors;
    pre.gradients = plain.gradients;
    pre.chiaroscuro = plain.chiaroscuro;
    pre.passes.retain(|p| !matches!(p, Pass::Segments | Pass::Facets | Pass::FacetIds));
    if !pre.passes.contains(&Pass::Saliency) {
        pre.passes.push(Pass::Saliency); // makes the pipeline compute the saliency map
    }
    pre
}

/// Pre-renders `settings`' view (`prerender_settings`), computes the Segment layout and its
/// inspection images.
pub fn inspect(prep: &Prepared, settings: &Settings, progress: &Progress) -> Result<Inspection> {
    let show_levels = settings.passes.contains(&Pass::Segments);
    let pre = prerender_settings(settings);
    let rendered = crate::render(prep, &pre, progress)?;
    progress.begin("segment", 1);
    let t = Instant::now();
    let (layout, levels) = layout(&rendered.frame, settings)?;
    let segment_time = t.elapsed();
    progress.finish();
    let mut images = Vec::new();
    for (pass, img) in &rendered.passes {
        if settings.passes.contains(pass) || (show_levels && *pass == Pass::Saliency) {
            images.push((pass.as_str().to_string(), img.clone()));
        }
    }
    if show_levels {
        images.extend(debug::images(&levels, &layout, &rendered.image));
    } else {
        images.push(("layout".into(), debug::layout_image(&layout, rendered.frame.width, rendered.frame.height)));
    }
    let mut timings: Vec<(String, Duration)> = rendered.timings.0.iter().map(|(n, d)| (n.to_string(), *d)).collect();
    timings.push(("segment".into(), segment_time));
    let mut warnings = rendered.warnings;
    warnings.extend(levels.warnings.iter().cloned());
    Ok(Inspection { view: rendered.image, images, layout, levels, timings, warnings })
}

#[cfg(test)]
mod tests;
