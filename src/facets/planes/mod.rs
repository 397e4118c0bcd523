//! Planes faceting ("Planes everywhere"): the whole canvas, background
//! included, is split into flat polygonal planes with straight edges, small around the
//! subject's salient parts and larger towards the edges, cut along the subject's outlines.
//!
//! Going past the thesis (5.5.1: its facets are "sharper and regular", "in a simple relation
//! with the content", where the painters aligned facets with the silhouette of the content):
//! 1. a density over the canvas from the pre-render (saliency, the subject's presence,
//!    nearness to its centre; `density`);
//! 2. the subject's outlines, traced from the pre-render's object ids and simplified to
//!    straight runs (`outlines`);
//! 3. the canvas split by straight lines, heaviest plane first, into `planes` convex planes
//!    (`split`): the painters' scaffolding of long strokes, with the outline's long runs
//!    extended across the ground; every plane has straight edges and the planes tile the
//!    canvas with no gap; none keeps more than `MAX_PLANE_SHARE` of it;
//! 4. the outlines cut every plane they cross (`polygon`): the part inside becomes a plane of
//!    its own, drawn over the rest, so a plane is all figure or all ground;
//! 5. planes too small or too thin to read as planes (a corner grazed by an outline) join the
//!    neighbour they share most border with, preferring one on the same side of the outline.
//!
//! Deterministic for a seed on any thread count; about 20-40 ms at 1000 x 1000
//! (`cargo bench --bench facet_stages`).

pub mod density;
pub mod outlines;
pub mod polygon;
pub mod split;

use glam::DVec2;
use rayon::prelude::*;

use crate::facets::{FacetLayout, FacetMap, FacetPolygon, MAX_FACETS};
use crate::film::PixelHit;

/// The planes faceting's parameters (settings `planes`, `plane_detail`, `plane_outlines`, `seed`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanesParams {
    /// Voronoi cells the canvas is split into before the outlines cut them.
    pub planes: u32,
    /// How much denser the planes are at the most salient parts than far from the subject
    /// (a ratio of plane counts per area, >= 1).
    pub detail: f64,
    /// Cut the cells along the subject's outlines.
    pub outlines: bool,
    pub seed: u64,
}

impl Default for PlanesParams {
    fn default() -> Self {
        PlanesParams { planes: 150, detail: 5.0, outlines: true, seed: 0 }
    }
}

/// What the planes faceting reads of the pre-render.
pub struct PlanesInput<'a> {
    pub width: u32,
    pub height: u32,
    /// The pre-render's hit per pixel (object ids and distances).
    pub hits: &'a [PixelHit],
    /// The saliency map, when computed.
    pub saliency: Option<&'a [f32]>,
}

/// Most cells (`planes`): the outlines then cut them into at most a few times as many facets,
/// well within `MAX_FACETS`.
pub const MAX_PLANES: u32 = 4000;
/// Largest share of the canvas one plane may keep: the corners' calm planes may be several
/// times the subject's, never one plane over much of the ground.
pub const MAX_PLANE_SHARE: f64 = 0.12;
/// Outline simplification tolerance, as a share of the image diagonal (2.5 px at 640 x 480):
/// the outline stays within about two pixels of the silhouette, and runs straight between.
pub const OUTLINE_TOLERANCE: f64 = 0.003;
/// Shortest outline edge, as a share of the image diagonal (`outlines::merge_short_edges`): a
/// bend traced pixel by pixel becomes edges long enough to read as straight strokes (runs
/// of at least 1% of the diagonal).
pub const OUTLINE_MIN_EDGE: f64 = 0.012;
/// Outline runs at least this share of the image diagonal long are candidate cuts.
pub const RUN_SHARE: f64 = 0.04;
/// Specks of one object (or holes in it) smaller than this share of the canvas are merged into
/// their surroundings before tracing.
pub const SPECK_SHARE: f64 = 0.0004;
/// Parts of the subject thinner than this share of the image diagonal on average, bordering
/// other parts more than the background, are painted with the part they border most
/// (`outlines::clean_labels`).
pub const THIN_WIDTH: f64 = 0.007;
/// An object gets its own outline layer (besides the outline of all geometry) from this share
/// of the canvas, when at least two objects are that large. Each layer's outline crosses the
/// planes it passes, and every crossing pins a junction: at 1% a scatter of thirty small
/// objects was cut into slivers (straight runs 96.5%, five seeds); at 2%, 97.1%, with the
/// still life's jug, bottle, guitar, bowl and table each still cut along its own outline.
pub const OBJECT_SHARE: f64 = 0.02;
/// A plane smaller than (this share of the image diagonal)^2, or thinner on average than
/// `MIN_WIDTH` of the diagonal, joins a neighbour: its edges would be too short to read as
/// straight runs (runs of at least 1% of the diagonal) or it would read as a crack.
pub const MIN_SIDE: f64 = 0.02;
pub const MIN_WIDTH: f64 = 0.007;
/// No split leaves a plane narrower than this share of the image diagonal: slivers and
/// needle-thin wedges read as cracks, not planes.
pub const SPLIT_WIDTH: f64 = 0.02;

