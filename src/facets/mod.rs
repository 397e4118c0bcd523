//! Facets: a facet layout is a resolution-independent description of how
//! the image splits into facets, rasterised to a facet id per pixel at any size, so one layout
//! can be saved once and reused for every frame of an animation on any machine.
//!
//! A layout is drawn in three layers, each over the previous:
//! 1. `base`: a label image scaled nearest-neighbour (Constant's facet map, Segment's level-1
//!    segments, or a layout loaded from a PNG);
//! 2. `sites`: Voronoi sites; a pixel belongs to the nearest site (in pixel distance);
//! 3. `polygons`: convex or not, drawn in order, later ones occluding earlier ones (Patch's
//!    quadrilaterals, Segment's fitted quads in ascending saliency).
//!
//! Pixels no layer covers (a thin sliver between quads rasterised at another size than the one
//! they were generated at) take the facet of the nearest covered pixel.

pub mod constant;
pub mod io;
pub mod motion;
pub mod patch;
pub mod planes;
pub mod segment;
pub mod voronoi;

use std::collections::VecDeque;
use std::path::PathBuf;

use glam::DVec2;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::film::Film;
use crate::util::grid::Grid;
use segment::SegmentParams;

/// Largest number of facets in a layout: ids fit the 16-bit `facet-ids` pass and PNG layouts.
pub const MAX_FACETS: u32 = 65536;
/// Largest base label image a layout file may hold: the largest image a render makes
/// (`settings::MAX_PIXELS`, checked equal in `pipeline::params`).
pub const MAX_BASE_PIXELS: u64 = 64 * 1024 * 1024;

/// A label raster, each value a facet id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LabelImage {
    pub width: u32,
    pub height: u32,
    pub labels: Vec<u32>,
}

/// A polygonal facet: vertices in normalised image coordinates ([0, 1]^2, x right, y down).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FacetPolygon {
    pub facet: u32,
    pub points: Vec<[f64; 2]>,
}

/// How an image splits into facets, independent of resolution.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct FacetLayout {
    /// Number of facets; every id used is below it.
    pub facet_count: u32,
    pub base: Option<LabelImage>,
    /// Voronoi sites in normalised coordinates; site i is facet i.
    pub sites: Vec<[f64; 2]>,
    /// Drawn in order over `base` and `sites`.
    pub polygons: Vec<FacetPolygon>,
}

/// A layout rasterised at one size: the facet id of every pixel (row 0 at the top).
#[derive(Clone, Debug, PartialEq)]
pub struct FacetMap {
    pub width: u32,
    pub height: u32,
    pub ids: Vec<u32>,
    pub facet_count: u32,
}

/// Marks a pixel no layer has covered yet during rasterisation.
const UNSET: u32 = u32::MAX;

