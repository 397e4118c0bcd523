//! Passage (ART.md "Each plane has its own light", issue 13): where two planes meet, one side
//! is a hard dark line and the other dissolves into the neighbour, so the surface shimmers in
//! shallow relief instead of every border blurring evenly on both sides (eq 4.8 darkens both
//! sides alike: the blind panel's "dark halo outlines").
//!
//! Edges are the facet borders and the objects' silhouettes (a pixel whose 4-neighbour shows
//! another facet or another object, the background counting as one), so the subject's
//! contours are drawn the same way, without the silhouette halo. For every pixel within md
//! of an edge, the feature transform (`distance::nearest_features`) gives the nearest edge
//! pixel, hence the pair of pixels facing each other across the edge, and each side's value
//! a little way in:
//! - the darker side takes the line: eq 4.8's darkening (a quarter of the colour on the edge,
//!   rising steeply, gone at md) on that side only, so the line's edge against the other
//!   side is crisp and it fades into its own plane;
//! - the line's strength follows the two sides' value contrast (planes of the same value
//!   meet softly) and a seeded, slowly varying "lost and found" along the edges, as a
//!   painter's line comes and goes;
//! - where the line is weak the two sides blend into each other across the edge (passage
//!   proper: the edge dissolves).
//!
//! The side decision counts the ramp the per-plane light will lay on each side (it runs after
//! the palette), so a plane's dark end takes the line against its neighbour's light end.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::borders::border_factor;
use super::noise::Grid2;
use super::plane_light::PlaneLight;
use super::planes::smoothstep;
use super::{Canvas, Effect, PaintContext, darken, luminance};
use crate::distance::NO_FEATURE;
use crate::error::Result;
use crate::util::rng::sub_seed;

const SALT: u64 = 0x7061_7373_6167_6531; // "passage1"
/// Share of a line's strength kept where both sides have the same value.
pub const FLOOR: f32 = 0.45;
/// Relative value difference (|a - b| / max) at which a line has its full strength.
pub const FULL_CONTRAST: f32 = 0.25;
/// Lost and found: along the edges a line's strength varies between this share and 1 ...
pub const LOST: f32 = 0.25;
/// ... over about this share of the image's size sqrt(w h).
pub const LOST_PERIOD: f32 = 0.05;
/// Largest share of the other side's colour a pixel takes on an edge whose line is lost.
pub const BLEND: f32 = 0.5;

/// How facet borders are drawn (`PaintParams::border_style`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BorderStyle {
    /// Eq 4.8 on both sides of every facet border (`borders::Borders`), as the thesis prints it.
    Symmetric,
    /// One side, lost and found, with passage; object silhouettes too (`Passage`).
    Passage,
}

