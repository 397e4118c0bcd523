//! The look report ("What we measure"): one render per scene,
//! measured from the render and its buffers, a row per scene, and contact sheets to look at
//! side by side. `pipeline::look` renders and calls `measure`; `cubist look` runs it;
//! `scripts/look-report.sh` runs it over the shared scenes, before (the `thesis` preset, the
//! look of the paper) and after (the default), into docs/look/.
//!
//! The measures, defined once here (see `measures` for the exact computations):
//! - straight: the share of facet-boundary length on straight runs at least 1% of the image
//!   diagonal long, after simplifying each boundary chain (between junctions) at 1 px;
//! - planes: the share of the canvas covered by polygonal facets (Segment's leftover level-1
//!   segments, which keep their pixel outline, do not count); largest: the largest facet's
//!   share of the canvas;
//! - fill: the share of the canvas showing geometry in the pre-render (mean sample
//!   coverage); bbox: the share taken by the bounding box of the pixels more than half covered;
//! - ghost: the share of the canvas that shows geometry in the final image where the
//!   pre-render showed background, within facets whose view was re-aimed;
//! - cues: of the most salient vertices (the top 5% of mesh saliency over the vertices of the
//!   meshes in view), how many the final image shows against how many the pre-render (the
//!   unfaceted render of the same camera) shows, as a ratio (>= 1: no cue lost); a vertex is
//!   shown when a primary sample hits a triangle it is a corner of;
//! - light: the share of facets (of at least 0.05% of the canvas) whose luminance varies
//!   across them by a gradient of at least 15% of the image's range (1st to 99th percentile):
//!   a least-squares plane over the facet spanning that much and explaining at least 30% of
//!   the facet's variance (a gradient, not noise);
//! - time: the render's wall time (all stages), and, with `time_size`, the median wall time of
//!   `time_runs` renders at that size (one process, noisy: a benchmark is the reference).

pub mod legibility;
pub mod measures;
pub mod odd;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use image::RgbaImage;
use serde::Serialize;

use crate::facets::{FacetLayout, FacetMap};
use crate::film::Film;
use crate::imprecision::cues::CueVertices;
use crate::scene::{Scene, World};

/// Minimum straight run, as a share of the image diagonal.
pub const RUN_SHARE: f64 = 0.01;
/// Boundary simplification tolerance, pixels.
pub const SIMPLIFY_PX: f64 = 1.0;
/// The most salient vertices: this top share of mesh saliency.
pub use crate::imprecision::cues::CUE_SHARE;
/// Per-plane light: the gradient's span, as a share of the image's luminance range.
pub const LIGHT_RANGE: f64 = 0.15;
/// Per-plane light: the share of a facet's variance its gradient must explain.
pub const LIGHT_R2: f64 = 0.3;
/// Per-plane light: facets smaller than this share of the canvas are not counted.
pub const LIGHT_MIN_SHARE: f64 = 0.0005;

/// One scene's measures.
#[derive(Clone, Debug, Serialize)]
pub struct LookRow {
    pub scene: String,
    /// The camera used (kind, angle, focal centre).
    pub camera: String,
    pub facets: usize,
    pub straight: f64,
    pub planes: f64,
    pub largest: f64,
    pub fill: f64,
    pub bbox: f64,
    pub ghost: f64,
    /// Top-salient vertices shown by the pre-render and by the final image.
    pub cues_pre: usize,
    pub cues_final: usize,
    /// cues_final / cues_pre (1 when the pre-render shows none).
    pub cues_kept: f64,
    pub light: f64,
    /// The subject's proportions against a parallel view of it (`legibility::stretch`; 1 = the
    /// same), None when one of them does not see it.
    pub stretch: Option<f64>,
    /// Median edge plane against median salient plane, by area (`legibility::hierarchy`).
    pub hierarchy: Option<f64>,
    /// Salient features kept whole in one plane, and how many there are.
    pub whole: f64,
    pub features: usize,
    /// The share of the subject's outline crossed by planes or opened by the paint.
    pub outline_broken: f64,
    /// Wall time of this render, milliseconds.
    pub time_ms: f64,
    /// Median wall time at the timing size, milliseconds, when asked.
    pub time_big_ms: Option<f64>,
}