/// The planes layout of a pre-render.
pub fn layout(input: &PlanesInput, params: &PlanesParams) -> FacetLayout {
    layout_guided(input, params, &guides(input, params.outlines)).0
}

/// What the planes read of the pre-render whatever their count, detail and seed: the
/// density's cues and the subject's outlines (steps 1 and 2). A render server keeps it while
/// the pre-render is the same (`pipeline::Session`), so another plane count or detail only
/// splits, cuts and merges again.
#[derive(Clone, Debug)]
pub struct Guides {
    pub cues: density::Cues,
    /// The outline layers; empty when made without outlines.
    pub layers: Vec<outlines::Layer>,
    /// Whether the outlines were made (`PlanesParams::outlines`).
    pub outlines: bool,
}

impl Guides {
    /// Bytes held (for a cache's budget).
    pub fn bytes(&self) -> u64 {
        let rings: usize = self.layers.iter().flat_map(|l| l.rings.iter()).map(|r| r.len()).sum();
        (self.cues.steps.len() * 8 + rings * size_of::<DVec2>()) as u64
    }
}

/// Steps 1 and 2 of a pre-render (`Guides`); the outlines only when `outlines`.
pub fn guides(input: &PlanesInput, outlines: bool) -> Guides {
    let (w, h) = (input.width as usize, input.height as usize);
    let (wf, hf) = (w as f64, h as f64);
    let n = w * h;
    let diag = (wf * wf + hf * hf).sqrt();
    let hits = input.hits;
    let covered = |i: usize| hits[i].is_hit();
    // The density and the outlines read only the pre-render: made side by side (the
    // outlines' labelling is serial).
    let (cues, layers) = rayon::join(
        || density::Cues::new(input.width, input.height, &covered, input.saliency),
        || {
            // 2. Outlines.
            if !outlines {
                return Vec::new();
            }
            let mut labels: Vec<u32> =
                hits.par_iter().map(|h| if h.is_hit() { h.object } else { outlines::BACKGROUND }).collect();
            outlines::clean_labels(&mut labels, w, h, ((SPECK_SHARE * n as f64) as usize).max(4), THIN_WIDTH * diag);
            let depth: Vec<f32> = hits.par_iter().map(|h| h.t).collect();
            outlines::layers(
                &labels,
                &depth,
                w,
                h,
                ((OBJECT_SHARE * n as f64) as usize).max(1),
                OUTLINE_TOLERANCE * diag,
                OUTLINE_MIN_EDGE * diag,
            )
        },
    );
    Guides { cues, layers, outlines }
}