impl FacetLayout {
    /// One facet covering the whole image (faceting `none`).
    pub fn single() -> FacetLayout {
        FacetLayout {
            facet_count: 1,
            base: None,
            sites: Vec::new(),
            polygons: vec![FacetPolygon { facet: 0, points: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] }],
        }
    }

    /// Checks the invariants every consumer relies on; the message says what is wrong.
    pub fn validate(&self) -> std::result::Result<(), String> {
        if self.facet_count == 0 || self.facet_count > MAX_FACETS {
            return Err(format!("facet count {} is outside 1..={MAX_FACETS}", self.facet_count));
        }
        if let Some(b) = &self.base {
            if b.width == 0 || b.height == 0 || b.labels.len() as u64 != b.width as u64 * b.height as u64 {
                return Err(format!("base label image {}x{} holds {} labels", b.width, b.height, b.labels.len()));
            }
            if let Some(l) = b.labels.iter().find(|&&l| l >= self.facet_count) {
                return Err(format!("base label {l} is not below the facet count {}", self.facet_count));
            }
        }
        if self.sites.len() > self.facet_count as usize {
            return Err(format!("{} Voronoi sites for {} facets", self.sites.len(), self.facet_count));
        }
        if self.sites.iter().flatten().any(|v| !v.is_finite()) {
            return Err("a Voronoi site is not finite".into());
        }
        for (k, p) in self.polygons.iter().enumerate() {
            if p.facet >= self.facet_count {
                return Err(format!("polygon {k} has facet {} >= facet count {}", p.facet, self.facet_count));
            }
            if p.points.len() < 3 {
                return Err(format!("polygon {k} has {} points (at least 3 needed)", p.points.len()));
            }
            if p.points.iter().flatten().any(|v| !v.is_finite()) {
                return Err(format!("polygon {k} has a non-finite point"));
            }
        }
        Ok(())
    }

    /// The polygon of `facet` (its shape), when it has one; the last drawn if several.
    pub fn polygon(&self, facet: u32) -> Option<&FacetPolygon> {
        self.polygons.iter().rev().find(|p| p.facet == facet)
    }

    /// Draw order of every facet: facets of `base` and `sites` first (rank 0), then each
    /// polygon's facet by its position in `polygons` (later = drawn over earlier).
    pub fn draw_order(&self) -> Vec<u32> {
        let mut rank = vec![0u32; self.facet_count as usize];
        for (k, p) in self.polygons.iter().enumerate() {
            if let Some(r) = rank.get_mut(p.facet as usize) {
                *r = k as u32 + 1;
            }
        }
        rank
    }

    /// The facet id of every pixel of a `width` x `height` image. Layers are sampled at
    /// pixel centres, so a layout rasterises the same way on any machine.
    pub fn rasterize(&self, width: u32, height: u32) -> FacetMap {
        let (w, h) = (width as usize, height as usize);
        let mut ids = vec![UNSET; w * h];
        if let Some(base) = &self.base {
            let (bw, bh) = (base.width as usize, base.height as usize);
            let col: Vec<usize> = (0..w).map(|x| nearest_source(x, w, bw)).collect();
            for y in 0..h {
                let sy = nearest_source(y, h, bh);
                let src = &base.labels[sy * bw..(sy + 1) * bw];
                for (x, id) in ids[y * w..(y + 1) * w].iter_mut().enumerate() {
                    *id = src[col[x]];
                }
            }
        }
        if !self.sites.is_empty() {
            voronoi::nearest_sites(&self.sites, width, height, &mut ids);
        }
        // The polygons in order, by bands of rows in parallel: each pixel
        // takes the last polygon over it, as when they are drawn one after another.
        if !self.polygons.is_empty() && w > 0 {
            let polygons: Vec<(u32, Vec<DVec2>)> = self
                .polygons
                .par_iter()
                .map(|p| (p.facet, p.points.iter().map(|q| DVec2::new(q[0] * w as f64, q[1] * h as f64)).collect()))
                .collect();
            const BAND_ROWS: usize = 32;
            ids.par_chunks_mut(w * BAND_ROWS).enumerate().for_each(|(b, band)| {
                let (first, rows) = (b * BAND_ROWS, band.len() / w);
                let offset = first * w;
                for (facet, pts) in &polygons {
                    fill_polygon_rows(pts, width, height, first..first + rows, |i| band[i - offset] = *facet);
                }
            });
        }
        fill_uncovered(&mut ids, width, height);
        FacetMap { width, height, ids, facet_count: self.facet_count }
    }
}

/// Nearest-neighbour source index of destination pixel `x` (of `n`) in a source of `m`.
fn nearest_source(x: usize, n: usize, m: usize) -> usize {
    ((((x as f64 + 0.5) * m as f64) / n as f64) as usize).min(m - 1)
}

/// Calls `set(pixel index)` for every pixel whose centre lies inside the polygon `pts`
/// (pixel coordinates, y down), even-odd rule, so convex and concave shapes both work.
pub fn fill_polygon(pts: &[DVec2], width: u32, height: u32, set: impl FnMut(usize)) {
    fill_polygon_rows(pts, width, height, 0..height as usize, set)
}