/// What `measure` reads of one render.
pub struct Render<'a> {
    pub scene_name: &'a str,
    /// The camera used, in words.
    pub camera: &'a str,
    pub width: u32,
    pub height: u32,
    /// The pre-render (the unfaceted render of the same camera) and the final film.
    pub pre: &'a Film,
    pub fin: &'a Film,
    /// The final image, as written.
    pub image: &'a RgbaImage,
    pub layout: &'a FacetLayout,
    pub map: &'a FacetMap,
    /// Whether each facet's view was re-aimed.
    pub moved: &'a [bool],
    /// The scene and its per-mesh vertex saliency (`MeshSaliency::per_mesh`).
    pub scene: &'a Scene,
    pub world: &'a World,
    pub vertex_saliency: &'a [Option<Arc<Vec<f32>>>],
    /// Whether the saliency map holds the small parts (`SaliencyParams::reads_parts`): the cue
    /// vertices then count them too, as the imprecision stage does.
    pub parts: bool,
    /// The pre-render's per-pixel saliency map.
    pub saliency_map: &'a [f32],
    /// `legibility::stretch`, measured by the caller (it frames the camera and traces a probe).
    pub stretch: Option<f64>,
    pub time_ms: f64,
}

/// The measures of one render (see the module doc).
pub fn measure(r: &Render) -> LookRow {
    let (w, h) = (r.width, r.height);
    let diag = ((w as f64).powi(2) + (h as f64).powi(2)).sqrt();
    let (straight, _) = measures::straight_share(r.map, SIMPLIFY_PX, RUN_SHARE * diag);
    let planes = measures::plane_coverage(r.layout, w, h);
    let largest = measures::largest_facet(r.map);
    let pre_cov: Vec<f32> = r.pre.color.iter().map(|c| c.w).collect();
    let fin_cov: Vec<f32> = r.fin.color.iter().map(|c| c.w).collect();
    let (fill, bbox) = measures::subject_fill(&pre_cov, w, h);
    let ghost = measures::ghost_share(r.map, r.moved, &pre_cov, &fin_cov);
    let (cues_pre, cues_final) = cues(r.scene, r.world, r.vertex_saliency, r.parts, r.pre, r.fin);
    let lum: Vec<f32> = r
        .image
        .pixels()
        .map(|p| (0.2126 * p.0[0] as f32 + 0.7152 * p.0[1] as f32 + 0.0722 * p.0[2] as f32) / 255.0)
        .collect();
    let min_px = ((LIGHT_MIN_SHARE * (w as f64) * (h as f64)) as usize).max(16);
    let (light, _) = measures::plane_light(r.map, &lum, min_px, LIGHT_RANGE, LIGHT_R2);
    let subject: Vec<bool> = pre_cov.iter().map(|&c| c > 0.5).collect();
    let salient = legibility::salient_pixels(r.saliency_map, &subject);
    let features = legibility::features(&salient, w, h);
    LookRow {
        scene: r.scene_name.to_string(),
        camera: r.camera.to_string(),
        facets: r.map.used_facets(),
        straight,
        planes,
        largest,
        fill,
        bbox,
        ghost,
        cues_pre,
        cues_final,
        cues_kept: if cues_pre == 0 { 1.0 } else { cues_final as f64 / cues_pre as f64 },
        light,
        stretch: r.stretch,
        hierarchy: legibility::hierarchy(r.map, &salient),
        whole: legibility::features_whole(r.map, &features),
        features: features.len(),
        outline_broken: legibility::outline_broken(r.map, &subject, &lum),
        time_ms: r.time_ms,
        time_big_ms: None,
    }
}