/// The planes layout of a pre-render from its `guides` (made with `params.outlines`), and
/// its facet map at the pre-render's size (the layout rasterised, as `FacetLayout::rasterize`
/// gives it: the merge's map renumbered, not drawn a second time).
pub fn layout_guided(input: &PlanesInput, params: &PlanesParams, guides: &Guides) -> (FacetLayout, FacetMap) {
    debug_assert_eq!(guides.outlines, params.outlines, "guides made with another outlines setting");
    let (w, h) = (input.width as usize, input.height as usize);
    let (wf, hf) = (w as f64, h as f64);
    let diag = (wf * wf + hf * hf).sqrt();
    let density = guides.cues.density(params.detail);
    let layers: &[outlines::Layer] = if params.outlines { &guides.layers } else { &[] };
    let runs: Vec<split::Run> = layers
        .iter()
        .flat_map(|l| l.rings.iter())
        .flat_map(|r| (0..r.len()).map(move |k| split::Run { a: r[k], b: r[(k + 1) % r.len()] }))
        .filter(|run| (run.b - run.a).length() >= RUN_SHARE * diag)
        .collect();

    // 3. The scaffolding.
    let weights = split::Weights {
        columns: density.columns,
        rows: density.rows,
        values: &density.values,
        protect: &guides.cues.protect,
        width: wf,
        height: hf,
    };
    let count = params.planes.clamp(1, MAX_PLANES) as usize;
    let cells = split::split(&weights, &runs, count, SPLIT_WIDTH * diag, MAX_PLANE_SHARE * wf * hf, params.seed);
    let mut polygons: Vec<(u32, Vec<DVec2>)> = cells.iter().enumerate().map(|(i, c)| (i as u32, c.clone())).collect();
    let mut next = cells.len() as u32;
    // Which side of the outline each facet is on: 0 = the ground, k = layer k - 1.
    let mut side: Vec<u32> = vec![0; cells.len()];

    // 4. Outlines cut the planes.
    let min_piece = 0.25 * (MIN_SIDE * diag).powi(2);
    for (k, layer) in layers.iter().enumerate() {
        for cell in &cells {
            let mut piece: Vec<DVec2> = Vec::new();
            let mut area = 0.0;
            for ring in &layer.rings {
                let clipped = polygon::clip_to_convex(ring, cell);
                if clipped.len() < 3 {
                    continue;
                }
                area += polygon::signed_area(&clipped);
                // Rings joined through a repeated first point: the bridge is traversed both
                // ways and cancels in the even-odd fill.
                if let Some(&first) = piece.first() {
                    piece.extend_from_slice(&clipped);
                    piece.push(clipped[0]);
                    piece.push(first);
                } else {
                    piece.extend_from_slice(&clipped);
                    piece.push(clipped[0]);
                }
            }
            // Passage: some planes the outline crosses stay whole across it, so the figure
            // opens into the ground there (never at a salient feature, never for a piece that
            // is most of its plane).
            if area.abs() >= min_piece && open_across(cell, area.abs(), &weights, params.seed, k) {
                continue;
            }
            if area.abs() >= min_piece && (next as usize) < MAX_FACETS as usize {
                polygons.push((next, piece));
                side.push(k as u32 + 1);
                next += 1;
            }
        }
    }

    // 5. Rasterise here, merge the planes too small or thin to read, renumber.
    let mut layout = to_layout(next, &polygons, wf, hf);
    let mut map = layout.rasterize(input.width, input.height);
    let relabel = merge_small(&map.ids, w, h, next as usize, &side, MIN_SIDE * diag, MIN_WIDTH * diag);
    let mut used = vec![false; next as usize];
    for &id in &map.ids {
        used[relabel[id as usize] as usize] = true;
    }
    let mut compact = vec![u32::MAX; next as usize];
    let mut count = 0u32;
    for f in 0..next as usize {
        if used[f] {
            compact[f] = count;
            count += 1;
        }
    }
    layout.polygons.retain_mut(|p| {
        let f = compact[relabel[p.facet as usize] as usize];
        p.facet = f;
        f != u32::MAX
    });
    layout.facet_count = count.max(1);
    debug_assert!(layout.validate().is_ok(), "{:?}", layout.validate());
    // The renumbered layout drawn again would give each pixel the new number of the polygon
    // on top of it there: the polygons dropped are on top nowhere (their facet is used by no
    // pixel), and `fill_uncovered` fills the same pixels from the same neighbours whatever
    // their numbers (a test holds the two maps equal).
    map.ids.par_iter_mut().for_each(|id| *id = compact[relabel[*id as usize] as usize]);
    map.facet_count = layout.facet_count;
    (layout, map)
}

/// The share of the planes an outline crosses that it leaves whole (`open_across`).
pub const OPEN_SHARE: f64 = 0.3;
/// A plane stays whole across the outline only while the subject's piece of it is at most
/// this share of it.
pub const OPEN_PIECE_SHARE: f64 = 0.6;
const OPEN_STREAM: u64 = 0x6f70_656e; // "open"

/// Whether the outline of layer `layer` leaves `cell` whole (passage): a seeded
/// `OPEN_SHARE` of the planes whose piece inside it (`piece_area`, pixels) is at most
/// `OPEN_PIECE_SHARE` of the plane and which hold no salient feature.
fn open_across(cell: &[DVec2], piece_area: f64, weights: &split::Weights, seed: u64, layer: usize) -> bool {
    let area = polygon::signed_area(cell).abs();
    if area <= 0.0 || piece_area > OPEN_PIECE_SHARE * area {
        return false;
    }
    let c = split::centroid(cell);
    let key = ((c.x.to_bits() >> 20) ^ (c.y.to_bits() >> 7)).wrapping_add(layer as u64);
    if crate::util::rng::rand01(seed, OPEN_STREAM, key) >= OPEN_SHARE {
        return false;
    }
    !weights.touches_protected(cell)
}