/// `fill_polygon` on the pixel rows `rows` alone.
fn fill_polygon_rows(pts: &[DVec2], width: u32, height: u32, rows: std::ops::Range<usize>, mut set: impl FnMut(usize)) {
    if pts.len() < 3 || rows.is_empty() {
        return;
    }
    let (lo, hi) = pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.y), hi.max(p.y)));
    let y0 = ((lo - 0.5).ceil().max(0.0)) as i64;
    let y1 = ((hi - 0.5).floor().min(height as f64 - 1.0)) as i64;
    let (y0, y1) = (y0.max(rows.start as i64), y1.min(rows.end as i64 - 1));
    let mut xs = Vec::with_capacity(8);
    for y in y0..=y1 {
        let yc = y as f64 + 0.5;
        xs.clear();
        for k in 0..pts.len() {
            let (a, b) = (pts[k], pts[(k + 1) % pts.len()]);
            // Half-open rule: a vertex on the scan line is counted once.
            if (a.y <= yc) != (b.y <= yc) {
                xs.push(a.x + (yc - a.y) * (b.x - a.x) / (b.y - a.y));
            }
        }
        xs.sort_by(f64::total_cmp);
        for pair in xs.chunks_exact(2) {
            // Pixels whose centre x + 0.5 lies in [pair[0], pair[1]).
            let x0 = ((pair[0] - 0.5).ceil().max(0.0)) as i64;
            let x1 = ((pair[1] - 0.5).ceil().min(width as f64)) as i64;
            for x in x0..x1 {
                set(y as usize * width as usize + x as usize);
            }
        }
    }
}

/// Gives every `UNSET` pixel the facet of the nearest set pixel (breadth-first, 4-connected,
/// in a fixed order, so the result is deterministic). All unset: facet 0.
fn fill_uncovered(ids: &mut [u32], width: u32, height: u32) {
    if !ids.contains(&UNSET) {
        return;
    }
    let grid = Grid::new(width, height);
    let mut queue: VecDeque<usize> = (0..ids.len()).filter(|&i| ids[i] != UNSET).collect();
    if queue.is_empty() {
        ids.fill(0);
        return;
    }
    while let Some(i) = queue.pop_front() {
        let id = ids[i];
        for j in grid.neighbours4(i) {
            if ids[j] == UNSET {
                ids[j] = id;
                queue.push_back(j);
            }
        }
    }
}

/// Every facet's pixel indices, facet-major, ascending within a facet
/// (`FacetMap::facet_pixels`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FacetPixels {
    /// `offsets[f]..offsets[f + 1]` indexes `pixels` for facet `f`.
    pub offsets: Vec<u32>,
    pub pixels: Vec<u32>,
}

impl FacetPixels {
    /// Facet `f`'s pixels, ascending (empty for a facet with none or out of range).
    pub fn of(&self, f: usize) -> &[u32] {
        match (self.offsets.get(f), self.offsets.get(f + 1)) {
            (Some(&a), Some(&b)) => &self.pixels[a as usize..b as usize],
            _ => &[],
        }
    }

    /// Number of facets listed.
    pub fn facet_count(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
}

impl FacetMap {
    /// How many ids a per-facet table needs: at least `facet_count` and one more than any id
    /// (a map made elsewhere may hold ids beyond its count).
    pub fn id_bound(&self) -> usize {
        (self.facet_count as usize).max(self.ids.iter().copied().max().map_or(0, |m| m as usize + 1))
    }

    /// Pixel indices of every facet, facet-major and ascending within a facet (a counting
    /// sort: `offsets[f]..offsets[f + 1]` indexes `pixels`). Bands of the image are sorted
    /// side by side, then each facet's pixels are gathered band after band (so still
    /// ascending): the same lists as one serial pass, on any thread count.
    pub fn pixels_by_facet(&self) -> (Vec<u32>, Vec<u32>) {
        let n = self.facet_count as usize;
        let band = (self.ids.len() / (4 * rayon::current_num_threads()).max(1)).max(1 << 16);
        let bands: Vec<(Vec<u32>, Vec<u32>)> = self
            .ids
            .par_chunks(band)
            .enumerate()
            .map(|(b, ids)| {
                let first = (b * band) as u32;
                let mut offsets = vec![0u32; n + 1];
                for &id in ids {
                    offsets[id as usize + 1] += 1;
                }
                for f in 0..n {
                    offsets[f + 1] += offsets[f];
                }
                let mut next = offsets.clone();
                let mut pixels = vec![0u32; ids.len()];
                for (k, &id) in ids.iter().enumerate() {
                    pixels[next[id as usize] as usize] = first + k as u32;
                    next[id as usize] += 1;
                }
                (offsets, pixels)
            })
            .collect();
        if bands.len() == 1 {
            return bands.into_iter().next().expect("one band");
        }
        let mut offsets = vec![0u32; n + 1];
        for f in 0..n {
            offsets[f + 1] = offsets[f] + bands.iter().map(|(o, _)| o[f + 1] - o[f]).sum::<u32>();
        }
        let mut pixels = vec![0u32; self.ids.len()];
        let mut slices = Vec::with_capacity(n);
        let mut rest = &mut pixels[..];
        for f in 0..n {
            let (own, tail) = rest.split_at_mut((offsets[f + 1] - offsets[f]) as usize);
            slices.push(own);
            rest = tail;
        }
        slices.into_par_iter().enumerate().for_each(|(f, own)| {
            let mut at = 0;
            for (o, p) in &bands {
                let part = &p[o[f] as usize..o[f + 1] as usize];
                own[at..at + part.len()].copy_from_slice(part);
                at += part.len();
            }
        });
        (offsets, pixels)
    }

