//! Passage ("Each plane has its own light"): where two planes meet, one side
//! is a hard dark line and the other dissolves into the neighbour, so the surface shimmers in
//! shallow relief instead of every border blurring evenly on both sides (eq 4.8 darkens both
//! sides alike: the blind panel's "dark halo outlines").
//!
//! Edges are the facet borders and the objects' silhouettes (a pixel whose 4-neighbour shows
//! another facet or another object, the background counting as one), so the subject's
//! contours are drawn the same way, without the silhouette halo. For every pixel within md
//! of an edge, the feature transform (`distance::nearest_features`) gives the nearest edge
//! pixel, hence the pair of pixels facing each other across the edge, and each side's value,
//! its region's mean (the plane's, not the strokes' dabs at the edge):
//! - the darker side takes the line (`border_profile::drawn_line`: a quarter of the colour
//!   over a narrow core, then a quick rise into its own plane), on that side only, so the
//!   line is crisp against both sides, a painter's line rather than a shadow; drawn by the
//!   distance to the edge's smoothed line (`util::edge_line`), not to its pixel
//!   staircase, so a slanted line runs straight and a line moving by less than a pixel moves;
//! - the line's strength follows the two sides' value contrast (planes of the same value
//!   meet softly) and a seeded, slowly varying "lost and found" along the edges, as a
//!   painter's line comes and goes;
//! - where the line is weak the two sides blend into each other across the edge (passage
//!   proper: the edge dissolves).
//!
//! It runs after the strokes and the per-plane light (`PassageParams`): its blends and lines
//! are the last word on each edge, so a lost edge melts the two planes' paint and light into
//! each other, and a plane's dark end takes the line against its neighbour's light end. Last,
//! it smooths the edges' pixel steps (`edge_smoothing`).

use glam::Vec3;
use rayon::prelude::*;

use super::border_profile::drawn_line;
use super::borders::BorderParams;
use super::edge_smoothing;
use super::noise::Grid2;
use super::planes::smoothstep;
use super::region_means::region_means;
use super::{Canvas, Effect, EffectParams, PaintContext, darken, luminance};
use crate::distance::NO_FEATURE;
use crate::error::Result;
use crate::util::edge_line::{EdgeLine, Window};
use crate::util::rng::sub_seed;

pub(crate) const SALT: u64 = 0x7061_7373_6167_6531; // "passage1"
/// Share of a line's strength kept where both sides have the same value: low, so two planes
/// of one value meet softly and the lines gather where the value changes.
pub const FLOOR: f32 = 0.2;
/// Relative value difference (|a - b| / max) at which a line has its full strength.
pub const FULL_CONTRAST: f32 = 0.25;
/// Lost and found: along the edges a line's strength varies between this share and 1 ...
pub const LOST: f32 = 0.05;
/// ... over about this share of the image's size sqrt(w h): longer than a plane's side, so
/// a join is drawn or lost over most of its length, and whole stretches of the picture are
/// drawn firmly while others dissolve, where a shorter period broke each line into dashes.
pub const LOST_PERIOD: f32 = 0.3;
/// Largest share of the other side's colour a pixel takes on an edge whose line is lost.
pub const BLEND: f32 = 0.5;

/// How facet borders are drawn (`borders::BorderParams::style`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum BorderStyle {
    /// Eq 4.8 on both sides of every facet border (`borders::Borders`), as the thesis prints it.
    Symmetric,
    /// One side, lost and found, with passage; object silhouettes too (`Passage`).
    Passage,
}

/// Passage's parameters: the facet borders' when they are drawn as passage. It runs after the
/// strokes and the per-plane light (the chain's order: `PaintParams`), so the planes' paint and
/// light melt into each other where an edge is lost (judged blind: docs/look/README.md, round
/// 21).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PassageParams(pub BorderParams);

impl EffectParams for PassageParams {
    fn is_on(&self) -> bool {
        self.0.drawn() && self.0.style == BorderStyle::Passage
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        let b = &self.0;
        Ok(Box::new(Passage { width: (b.width * b.scale) as f32, strength: b.strength as f32, seed: b.seed }))
    }
}

/// One-sided, lost-and-found borders with passage.
#[derive(Clone, Copy, Debug)]
pub struct Passage {
    /// md, pixels of this image: the join's reach (the line within `LINE_END` md of the edge,
    /// the blend within md / 2).
    pub width: f32,
    /// In [0, 1]: 1 = the drawn line's full darkening where the line is strongest.
    pub strength: f32,
    pub seed: u64,
}