/// The polygons (pixel units) as a layout in normalised coordinates.
fn to_layout(facet_count: u32, polygons: &[(u32, Vec<DVec2>)], w: f64, h: f64) -> FacetLayout {
    FacetLayout {
        facet_count: facet_count.max(1),
        base: None,
        sites: Vec::new(),
        polygons: polygons
            .iter()
            .filter(|(_, p)| p.len() >= 3)
            .map(|(f, p)| FacetPolygon { facet: *f, points: p.iter().map(|q| [q.x / w, q.y / h]).collect() })
            .collect(),
    }
}

/// Union-find root with path halving.
fn root(parent: &mut [u32], mut a: u32) -> u32 {
    while parent[a as usize] != a {
        parent[a as usize] = parent[parent[a as usize] as usize];
        a = parent[a as usize];
    }
    a
}

/// The facet each facet ends up in after merging every facet of fewer than `min_side`^2
/// pixels, or of mean width (2 area / inner perimeter) under `min_width`, into the neighbour it
/// shares the longest border with (preferring the same `side` of the outline), smallest first,
/// in a few rounds. Deterministic: fixed orders, ties to the lower id.
fn merge_small(ids: &[u32], w: usize, h: usize, count: usize, side: &[u32], min_side: f64, min_width: f64) -> Vec<u32> {
    // The counts by bands of rows in parallel, summed (integers: the same totals in any
    // order), once over the pixels: a later round's counts are the first
    // round's summed over each facet's root (one pass over the image
    // instead of one a round).
    let first = std::cell::OnceCell::new();
    let counts = |current: &[u32]| {
        let (area, _, shared): &BorderCounts = first.get_or_init(|| {
            let identity: Vec<u32> = (0..count as u32).collect();
            const BAND: usize = 32;
            (0..h.div_ceil(BAND))
                .into_par_iter()
                .map(|k| border_counts(ids, w, h, count, &identity, k * BAND..((k + 1) * BAND).min(h)))
                .reduce_with(|(mut a1, mut p1, mut s1), (a2, p2, s2)| {
                    a1.iter_mut().zip(a2).for_each(|(x, y)| *x += y);
                    p1.iter_mut().zip(p2).for_each(|(x, y)| *x += y);
                    for (k, v) in s2 {
                        *s1.entry(k).or_insert(0) += v;
                    }
                    (a1, p1, s1)
                })
                .unwrap_or_else(|| (vec![0; count], vec![0; count], Default::default()))
        });
        counts_by_root(area, shared, current)
    };
    merge_small_counted(count, side, min_side, min_width, counts)
}

/// The `BorderCounts` of the facets' roots (`current`: each facet's root) from those of the
/// facets themselves (`area`, `shared`): a root's area is its facets' areas; two roots share
/// the borders their facets share; a root's inner perimeter is the borders it shares (each
/// differing pair of neighbouring pixels counts once on either side, as `border_counts` does).
fn counts_by_root(area: &[u64], shared: &std::collections::BTreeMap<(u32, u32), u64>, current: &[u32]) -> BorderCounts {
    let mut root_area = vec![0u64; area.len()];
    for (f, &a) in area.iter().enumerate() {
        root_area[current[f] as usize] += a;
    }
    let mut perimeter = vec![0u64; area.len()];
    let mut root_shared: std::collections::BTreeMap<(u32, u32), u64> = Default::default();
    for (&(a, b), &len) in shared {
        let (ra, rb) = (current[a as usize], current[b as usize]);
        if ra != rb {
            perimeter[ra as usize] += len;
            perimeter[rb as usize] += len;
            *root_shared.entry((ra.min(rb), ra.max(rb))).or_insert(0) += len;
        }
    }
    (root_area, perimeter, root_shared)
}

/// Each facet root's area and inner perimeter, and the shared border lengths (a, b) -> count
/// with a < b between roots (`current`: each facet's root).
type BorderCounts = (Vec<u64>, Vec<u64>, std::collections::BTreeMap<(u32, u32), u64>);