    /// `pixels_by_facet` as a `FacetPixels`, made once and shared by the stages that read
    /// every facet's pixels (the imprecision stage's centres, coverage and cue checks).
    pub fn facet_pixels(&self) -> FacetPixels {
        let (offsets, pixels) = self.pixels_by_facet();
        FacetPixels { offsets, pixels }
    }

    /// Number of facets that own at least one pixel.
    pub fn used_facets(&self) -> usize {
        let mut seen = vec![false; self.facet_count as usize];
        self.ids.iter().for_each(|&id| seen[id as usize] = true);
        seen.iter().filter(|&&s| s).count()
    }

    /// Whether pixel `i` touches a pixel of another facet (4-neighbourhood).
    pub fn is_border(&self, i: usize) -> bool {
        Grid::new(self.width, self.height).on_border(&self.ids, i)
    }
}

/// How the image is split into facets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FacetMethod {
    /// One facet: the unfaceted cubist view.
    None,
    /// A facet map image, each distinct colour a facet (`constant`).
    Constant,
    /// Nearest of k stratified random points (`voronoi`).
    Voronoi,
    /// Random quadrilaterals painted until every pixel is covered (`patch`).
    Patch,
    /// Multiscale normalized-cut segments of the pre-render, selected by saliency (`segment`).
    Segment,
    /// Straight-edged planes tiling the canvas, cut along the subject's outlines (`planes`).
    Planes,
}

/// What the faceting stage needs besides the pre-render.
#[derive(Clone, Debug, PartialEq)]
pub struct FacetParams {
    pub method: FacetMethod,
    /// A saved layout (.json or .png) to load instead of computing one, so every frame of an
    /// animation shares it.
    pub layout_file: Option<PathBuf>,
    /// The facet map image of `Constant`.
    pub facet_map: Option<PathBuf>,
    /// Voronoi: k facets over m grid cells.
    pub facet_count: u32,
    pub grid_cells: u32,
    /// Patch: n_p quadrilaterals and the occlusion ratio r_occ of eq 4.3.
    pub patch_count: u32,
    pub occlusion: f64,
    pub segment: SegmentParams,
    pub planes: planes::PlanesParams,
    pub width: u32,
    pub height: u32,
    pub seed: u64,
}

impl FacetParams {
    /// Whether the image is split at all: a faceting method, or a layout loaded from a file.
    pub fn faceted(&self) -> bool {
        self.method != FacetMethod::None || self.layout_file.is_some()
    }

    fn aspect(&self) -> f64 {
        self.width as f64 / self.height as f64
    }
}