/// (top-salient vertices shown by `pre`, by `fin`): see the module doc. The vertex set is the
/// one the imprecision stage keeps in view (`imprecision::cues`).
pub fn cues(
    scene: &Scene,
    world: &World,
    saliency: &[Option<Arc<Vec<f32>>>],
    parts: bool,
    pre: &Film,
    fin: &Film,
) -> (usize, usize) {
    match CueVertices::new(scene, world, saliency, parts) {
        Some(c) => (c.shown(pre), c.shown(fin)),
        None => (0, 0),
    }
}

/// The scene files under `paths`: files as given, directories' `.glb`/`.gltf` files (not
/// recursive), sorted by name.
pub fn scene_files(paths: &[PathBuf]) -> std::io::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut v: Vec<PathBuf> = std::fs::read_dir(p)?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| f.extension().is_some_and(|x| x == "glb" || x == "gltf"))
                .collect();
            v.sort();
            out.extend(v);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// A contact sheet: one row per scene, its pictures (e.g. before and after) side by side,
/// each scaled to `thumb_width`; `columns` scenes across.
pub fn contact_sheet(rows: &[Vec<&RgbaImage>], thumb_width: u32, columns: usize) -> RgbaImage {
    let per_scene = rows.iter().map(|r| r.len()).max().unwrap_or(1).max(1);
    let aspect =
        rows.iter().flat_map(|r| r.first()).map(|i| i.height() as f64 / i.width().max(1) as f64).next().unwrap_or(0.75);
    let th = ((thumb_width as f64 * aspect).round() as u32).max(1);
    let gap = 4;
    let columns = columns.max(1);
    let cell_w = per_scene as u32 * (thumb_width + gap) + 2 * gap;
    let lines = rows.len().div_ceil(columns) as u32;
    let mut sheet =
        RgbaImage::from_pixel(columns as u32 * cell_w, lines * (th + gap) + gap, image::Rgba([255, 255, 255, 255]));
    for (k, row) in rows.iter().enumerate() {
        let (cx, cy) = ((k % columns) as u32 * cell_w + gap, (k / columns) as u32 * (th + gap) + gap);
        for (j, img) in row.iter().enumerate() {
            let t = image::imageops::resize(*img, thumb_width, th, image::imageops::FilterType::Triangle);
            image::imageops::overlay(&mut sheet, &t, (cx + j as u32 * (thumb_width + gap)) as i64, cy as i64);
        }
    }
    sheet
}

/// A markdown table of rows (percentages), with the scene names in the order of the sheet.
pub fn markdown(rows: &[LookRow]) -> String {
    let pct = |v: f64| format!("{:.1}", 100.0 * v);
    let mut s = String::from(
        "| scene | facets | straight % | planes % | largest % | fill % | bbox % | ghost % | cues kept | light % | stretch | hierarchy | whole % (features) | outline broken % | ms | ms (timing size) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.2} ({}/{}) | {} | {} | {} | {} ({}) | {} | {:.0} | {} |\n",
            r.scene,
            r.facets,
            pct(r.straight),
            pct(r.planes),
            pct(r.largest),
            pct(r.fill),
            pct(r.bbox),
            pct(r.ghost),
            r.cues_kept,
            r.cues_final,
            r.cues_pre,
            pct(r.light),
            r.stretch.map_or("-".into(), |v| format!("{v:.2}")),
            r.hierarchy.map_or("-".into(), |v| format!("{v:.1}")),
            pct(r.whole),
            r.features,
            pct(r.outline_broken),
            r.time_ms,
            r.time_big_ms.map_or("-".into(), |t| format!("{t:.0}")),
        );
    }
    s
}

/// The display name of a scene path (its file name), or `still-life` for the built-in one.
pub fn scene_name(path: Option<&Path>) -> String {
    path.and_then(|p| p.file_name()).map_or_else(|| "still-life".into(), |n| n.to_string_lossy().into_owned())
}