/// `BorderCounts` of the pixels in `rows` (each pixel with its right and lower neighbours).
fn border_counts(
    ids: &[u32],
    w: usize,
    h: usize,
    count: usize,
    current: &[u32],
    rows: std::ops::Range<usize>,
) -> BorderCounts {
    let mut area = vec![0u64; count];
    let mut perimeter = vec![0u64; count];
    let mut shared: std::collections::BTreeMap<(u32, u32), u64> = Default::default();
    for y in rows {
        for x in 0..w {
            let i = y * w + x;
            let a = current[ids[i] as usize];
            area[a as usize] += 1;
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)].into_iter().flatten() {
                let b = current[ids[j] as usize];
                if a != b {
                    perimeter[a as usize] += 1;
                    perimeter[b as usize] += 1;
                    *shared.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                }
            }
        }
    }
    (area, perimeter, shared)
}

/// `merge_small`'s rounds, with `counts` giving the `BorderCounts` for each facet's current
/// root.
fn merge_small_counted(
    count: usize,
    side: &[u32],
    min_side: f64,
    min_width: f64,
    counts: impl Fn(&[u32]) -> BorderCounts,
) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..count as u32).collect();
    let min_area = (min_side * min_side) as u64;
    for _round in 0..3 {
        let mut current: Vec<u32> = (0..count as u32).collect();
        for f in 0..count as u32 {
            current[f as usize] = root(&mut parent, f);
        }
        let (area, perimeter, shared) = counts(&current);
        let mut small: Vec<u32> = (0..count as u32)
            .filter(|&f| {
                let (a, p) = (area[f as usize], perimeter[f as usize]);
                a > 0 && p > 0 && (a < min_area || 2.0 * (a as f64) / (p as f64) < min_width)
            })
            .collect();
        if small.is_empty() {
            break;
        }
        small.sort_by_key(|&f| (area[f as usize], f));
        let mut neighbours: Vec<Vec<(u32, u64)>> = vec![Vec::new(); count];
        for (&(a, b), &len) in &shared {
            neighbours[a as usize].push((b, len));
            neighbours[b as usize].push((a, len));
        }
        let mut merged_any = false;
        for f in small {
            let rf = root(&mut parent, f);
            if rf != f {
                continue; // already absorbed this round
            }
            let best = neighbours[f as usize]
                .iter()
                .map(|&(g, len)| (root(&mut parent, g), g, len))
                .filter(|&(r, _, _)| r != rf)
                .max_by(|a, b| {
                    let same = |g: u32| (side[g as usize] == side[f as usize]) as u8;
                    same(a.1).cmp(&same(b.1)).then(a.2.cmp(&b.2)).then(b.0.cmp(&a.0))
                });
            if let Some((r, _, _)) = best {
                parent[rf as usize] = r;
                merged_any = true;
            }
        }
        if !merged_any {
            break;
        }
    }
    (0..count as u32).map(|f| root(&mut parent, f)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `merge_small` with its counts made in one pass over every row for every round, as
    /// before they were made in parallel bands (perf7) and once for all rounds (facet9): the
    /// reference the parallel, summed form must match.
    fn merge_small_serial(
        ids: &[u32],
        w: usize,
        h: usize,
        count: usize,
        side: &[u32],
        min_side: f64,
        min_width: f64,
    ) -> Vec<u32> {
        merge_small_counted(count, side, min_side, min_width, |current| border_counts(ids, w, h, count, current, 0..h))
    }

    /// A synthetic pre-render: two overlapping discs of two objects (nearer on the right) and
    /// a saliency blob, at `w` x `h`.
    fn discs(w: u32, h: u32) -> (Vec<PixelHit>, Vec<f32>) {
        let (wf, hf) = (w as f32, h as f32);
        let mut hits = vec![PixelHit::MISS; (w * h) as usize];
        let mut sal = vec![0.0f32; (w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) as usize;
                let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                let d = |cx: f32, cy: f32, r: f32| ((px - cx * wf).powi(2) + (py - cy * hf).powi(2)).sqrt() < r * hf;
                if d(0.62, 0.55, 0.22) {
                    hits[i] = PixelHit { tri: 1, object: 1, t: 2.0, ..PixelHit::MISS };
                } else if d(0.4, 0.45, 0.3) {
                    hits[i] = PixelHit { tri: 0, object: 0, t: 3.0, ..PixelHit::MISS };
                }
                sal[i] = (1.0 - ((px / wf - 0.45).powi(2) + (py / hf - 0.4).powi(2)).sqrt() * 4.0).max(0.0);
            }
        }
        (hits, sal)
    }

    /// The map `layout_guided` gives is the layout rasterised again, bit for bit; one
    /// `guides` serve every plane count, detail and seed as a fresh one would.
    #[test]
    fn a_prepared_layout_is_the_fresh_one_and_its_map_the_rasterised_one() {
        for (w, h) in [(320u32, 240u32), (211, 307)] {
            let (hits, sal) = discs(w, h);
            for saliency in [Some(sal.as_slice()), None] {
                let input = PlanesInput { width: w, height: h, hits: &hits, saliency };
                for outlines in [true, false] {
                    let prep = guides(&input, outlines);
                    for (planes, detail, seed) in [(150, 5.0, 0), (151, 5.5, 0), (40, 1.0, 3), (400, 8.0, 1)] {
                        let params = PlanesParams { planes, detail, outlines, seed };
                        let (layout, map) = layout_guided(&input, &params, &prep);
                        assert_eq!(layout, super::layout(&input, &params), "{w}x{h} {params:?}");
                        let drawn = layout.rasterize(w, h);
                        assert_eq!(map.ids, drawn.ids, "{w}x{h} {params:?}");
                        assert_eq!(map.facet_count, drawn.facet_count);
                        assert!(map.facet_count > 1, "{w}x{h} {params:?}: several facets");
                    }
                }
            }
        }
    }

    /// Merging small facets with its counts made in parallel bands of rows gives the serial
    /// form's result, on random layouts of many small facets, bands cut anywhere.
    #[test]
    fn merge_small_matches_the_serial_counts() {
        for (case, (w, h, cells)) in
            [(97usize, 61usize, 9usize), (300, 170, 23), (64, 33, 4), (517, 89, 41)].into_iter().enumerate()
        {
            let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ case as u64;
            let mut next = || {
                state = crate::util::rng::splitmix64(state);
                state
            };
            // Voronoi-like cells of random sites, some tiny, with speckle.
            let sites: Vec<(usize, usize)> =
                (0..cells * cells).map(|_| ((next() % w as u64) as usize, (next() % h as u64) as usize)).collect();
            let count = sites.len() + 5;
            let ids: Vec<u32> = (0..w * h)
                .map(|i| {
                    let (x, y) = (i % w, i / w);
                    if next() % 97 == 0 {
                        return (sites.len() + (next() % 5) as usize) as u32;
                    }
                    (0..sites.len())
                        .min_by_key(|&k| {
                            let (sx, sy) = sites[k];
                            (sx as i64 - x as i64).pow(2) + (sy as i64 - y as i64).pow(2)
                        })
                        .unwrap() as u32
                })
                .collect();
            let side: Vec<u32> = (0..count as u32).map(|f| f % 3).collect();
            let mut merged = 0;
            for (min_side, min_width) in [(6.0, 2.0), (12.0, 4.0), (3.0, 0.5)] {
                let want = merge_small_serial(&ids, w, h, count, &side, min_side, min_width);
                let got = merge_small(&ids, w, h, count, &side, min_side, min_width);
                assert_eq!(got, want, "case {case}, {min_side} {min_width}");
                merged += want.iter().enumerate().filter(|(f, r)| **r != *f as u32).count();
            }
            assert!(merged > 0, "case {case}: something merged");
            // A later round's counts summed from the first's are those counted again over
            // the pixels, for roots of every kind (facets folded into lower, higher, one).
            let first = border_counts(&ids, w, h, count, &(0..count as u32).collect::<Vec<_>>(), 0..h);
            for fold in [1u32, 2, 3, 7] {
                let current: Vec<u32> = (0..count as u32).map(|f| (f / fold * fold + fold / 2).min(f)).collect();
                let want = border_counts(&ids, w, h, count, &current, 0..h);
                assert_eq!(counts_by_root(&first.0, &first.2, &current), want, "case {case}, fold {fold}");
            }
            let reversed: Vec<u32> = (0..count as u32).map(|f| count as u32 - 1 - f / 2).collect();
            let want = border_counts(&ids, w, h, count, &reversed, 0..h);
            assert_eq!(counts_by_root(&first.0, &first.2, &reversed), want, "case {case}, reversed");
        }
    }
}