impl Passage {
    /// A line's presence in [LOST x FLOOR, 1] from the two sides' values and the
    /// lost-and-found noise value `lost_found` in [0, 1]; its darkening is `strength` times it.
    pub fn line(va: f32, vb: f32, lost_found: f32) -> f32 {
        let contrast = (va - vb).abs() / va.max(vb).max(1e-4);
        let lambda = FLOOR + (1.0 - FLOOR) * smoothstep(0.0, FULL_CONTRAST, contrast);
        lambda * (LOST + (1.0 - LOST) * lost_found)
    }
}

/// What passage reads of the region edges alone, not of the colour nor of md: for every
/// pixel with a nearest edge pixel q (within the edges' limit), the pair (a, b) of pixels
/// facing each other across that edge, a on the pixel's side. Kept with the edges
/// (`Edges::passage`), so a border width change reuses it; the pairs' values, which read the
/// colour, are computed again by each run.
pub struct Pairs {
    /// The edge pixels (their own nearest edge pixel), in scan order.
    edge_pixels: Vec<u32>,
    /// Per pixel: the pair of its nearest edge, `NO_PAIR`, or `FALLBACK | k` (the k-th of
    /// `fallback`). A pair is ((e * 4 + dir) << 1 | role): edge pixel e = a (`edge_pixels[e]`),
    /// b its neighbour in direction dir (right, down, left, up); role 0 when q is a (the
    /// pixel is in q's region), 1 when q is b. (At most `MAX_PIXELS` = 2^26 pixels: the
    /// index fits below `FALLBACK`.)
    of: Vec<u32>,
    /// Pixels whose region has no 4-neighbour of q: a is the pixel itself, b is q.
    /// (Role 1 and these do not arise from an exact feature transform: the pixels of a
    /// monotone 4-connected path from a pixel to a q of another region all lie in their
    /// bounding box, so the last one in the pixel's region is an edge pixel strictly nearer
    /// than q. They are kept so the result never rests on that.)
    fallback: Vec<(u32, u32)>,
    /// Each pixel's index in `edge_pixels` (u32::MAX off the edges), for the lost-and-found
    /// value of b.
    slot: Vec<u32>,
    /// Per edge pixel, its region's smoothed edge line there (`util::edge_line`),
    /// which the line is drawn from: a pixel's distance to the edge's true line, not to the
    /// nearest pixel of its staircase, so a slanted line is drawn straight and a line moving
    /// less than a pixel moves with it.
    lines: Vec<Option<EdgeLine>>,
    /// Where the distance to a line is measured from (`edge_line::Window::grid_offset`).
    grid_offset: f32,
    /// What the sides of each edge pixel read besides the colour, for one step and seed
    /// (kept across chains only: `Passage::apply`).
    geometry: std::sync::Mutex<Option<GeometryOf>>,
}

/// `Pairs::geometry`'s key (step, seed) and the geometry.
type GeometryOf = ([u64; 2], std::sync::Arc<Vec<[Geometry; 4]>>);

const NO_PAIR: u32 = u32::MAX;
const FALLBACK: u32 = 1 << 31;