/// The layout `params` ask for: loaded from `layout_file`, or computed by the faceting method
/// (`film` is the pre-render, for methods that follow the picture).
pub fn layout_for(params: &FacetParams, film: &Film) -> Result<FacetLayout> {
    if let Some(path) = &params.layout_file {
        return io::load(path);
    }
    let layout = match params.method {
        FacetMethod::None => FacetLayout::single(),
        FacetMethod::Constant => {
            let path = params.facet_map.as_deref().ok_or_else(|| {
                Error::setting("facet_map", "constant faceting needs a facet map image (--facet-map)")
            })?;
            constant::layout(path)?
        }
        FacetMethod::Voronoi => voronoi::layout(params.facet_count, params.grid_cells, params.aspect(), params.seed),
        FacetMethod::Patch => patch::layout(params.patch_count, params.occlusion, params.aspect(), params.seed)?,
        FacetMethod::Segment => segment::layout(film, &params.segment)?.0,
        FacetMethod::Planes => planes::layout(
            &planes::PlanesInput {
                width: film.width,
                height: film.height,
                hits: &film.hits,
                saliency: film.saliency.as_deref(),
            },
            &params.planes,
        ),
    };
    debug_assert!(layout.validate().is_ok());
    Ok(layout)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(facet: u32, x0: f64, y0: f64, x1: f64, y1: f64) -> FacetPolygon {
        FacetPolygon { facet, points: vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]] }
    }

    #[test]
    fn single_covers_everything_at_any_size() {
        for (w, h) in [(1, 1), (7, 3), (64, 48)] {
            let m = FacetLayout::single().rasterize(w, h);
            assert!(m.ids.iter().all(|&i| i == 0));
            assert_eq!(m.used_facets(), 1);
        }
    }

    #[test]
    fn polygons_fill_pixel_centres_and_later_ones_occlude() {
        let layout = FacetLayout {
            facet_count: 3,
            base: Some(LabelImage { width: 1, height: 1, labels: vec![0] }),
            sites: vec![],
            polygons: vec![square(1, 0.0, 0.0, 0.5, 0.5), square(2, 0.25, 0.25, 0.75, 0.75)],
        };
        let m = layout.rasterize(8, 8);
        let at = |x: usize, y: usize| m.ids[y * 8 + x];
        assert_eq!(at(0, 0), 1);
        assert_eq!(at(1, 1), 1);
        assert_eq!(at(2, 2), 2, "the later polygon is drawn over the earlier one");
        assert_eq!(at(5, 5), 2);
        assert_eq!(at(6, 6), 0);
        assert_eq!(at(7, 0), 0);
        assert_eq!(m.ids.iter().filter(|&&i| i == 2).count(), 16);
        assert_eq!(layout.draw_order(), vec![0, 1, 2]);
        assert_eq!(layout.polygon(2).unwrap().facet, 2);
        assert!(layout.polygon(0).is_none());
    }

    #[test]
    fn concave_polygons_use_even_odd() {
        // An L shape: its bounding box's top-right quarter stays outside.
        let l = FacetPolygon {
            facet: 1,
            points: vec![[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [1.0, 0.5], [1.0, 1.0], [0.0, 1.0]],
        };
        let layout = FacetLayout { facet_count: 2, base: None, sites: vec![[0.9, 0.1]], polygons: vec![l] };
        let m = layout.rasterize(10, 10);
        assert_eq!(m.ids.iter().filter(|&&i| i == 1).count(), 75);
        assert_eq!(m.ids[9], 0);
        assert_eq!(m.ids[5 * 10 + 9], 1);
    }

    #[test]
    fn base_scales_nearest_neighbour() {
        let base = LabelImage { width: 2, height: 2, labels: vec![0, 1, 2, 3] };
        let layout = FacetLayout { facet_count: 4, base: Some(base), sites: vec![], polygons: vec![] };
        let m = layout.rasterize(4, 6);
        assert_eq!(&m.ids[0..4], &[0, 0, 1, 1]);
        assert_eq!(&m.ids[2 * 4..3 * 4], &[0, 0, 1, 1]);
        assert_eq!(&m.ids[3 * 4..4 * 4], &[2, 2, 3, 3]);
        let m1 = layout.rasterize(1, 1);
        assert_eq!(m1.ids, vec![3]);
    }

    #[test]
    fn uncovered_pixels_take_the_nearest_facet() {
        let layout = FacetLayout {
            facet_count: 2,
            base: None,
            sites: vec![],
            polygons: vec![square(0, 0.0, 0.0, 0.3, 1.0), square(1, 0.7, 0.0, 1.0, 1.0)],
        };
        let m = layout.rasterize(10, 4);
        for y in 0..4 {
            let row: Vec<u32> = m.ids[y * 10..(y + 1) * 10].to_vec();
            assert_eq!(row, vec![0, 0, 0, 0, 0, 1, 1, 1, 1, 1], "row {y}");
        }
    }

    #[test]
    fn validation_names_the_problem() {
        let mut l = FacetLayout::single();
        assert!(l.validate().is_ok());
        l.polygons[0].facet = 3;
        assert!(l.validate().unwrap_err().contains("polygon 0"));
        let l = FacetLayout { facet_count: 0, ..Default::default() };
        assert!(l.validate().is_err());
        let l = FacetLayout {
            facet_count: 2,
            base: Some(LabelImage { width: 2, height: 2, labels: vec![0, 1, 5, 0] }),
            ..Default::default()
        };
        assert!(l.validate().unwrap_err().contains("label 5"));
    }

    /// Polygons drawn by bands of rows in parallel are those drawn one after another: each
    /// pixel the last polygon over it (overlapping, concave, partly outside, degenerate), on
    /// 1-3 threads and sizes that do and do not split into whole bands.
    #[test]
    fn polygons_drawn_by_bands_are_those_drawn_in_order() {
        let mut state = 7u64;
        let mut next = || {
            state = crate::util::rng::splitmix64(state);
            (state % 10_000) as f64 / 10_000.0 * 1.4 - 0.2
        };
        let polygons: Vec<FacetPolygon> = (0..60)
            .map(|k| FacetPolygon { facet: k % 9, points: (0..3 + k as usize % 6).map(|_| [next(), next()]).collect() })
            .collect();
        let layout = FacetLayout { facet_count: 9, base: None, sites: Vec::new(), polygons };
        for (w, h) in [(640u32, 480u32), (97, 301), (1, 70), (300, 1)] {
            let mut ids = vec![UNSET; (w * h) as usize];
            for p in &layout.polygons {
                let pts: Vec<DVec2> = p.points.iter().map(|q| DVec2::new(q[0] * w as f64, q[1] * h as f64)).collect();
                fill_polygon(&pts, w, h, |i| ids[i] = p.facet);
            }
            fill_uncovered(&mut ids, w, h);
            for threads in 1..=3 {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let m = pool.install(|| layout.rasterize(w, h));
                assert_eq!(m.ids, ids, "{w}x{h}, {threads} threads");
            }
        }
    }

    #[test]
    fn pixels_by_facet_in_bands_is_the_serial_counting_sort() {
        // Several bands (more than 65536 pixels), facets empty, tiny and huge, on 1-3 threads.
        let (w, h) = (700u32, 300u32);
        let ids: Vec<u32> =
            (0..w * h).map(|i| if i % 7 == 0 { 3 } else { ((i % w) / 90 + 9 * ((i / w) / 80)) % 40 }).collect();
        let m = FacetMap { width: w, height: h, ids, facet_count: 43 };
        let n = m.facet_count as usize;
        let mut offsets = vec![0u32; n + 1];
        for &id in &m.ids {
            offsets[id as usize + 1] += 1;
        }
        for f in 0..n {
            offsets[f + 1] += offsets[f];
        }
        let mut next = offsets.clone();
        let mut pixels = vec![0u32; m.ids.len()];
        for (i, &id) in m.ids.iter().enumerate() {
            pixels[next[id as usize] as usize] = i as u32;
            next[id as usize] += 1;
        }
        for threads in 1..=3 {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let got = pool.install(|| m.facet_pixels());
            assert_eq!((&got.offsets, &got.pixels), (&offsets, &pixels), "{threads} threads");
            assert_eq!(got.facet_count(), n);
            assert!(got.of(41).is_empty() && got.of(99).is_empty());
            assert_eq!(got.of(3).len(), (offsets[4] - offsets[3]) as usize);
        }
    }

    #[test]
    fn pixels_by_facet_is_a_partition() {
        let layout = voronoi::layout(20, 4, 1.5, 3);
        let m = layout.rasterize(30, 20);
        let (off, px) = m.pixels_by_facet();
        assert_eq!(off.len(), 21);
        assert_eq!(*off.last().unwrap() as usize, 600);
        for f in 0..20 {
            let s = &px[off[f] as usize..off[f + 1] as usize];
            assert!(s.windows(2).all(|w| w[0] < w[1]));
            assert!(s.iter().all(|&i| m.ids[i as usize] == f as u32));
        }
    }
}