/// One-sided, lost-and-found borders with passage.
pub struct Passage {
    /// md, pixels of this image: the line fades out this far into its plane.
    pub width: f32,
    /// In [0, 1]: 1 = eq 4.8's full darkening where the line is strongest.
    pub strength: f32,
    pub seed: u64,
    /// The per-plane light's amount (0 = off), whose ramps count in the side decision.
    pub plane_light: f32,
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
        let ids = ctx.facets.map(|f| &f.ids[..]);
        // Regions (facet << 32 | object): ordered by (facet, object), the tie-break when both
        // sides match in value.
        // (A one-off render reads the facet ids and hits instead: no regions buffer held.)
        let regions = ctx.inputs_kept().then(|| ctx.regions(w * h));
        let hits = (ctx.hits.len() == w * h).then_some(ctx.hits);
        let ids = ids.filter(|d| d.len() == w * h);
        let key = |i: usize| match &regions {
            Some(r) => r[i],
            None => ((ids.map_or(0, |d| d[i]) as u64) << 32) | hits.map_or(0, |o| o[i].object) as u64,
        };
        let same = |i: usize, j: usize| match &regions {
            Some(r) => r[i] == r[j],
            None => ids.is_none_or(|d| d[i] == d[j]) && hits.is_none_or(|o| o[i].object == o[j].object),
        };
        let edges = ctx.edges(w as u32, h as u32, md);
        let (dist, near) = (&edges.dist, &edges.near);
        // The colours before (what the other side blends in; alpha is not read).
        let before: Vec<Vec3> = canvas.px.par_iter().map(|p| p.truncate()).collect();
        let lum: Vec<f32> = before.par_iter().map(|p| luminance(*p).max(0.0)).collect();
        // A 4-neighbour of q (right, down, left, up: fixed order) that is (`want` = true) or
        // is not in the region of `of`.
        let neighbour = |q: usize, of: usize, want: bool| -> Option<usize> {
            let (x, y) = (q % w, q / w);
            [(x + 1 < w).then(|| q + 1), (y + 1 < h).then(|| q + w), (x > 0).then(|| q - 1), (y > 0).then(|| q - w)]
                .into_iter()
                .flatten()
                .find(|&n| same(n, of) == want)
        };
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
        // The per-plane light's factor at a pixel (1 when it is off).
        let ramps = (self.plane_light > 0.0).then(|| {
            (PlaneLight { amount: self.plane_light, seed: self.seed }, ctx.planes(w as u32, w * h, self.seed))
        });
        let ramp = |i: usize| match (&ramps, ids) {
            (Some((light, planes)), Some(ids)) => {
                light.at(&planes[ids[i] as usize], Vec2::new((i % w) as f32 + 0.5, (i / w) as f32 + 0.5))
            }
            _ => 1.0,
        };
        let seed = sub_seed(self.seed, SALT);
        let period = (LOST_PERIOD * ((w * h) as f32).sqrt()).max(4.0);
        let grid = Grid2::new(seed, (0.0, w as f32 / period), (0.0, h as f32 / period));
        // What a pair (a, b) facing each other across an edge gives: b's inward pixel and
        // the two sides' values (a on the pixel's side; the tie-break's region of the pixel
        // is a's); and the lost-and-found value of each edge pixel q. Each depends on the
        // pair or the edge pixel alone, so it is computed once per edge pixel (`memo` for
        // the four neighbours b of an edge pixel a) instead of once per pixel near it.
        let sides = |a: usize, b: usize| -> (usize, f32, f32) {
            let (dx, dy) = ((b % w) as i64 - (a % w) as i64, (b / w) as i64 - (a / w) as i64);
            let (nx, ny) = if dx.abs() >= dy.abs() { (dx.signum(), 0) } else { (0, dy.signum()) };
            let (a_in, b_in) = (inward(a, -nx, -ny), inward(b, nx, ny));
            let va = 0.5 * (lum[a] + lum[a_in]) * ramp(a);
            let vb = 0.5 * (lum[b] + lum[b_in]) * ramp(b);
            (b_in, va, vb)
        };
        let lost_found =
            |q: usize| smoothstep(0.25, 0.75, grid.value2(seed, (q % w) as f32 / period, (q / w) as f32 / period));
        // Edge pixels are their own nearest edge pixel.
        let mut slot = vec![u32::MAX; w * h];
        let mut edge_pixels = Vec::new();
        for (i, s) in slot.iter_mut().enumerate() {
            if near[i] as usize == i {
                *s = edge_pixels.len() as u32;
                edge_pixels.push(i);
            }
        }
        struct Memo {
            lost_found: f32,
            /// Per neighbour b (right, down, left, up) of a: (b_in, va, vb); b_in u32::MAX
            /// where there is no such neighbour in another region.
            pairs: [(u32, f32, f32); 4],
        }
        let memo: Vec<Memo> = edge_pixels
            .par_iter()
            .map(|&a| {
                let (x, y) = (a % w, a / w);
                let nb = [
                    (x + 1 < w).then(|| a + 1),
                    (y + 1 < h).then(|| a + w),
                    (x > 0).then(|| a - 1),
                    (y > 0).then(|| a - w),
                ];
                Memo {
                    lost_found: lost_found(a),
                    pairs: nb.map(|b| {
                        b.filter(|&b| !same(a, b)).map_or((u32::MAX, 0.0, 0.0), |b| {
                            let (b_in, va, vb) = sides(a, b);
                            (b_in as u32, va, vb)
                        })
                    }),
                }
            })
            .collect();
        // The memo of adjacent pixels a, b in different regions, or None.
        let memo_of = |a: usize, b: usize| -> Option<(usize, f32, f32)> {
            let m = memo.get(slot[a] as usize)?;
            let k = if b == a + 1 {
                0
            } else if b == a + w {
                1
            } else if b + 1 == a {
                2
            } else if b + w == a {
                3
            } else {
                return None;
            };
            let (b_in, va, vb) = m.pairs[k];
            (b_in != u32::MAX).then_some((b_in as usize, va, vb))
        };
        let transparent = canvas.transparent;
        let (coverage, px) = canvas.coverage_and_pixels();
        px.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, p) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let (q, d) = (near[i], dist[i]);
                if q == NO_FEATURE || d >= md {
                    continue;
                }
                let q = q as usize;
                // The pair facing each other across the edge: a on this pixel's side, b across.
                let (a, b) = if same(i, q) {
                    match neighbour(q, q, false) {
                        Some(b) => (q, b),
                        None => continue,
                    }
                } else {
                    (neighbour(q, i, true).unwrap_or(i), q)
                };
                // key(i) is key(a): a is this pixel or a pixel of its region.
                let (b_in, va, vb) = memo_of(a, b).unwrap_or_else(|| sides(a, b));
                let dark_side = if va != vb { va < vb } else { key(a) < key(b) };
                let lf = memo.get(slot[q] as usize).map_or_else(|| lost_found(q), |m| m.lost_found);
                let line = Passage::line(va, vb, lf);
                // Passage: the sides blend where the line is lost, within md / 2 of the edge.
                let wb = 0.5 * md;
                if d < wb && coverage.is_painted(i) && coverage.is_painted(b_in) {
                    let beta = BLEND * (1.0 - line) * (1.0 - d / wb).powi(2);
                    *p = p.truncate().lerp(before[b_in], beta).extend(p.w);
                }
                if dark_side && self.strength > 0.0 {
                    darken(p, 1.0 - self.strength * line * (1.0 - border_factor(d, md)), transparent);
                }
            }
        });
        Ok(())
    }
}