impl Pairs {
    /// The pairs of `near` (`PaintContext::edges`) in a `w` x `h` image whose pixels are in
    /// the same region when `same` says so.
    pub fn new(w: usize, h: usize, near: &[u32], same: &(impl Fn(usize, usize) -> bool + Sync)) -> Pairs {
        let mut slot = vec![u32::MAX; w * h];
        let mut edge_pixels = Vec::new();
        for (i, s) in slot.iter_mut().enumerate() {
            if near[i] as usize == i {
                *s = edge_pixels.len() as u32;
                edge_pixels.push(i as u32);
            }
        }
        let pair = |a: usize, b: usize, role: u32| -> u32 { ((slot[a] * 4 + direction(w, a, b)) << 1) | role };
        let mut of: Vec<u32> = vec![NO_PAIR; w * h];
        of.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let q = near[i];
                if q == NO_FEATURE {
                    continue;
                }
                let q = q as usize;
                *o = if same(i, q) {
                    match neighbour(w, h, q, |n| !same(n, q)) {
                        Some(b) => pair(q, b, 0),
                        None => NO_PAIR,
                    }
                } else {
                    match neighbour(w, h, q, |n| same(n, i)) {
                        Some(a) => pair(a, q, 1),
                        None => FALLBACK,
                    }
                };
            }
        });
        let mut fallback = Vec::new();
        for (i, o) in of.iter_mut().enumerate() {
            if *o == FALLBACK {
                *o = FALLBACK | fallback.len() as u32;
                fallback.push((i as u32, near[i]));
            }
        }
        let window = Window::new();
        let lines = edge_pixels.par_iter().map(|&q| window.line(w, h, q as usize, |j| same(j, q as usize))).collect();
        let grid_offset = window.grid_offset;
        Pairs { edge_pixels, of, fallback, slot, lines, grid_offset, geometry: std::sync::Mutex::new(None) }
    }

    /// Pixel `i`'s distance to the edge line at edge pixel `e` of its own region (`lines`),
    /// measured as `d` (the distance to the nearest edge pixel: from the edge pixels' centres,
    /// half a pixel in from the line, `grid_offset`), within a pixel of `d`; `d` where the
    /// line is not known.
    fn to_line(&self, e: usize, i: usize, w: usize, d: f32) -> f32 {
        let Some(line) = self.lines[e] else { return d };
        let q = self.edge_pixels[e] as usize;
        let (dx, dy) = ((i % w) as f32 - (q % w) as f32, (i / w) as f32 - (q / w) as f32);
        (line.at(dx, dy) - self.grid_offset).clamp((d - 1.0).max(0.0), d + 1.0)
    }

    pub fn bytes(&self) -> usize {
        let geometry = self.geometry.lock().map_or(0, |g| g.as_ref().map_or(0, |(_, g)| size_of_val(&g[..])));
        (self.edge_pixels.len() + self.of.len() + self.slot.len() + 2 * self.fallback.len()) * 4
            + size_of_val(&self.lines[..])
            + geometry
    }

    /// The geometry of every edge pixel's sides for `key`, made by `make` when not held (the
    /// last one made is held).
    fn geometry(&self, key: [u64; 2], make: impl FnOnce() -> Vec<[Geometry; 4]>) -> std::sync::Arc<Vec<[Geometry; 4]>> {
        if let Some((k, g)) = self.geometry.lock().ok().and_then(|g| g.clone())
            && k == key
        {
            return g;
        }
        let g = std::sync::Arc::new(make());
        if let Ok(mut held) = self.geometry.lock() {
            *held = Some((key, g.clone()));
        }
        g
    }
}

/// The 4-neighbours of q in a w x h grid in passage's fixed order (right, down, left, up;
/// None outside the grid): the order edge pairs and their tie-breaks are taken in.
pub(super) fn neighbours_rdlu(w: usize, h: usize, q: usize) -> [Option<usize>; 4] {
    let (x, y) = (q % w, q / w);
    [(x + 1 < w).then(|| q + 1), (y + 1 < h).then(|| q + w), (x > 0).then(|| q - 1), (y > 0).then(|| q - w)]
}

/// The first 4-neighbour of q (right, down, left, up: fixed order) for which `want` holds.
fn neighbour(w: usize, h: usize, q: usize, want: impl Fn(usize) -> bool) -> Option<usize> {
    neighbours_rdlu(w, h, q).into_iter().flatten().find(|&n| want(n))
}

/// The direction (0 right, 1 down, 2 left, 3 up) from pixel a to its 4-neighbour b.
fn direction(w: usize, a: usize, b: usize) -> u32 {
    if b == a + w {
        1
    } else if b + w == a {
        3
    } else if b == a + 1 {
        0
    } else {
        2
    }
}

/// What a pair (a, b) facing each other across an edge reads besides the colour: both
/// pixels, b's inward pixel (`step` in, whose colour a blends in), their lost-and-found
/// values (a's, b's) and the tie-break (a's region before b's). The same on every run over
/// these edges with the same step and seed: a session keeps it, so a colour change upstream
/// reads only the colours (`Side`). `a` = `NONE`: no pair.
#[derive(Clone, Copy)]
struct Geometry {
    a: u32,
    b: u32,
    b_in: u32,
    lost_found: [f32; 2],
    below: bool,
}

impl Geometry {
    const NONE: Geometry = Geometry { a: u32::MAX, b: 0, b_in: 0, lost_found: [0.0; 2], below: false };
}

/// A pair's values for one run: the colour of b's inward pixel before passage (what a's side
/// blends in) and whether it was painted, whether a's side takes the line, and the line's
/// presence with the lost-and-found value of a (role 0) and of b (role 1).
#[derive(Clone, Copy, Default)]
struct Side {
    across: Vec3,
    painted: bool,
    dark: bool,
    line: [f32; 2],
}

impl Effect for Passage {
    fn name(&self) -> &'static str {
        "passage"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let (w, h) = (canvas.width as usize, canvas.height as usize);
        let md = self.width;
        if w == 0 || h == 0 || !(md > 0.0) {
            return Ok(());
        }
        // Regions (facet << 32 | object): ordered by (facet, object), the tie-break when both
        // sides match in value. The same regions the edges are found in (`PaintContext::regions`:
        // a plane open across the outline is one region).
        let regions = ctx.regions(w * h);
        let key = |i: usize| regions[i];
        let same = |i: usize, j: usize| regions[i] == regions[j];
        // The edges up to md, and as far as the edges' smoothing reads them.
        let edges = ctx.edges(w as u32, h as u32, md.max(edge_smoothing::REACH));
        let dist = &edges.dist;
        // The first run over these edges (a facet or camera change) keeps no geometry: only
        // the runs after it (a paint-only change) read it again.
        let again = edges.passage.get().is_some();
        let pairs = edges.passage.get_or_init(|| Pairs::new(w, h, &edges.near, &same));
        // How far in each side's value is read: a few pixels, at least one.
        let step = (md / 4.0).round().max(1.0) as i64;
        let inward = |from: usize, dx: i64, dy: i64| -> usize {
            let (x, y) = ((from % w) as i64 + dx * step, (from / w) as i64 + dy * step);
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                return from;
            }
            let j = y as usize * w + x as usize;
            if same(j, from) { j } else { from }
        };
        let seed = sub_seed(self.seed, SALT);
        let period = (LOST_PERIOD * ((w * h) as f32).sqrt()).max(4.0);
        let grid = Grid2::new(seed, (0.0, w as f32 / period), (0.0, h as f32 / period));
        // Read where the plane is (`plane_point`): with facets that follow, it moves with them.
        let lost_found = |q: usize| {
            let at = ctx.plane_point(q, w) - 0.5;
            smoothstep(0.25, 0.75, grid.value2(seed, at.x / period, at.y / period))
        };
        let (coverage, px) = canvas.coverage_and_pixels();
        // The colours before (what the other side blends in; alpha is not read) and each
        // region's value (its mean's), read before any pixel changes: a join weighs its two
        // planes, not the strokes' dabs at it, which would turn its line on and off, and from
        // side to side, dab by dab (a dashed, stitched seam).
        let mut means = region_means(px, &regions, &coverage);
        // A sequence's background and open planes take the layout frame's means
        // (`sequence::Held::means`), as the strokes do: the subject moving over part of one
        // must not move its joins' lines far from the subject.
        if let Some(held) = ctx.held().and_then(|h| h.means.as_ref()) {
            means.extend(held.iter().map(|(r, m)| (*r, *m)));
        }
        let value = |i: usize| means.get(&regions[i]).map_or(0.0, |m| luminance(*m).max(0.0));
        // What a pair (a, b) facing each other across an edge reads besides the colour and the
        // two regions' values: b's inward pixel, whose colour a takes where the line is lost
        // (a on the pixel's side; the tie-break's region of the pixel is a's).
        let geometry = |a: usize, b: usize, lost_found: [f32; 2]| -> Geometry {
            let (dx, dy) = ((b % w) as i64 - (a % w) as i64, (b / w) as i64 - (a / w) as i64);
            let (nx, ny) = if dx.abs() >= dy.abs() { (dx.signum(), 0) } else { (0, dy.signum()) };
            let b_in = inward(b, nx, ny);
            Geometry { a: a as u32, b: b as u32, b_in: b_in as u32, lost_found, below: key(a) < key(b) }
        };
        // What a pair gives on this picture: the two sides' values.
        let side = |g: &Geometry| -> Side {
            if g.a == u32::MAX {
                return Side::default();
            }
            let (a, b, b_in) = (g.a as usize, g.b as usize, g.b_in as usize);
            let (va, vb) = (value(a), value(b));
            Side {
                across: px[b_in].truncate(),
                painted: coverage.is_painted(b_in),
                dark: if va != vb { va < vb } else { g.below },
                line: g.lost_found.map(|lf| Passage::line(va, vb, lf)),
            }
        };
        // Each edge pixel's pairs, right, down, left, up (`Pairs::of`).
        let edge_lf = || -> Vec<f32> { pairs.edge_pixels.par_iter().map(|&q| lost_found(q as usize)).collect() };
        let edge_geometry = |edge_lf: &[f32], a: usize, lf_a: f32| -> [Geometry; 4] {
            neighbours_rdlu(w, h, a).map(|b| match b {
                Some(b) if !same(a, b) => {
                    let lf_b = edge_lf.get(pairs.slot[b] as usize).copied().unwrap_or_else(|| lost_found(b));
                    geometry(a, b, [lf_a, lf_b])
                }
                _ => Geometry::NONE,
            })
        };
        let sides: Vec<[Side; 4]> = if ctx.kept_across_chains() && again {
            // A session keeps the geometry from the second run over these edges on: a colour
            // change upstream (a border width) reads only the colours.
            let key = [step as u64, self.seed];
            let g = pairs.geometry(key, || {
                let lf = edge_lf();
                pairs.edge_pixels.par_iter().zip(&lf).map(|(&a, &lf_a)| edge_geometry(&lf, a as usize, lf_a)).collect()
            });
            g.par_iter().map(|g| g.each_ref().map(&side)).collect()
        } else {
            let lf = edge_lf();
            pairs
                .edge_pixels
                .par_iter()
                .zip(&lf)
                .map(|(&a, &lf_a)| edge_geometry(&lf, a as usize, lf_a).each_ref().map(&side))
                .collect()
        };
        let fallback: Vec<Side> = pairs
            .fallback
            .par_iter()
            .map(|&(a, q)| {
                let lf = lost_found(q as usize);
                side(&geometry(a as usize, q as usize, [lf, lf]))
            })
            .collect();
        let transparent = canvas.transparent;
        let (coverage, px) = canvas.coverage_and_pixels();
        // Passage: the sides blend where the line is lost, within md / 2 of the edge.
        let wb = 0.5 * md;
        px.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, p) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let (o, d) = (pairs.of[i], dist[i]);
                if o == NO_PAIR || d >= md {
                    continue;
                }
                let (s, line, d) = if o & FALLBACK != 0 {
                    let s = &fallback[(o & !FALLBACK) as usize];
                    (s, s.line[1], d)
                } else {
                    let k = (o >> 1) as usize;
                    let s = &sides[k / 4][k % 4];
                    let role = (o & 1) as usize;
                    (s, s.line[role], if role == 0 { pairs.to_line(k / 4, i, w, d) } else { d })
                };
                if d < wb && s.painted && coverage.is_painted(i) {
                    let beta = BLEND * (1.0 - line) * (1.0 - d / wb).powi(2);
                    *p = p.truncate().lerp(s.across, beta).extend(p.w);
                }
                if s.dark && self.strength > 0.0 {
                    darken(p, 1.0 - self.strength * line * (1.0 - drawn_line(d, md)), transparent);
                }
            }
        });
        // Last, the edges' pixel steps smoothed (the lines and blends are drawn per pixel).
        edge_smoothing::smooth_edges(canvas, &regions, dist);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::distance::nearest_features;

    /// Each pixel's distance to the line (`Pairs::to_line`) on a `w` x `h` map split by
    /// `region`, against `truth` (x, y -> the distance measured as `to_line` measures it), for
    /// the pixels within 4 of an edge whose pair is of their own region.
    fn worst_miss(
        w: usize,
        h: usize,
        region: impl Fn(usize, usize) -> u32,
        truth: impl Fn(usize, usize) -> f32,
    ) -> f32 {
        let ids: Vec<u32> = (0..w * h).map(|i| region(i % w, i / w)).collect();
        let grid = crate::util::grid::Grid::new(w as u32, h as u32);
        let (dist, near) = nearest_features(w as u32, h as u32, 4.0, |i| grid.on_border(&ids, i));
        let pairs = Pairs::new(w, h, &near, &|i, j| ids[i] == ids[j]);
        let mut worst = 0.0f32;
        for i in 0..w * h {
            let (o, d) = (pairs.of[i], dist[i]);
            let (x, y) = (i % w, i / w);
            if o == NO_PAIR || o & FALLBACK != 0 || o & 1 != 0 || d >= 4.0 || x < 8 || y < 8 || x + 8 > w || y + 8 > h {
                continue;
            }
            let e = (o >> 1) as usize / 4;
            worst = worst.max((pairs.to_line(e, i, w, d) - truth(x, y)).abs());
        }
        worst
    }

    #[test]
    fn along_the_grid_the_distance_to_the_line_is_the_distance_to_the_edge_pixels() {
        let miss =
            worst_miss(40, 30, |x, _| (x >= 20) as u32, |x, _| if x >= 20 { (x - 20) as f32 } else { (19 - x) as f32 });
        assert!(miss < 1e-4, "{miss}");
    }

    #[test]
    fn on_a_slanted_edge_the_distance_is_to_its_true_line() {
        // The line y = 0.6 x + 5 (pixel centres at integer + 0.5), measured from half a pixel in.
        let (a, b) = (0.6f32, 5.0f32);
        let signed = |x: usize, y: usize| ((y as f32 + 0.5) - a * (x as f32 + 0.5) - b) / (1.0 + a * a).sqrt();
        let miss = worst_miss(60, 60, |x, y| (signed(x, y) > 0.0) as u32, |x, y| (signed(x, y).abs() - 0.5).max(0.0));
        assert!(miss < 0.25, "{miss}");
    }
}
