//! The planes' scaffolding: the canvas split recursively by straight lines (a binary space
//! partition), heaviest plane first, until there are `count` planes.
//!
//! Why lines and not a Voronoi diagram: a relaxed Voronoi diagram is a honeycomb of even
//! hexagons, which reads as crazy paving. The 1909-1912 canvases are built on a scaffolding
//! of long straight strokes, mostly near-vertical, near-horizontal and steep diagonals, that
//! run on across several planes and stop on one another (T-junctions), giving wedges,
//! trapezoids and long triangles; the contours of the figure are extended into the ground.
//! A split of a convex plane by a line gives exactly that: the first splits cross the whole
//! canvas, later ones stop on earlier ones, every edge is straight, and the planes tile the
//! canvas with no gap or overlap.
//!
//! Each split picks among candidate lines: the long straight runs of the subject's outline
//! that cross the plane (the painters' extended contours), and a few seeded lines of the
//! painters' directions (`DIRECTIONS`, jittered) through the plane's weighted centre. A
//! candidate is refused when it would leave a piece thinner than `min_width`; of the rest,
//! the one that best balances the two pieces' weights and keeps them compact wins, outline
//! runs with a bonus.

use std::collections::BinaryHeap;

use glam::DVec2;

use super::polygon::{clip_half_plane, signed_area};
use crate::util::rng::rand01;

const STREAM: u64 = 0x0073_706c_6974; // "split"
/// Preferred stroke directions, degrees from the horizontal, with their weights: the
/// canvases' scaffolding is mostly verticals and horizontals, then steep diagonals, a few
/// shallow ones.
const DIRECTIONS: [(f64, f64); 7] =
    [(90.0, 0.2), (0.0, 0.12), (72.0, 0.16), (108.0, 0.16), (55.0, 0.12), (125.0, 0.12), (20.0, 0.12)];
/// Jitter of a direction, degrees either way.
const JITTER_DEG: f64 = 8.0;
/// Seeded direction candidates per split.
const RANDOM_CANDIDATES: usize = 6;
/// Score lost by a line crossing the salient features (`Weights::protect`), at
/// `PROTECT_CELLS` cells crossed and more: a feature stays whole in one plane unless no
/// other line divides the plane.
const PROTECT_PENALTY: f64 = 1.6;
const PROTECT_CELLS: f64 = 2.0;
/// Score bonus of a line along the subject's outline (the score's other terms are in [0, 2.5]).
const OUTLINE_BONUS: f64 = 0.6;

/// A straight run of the subject's outline (pixel units), from `a` to `b`.
#[derive(Clone, Copy, Debug)]
pub struct Run {
    pub a: DVec2,
    pub b: DVec2,
}

/// Weight (integral of the density) of a convex polygon, from the density grid: sample the
/// grid cells whose centres fall inside, plus the polygon's area times the density at its
/// centroid when it covers no cell centre.
pub struct Weights<'a> {
    pub columns: usize,
    pub rows: usize,
    pub values: &'a [f64],
    /// 1 on the cells of the salient features (`density::Cues::protect`), which lines avoid;
    /// empty: none.
    pub protect: &'a [f64],
    /// Canvas size, pixels.
    pub width: f64,
    pub height: f64,
}

impl Weights<'_> {
    fn density_at(&self, p: DVec2) -> f64 {
        let x = ((p.x / self.width * self.columns as f64) as usize).min(self.columns - 1);
        let y = ((p.y / self.height * self.rows as f64) as usize).min(self.rows - 1);
        self.values[y * self.columns + x]
    }

    /// The protected cells the segment from `a` to `b` (pixel units) crosses, sampled at half
    /// a cell.
    fn crossed(&self, a: DVec2, b: DVec2) -> f64 {
        if self.protect.is_empty() {
            return 0.0;
        }
        let cell = (self.width / self.columns as f64).min(self.height / self.rows as f64);
        let n = (((b - a).length() / (0.5 * cell)).ceil() as usize).max(1);
        let mut last = usize::MAX;
        let mut count = 0.0;
        for k in 0..=n {
            let p = a + (b - a) * (k as f64 / n as f64);
            let x = ((p.x / self.width * self.columns as f64) as usize).min(self.columns - 1);
            let y = ((p.y / self.height * self.rows as f64) as usize).min(self.rows - 1);
            let i = y * self.columns + x;
            if i != last {
                count += self.protect[i];
                last = i;
            }
        }
        count
    }

    /// Whether `poly` (pixel units) covers the centre of a protected cell.
    pub fn touches_protected(&self, poly: &[DVec2]) -> bool {
        if self.protect.is_empty() {
            return false;
        }
        let (sx, sy) = (self.width / self.columns as f64, self.height / self.rows as f64);
        let grid: Vec<DVec2> = poly.iter().map(|p| DVec2::new(p.x / sx, p.y / sy)).collect();
        let mut hit = false;
        crate::facets::fill_polygon(&grid, self.columns as u32, self.rows as u32, |i| hit |= self.protect[i] > 0.0);
        hit
    }

    /// (weight, weighted centroid) of `poly` (pixel units).
    fn of(&self, poly: &[DVec2]) -> (f64, DVec2) {
        let (sx, sy) = (self.width / self.columns as f64, self.height / self.rows as f64);
        let grid: Vec<DVec2> = poly.iter().map(|p| DVec2::new(p.x / sx, p.y / sy)).collect();
        let (mut wsum, mut c) = (0.0, DVec2::ZERO);
        crate::facets::fill_polygon(&grid, self.columns as u32, self.rows as u32, |i| {
            let v = self.values[i];
            wsum += v;
            c += v * DVec2::new(((i % self.columns) as f64 + 0.5) * sx, ((i / self.columns) as f64 + 0.5) * sy);
        });
        if wsum > 0.0 {
            return (wsum * sx * sy, c / wsum);
        }
        let g = centroid(poly);
        (signed_area(poly).abs() * self.density_at(g), g)
    }
}

/// Area centroid of a polygon (the vertex mean for a degenerate one).
pub fn centroid(poly: &[DVec2]) -> DVec2 {
    let n = poly.len();
    let (mut a, mut c) = (0.0, DVec2::ZERO);
    for k in 0..n {
        let (p, q) = (poly[k], poly[(k + 1) % n]);
        let cross = p.x * q.y - q.x * p.y;
        a += cross;
        c += (p + q) * cross;
    }
    if a.abs() < 1e-12 {
        return poly.iter().copied().sum::<DVec2>() / n.max(1) as f64;
    }
    c / (3.0 * a)
}

/// Extent of a convex polygon along unit direction `u`: (min, max) of p . u.
fn extent(poly: &[DVec2], u: DVec2) -> (f64, f64) {
    poly.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.dot(u)), hi.max(p.dot(u))))
}

/// The width of a convex polygon: its smallest extent over its own edge normals (exact for
/// convex polygons: the minimum-width direction is normal to an edge).
pub fn width(poly: &[DVec2]) -> f64 {
    let n = poly.len();
    let mut best = f64::INFINITY;
    for k in 0..n {
        let d = poly[(k + 1) % n] - poly[k];
        let Some(u) = DVec2::new(-d.y, d.x).try_normalize() else { continue };
        let (lo, hi) = extent(poly, u);
        best = best.min(hi - lo);
    }
    if best.is_finite() { best } else { 0.0 }
}

/// Its longest extent over the same directions and the ones along its edges: with `width`,
/// an elongation measure.
fn length(poly: &[DVec2]) -> f64 {
    let n = poly.len();
    let mut best: f64 = 0.0;
    for k in 0..n {
        let Some(u) = (poly[(k + 1) % n] - poly[k]).try_normalize() else { continue };
        let (lo, hi) = extent(poly, u);
        best = best.max(hi - lo);
    }
    best
}

/// Splits convex `poly` by the line through `p` with unit direction `d`: the two sides.
pub fn cut(poly: &[DVec2], p: DVec2, d: DVec2) -> (Vec<DVec2>, Vec<DVec2>) {
    let n = DVec2::new(-d.y, d.x);
    (clip_half_plane(poly, p, n), clip_half_plane(poly, p, -n))
}

struct Leaf {
    poly: Vec<DVec2>,
    weight: f64,
    centre: DVec2,
}

/// Max-heap entry: the highest priority first, ties to the lower index.
#[derive(PartialEq)]
struct Entry(f64, usize);
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&o.0).then(o.1.cmp(&self.1))
    }
}

/// Splits the `width` x `height` canvas into `count` convex planes, heaviest first (fewer when
/// no plane can be split without a piece thinner than `min_width`), splitting on past `count`
/// while a plane is larger than `max_area`. Deterministic for `seed`.
pub fn split(
    weights: &Weights,
    runs: &[Run],
    count: usize,
    min_width: f64,
    max_area: f64,
    seed: u64,
) -> Vec<Vec<DVec2>> {
    let (w, h) = (weights.width, weights.height);
    let canvas = vec![DVec2::new(0.0, 0.0), DVec2::new(w, 0.0), DVec2::new(w, h), DVec2::new(0.0, h)];
    let leaf = |poly: Vec<DVec2>| {
        let (weight, centre) = weights.of(&poly);
        Leaf { poly, weight, centre }
    };
    // Oversized planes come first whatever their weight.
    let priority = |l: &Leaf| if signed_area(&l.poly).abs() > max_area { f64::INFINITY } else { l.weight };
    let mut leaves = vec![leaf(canvas)];
    let mut heap = BinaryHeap::new();
    heap.push(Entry(priority(&leaves[0]), 0));
    let mut live = 1;
    let mut splits = 0u64;
    // Every cut's ends (T-junctions and crossings): a later cut ending near one ends on it.
    let mut ends: Vec<DVec2> = Vec::new();
    let snap = SNAP_SHARE * min_width;
    while let Some(Entry(p, i)) = heap.pop() {
        if live >= count && p.is_finite() {
            break;
        }
        splits += 1;
        if let Some((a, b)) = best_cut(&leaves[i], weights, runs, min_width, seed, splits, &mut ends, snap) {
            leaves[i].poly.clear();
            live += 1;
            for q in [a, b] {
                let l = leaf(q);
                heap.push(Entry(priority(&l), leaves.len()));
                leaves.push(l);
            }
        }
    }
    leaves.into_iter().filter(|l| !l.poly.is_empty()).map(|l| l.poly).collect()
}

/// The best valid cut of `leaf` (see the module doc), or None.
/// A seeded cut's ends closer than this share of `min_width` to an earlier cut's end (or a
/// plane's corner) on the plane's boundary move onto it: without it, two junctions a few
/// pixels apart leave a boundary too short to read as a straight stroke (the largest share of
/// the facet-boundary length off straight runs).
pub const SNAP_SHARE: f64 = 0.6;

/// Where the line through `p` along `d` enters and leaves convex `poly`.
fn chord(poly: &[DVec2], p: DVec2, d: DVec2) -> Option<(DVec2, DVec2)> {
    let n = DVec2::new(-d.y, d.x);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    let k = poly.len();
    for i in 0..k {
        let (a, b) = (poly[i], poly[(i + 1) % k]);
        let (sa, sb) = ((a - p).dot(n), (b - p).dot(n));
        if (sa <= 0.0 && sb >= 0.0) || (sa >= 0.0 && sb <= 0.0) {
            let q = if (sa - sb).abs() > 0.0 { a + (b - a) * (sa / (sa - sb)) } else { a };
            let t = (q - p).dot(d);
            lo = lo.min(t);
            hi = hi.max(t);
        }
    }
    (lo < hi).then(|| (p + d * lo, p + d * hi))
}

/// Whether `q` lies on the boundary of `poly` (within `eps`).
fn on_boundary(poly: &[DVec2], q: DVec2, eps: f64) -> bool {
    let k = poly.len();
    (0..k).any(|i| {
        let (a, b) = (poly[i], poly[(i + 1) % k]);
        let ab = b - a;
        let t = ((q - a).dot(ab) / ab.length_squared().max(1e-300)).clamp(0.0, 1.0);
        (a + ab * t - q).length() <= eps
    })
}

/// The chord `(e0, e1)` of `poly` with each end moved onto the nearest point of `ends` or
/// corner of `poly` on its boundary within `snap` (ties to the earlier point); None when
/// neither moves or the moved ends would not span the plane.
fn snapped(poly: &[DVec2], e: (DVec2, DVec2), ends: &[DVec2], snap: f64) -> Option<(DVec2, DVec2)> {
    if snap <= 0.0 {
        return None;
    }
    let eps = 1e-6 * (1.0 + e.0.length().max(e.1.length()));
    let near = |q: DVec2| {
        let mut best: Option<(f64, DVec2)> = None;
        for &v in poly.iter().chain(ends.iter()) {
            let dist = (v - q).length();
            if dist <= snap && best.is_none_or(|(b, _)| dist < b) && on_boundary(poly, v, eps) {
                best = Some((dist, v));
            }
        }
        best.map(|(_, v)| v)
    };
    let (a, b) = (near(e.0), near(e.1));
    if a.is_none() && b.is_none() {
        return None;
    }
    let (a, b) = (a.unwrap_or(e.0), b.unwrap_or(e.1));
    ((b - a).length() > 2.0 * snap).then_some((a, b))
}

#[allow(clippy::too_many_arguments)]
fn best_cut(
    leaf: &Leaf,
    weights: &Weights,
    runs: &[Run],
    min_width: f64,
    seed: u64,
    index: u64,
    ends: &mut Vec<DVec2>,
    snap: f64,
) -> Option<(Vec<DVec2>, Vec<DVec2>)> {
    let poly = &leaf.poly;
    let mut candidates: Vec<(DVec2, DVec2, f64)> = Vec::new(); // (point, direction, bonus)
    // Outline runs whose middle lies inside the plane, longest first (at most three).
    let mut inside: Vec<&Run> = runs.iter().filter(|r| contains(poly, (r.a + r.b) * 0.5)).collect();
    inside.sort_by(|x, y| (y.b - y.a).length_squared().total_cmp(&(x.b - x.a).length_squared()));
    for r in inside.iter().take(3) {
        if let Some(d) = (r.b - r.a).try_normalize() {
            candidates.push(((r.a + r.b) * 0.5, d, OUTLINE_BONUS));
        }
    }
    let l = length(poly).max(1e-9);
    for k in 0..RANDOM_CANDIDATES {
        let s = index * 16 + k as u64;
        let mut u = rand01(seed, STREAM, 4 * s) * DIRECTIONS.iter().map(|d| d.1).sum::<f64>();
        let mut base = DIRECTIONS[0].0;
        for &(angle, weight) in &DIRECTIONS {
            base = angle;
            if u < weight {
                break;
            }
            u -= weight;
        }
        let angle = base + JITTER_DEG * (2.0 * rand01(seed, STREAM, 4 * s + 1) - 1.0);
        let d = DVec2::new(angle.to_radians().cos(), -angle.to_radians().sin());
        let n = DVec2::new(-d.y, d.x);
        let offset = 0.15 * l * (2.0 * rand01(seed, STREAM, 4 * s + 2) - 1.0);
        candidates.push((leaf.centre + n * offset, d, 0.0));
    }
    let area = |p: &[DVec2]| signed_area(p).abs();
    // (score, the two pieces, the cut's ends)
    type Best = (f64, Vec<DVec2>, Vec<DVec2>, Option<(DVec2, DVec2)>);
    let mut best: Option<Best> = None;
    for (p, d, bonus) in candidates {
        // Seeded lines end on the earlier cuts' ends near them, so no two junctions sit a few
        // pixels apart (a boundary too short to read as a straight stroke); lines along the
        // outline stay on it.
        let mut line = (p, d);
        let e = chord(poly, p, d);
        if bonus == 0.0
            && let Some(e) = e
            && let Some((a, b)) = snapped(poly, e, ends, snap)
            && let Some(d) = (b - a).try_normalize()
        {
            line = (a, d);
        }
        let (p, d) = line;
        let (a, b) = cut(poly, p, d);
        if a.len() < 3 || b.len() < 3 || area(&a) < 1e-9 || area(&b) < 1e-9 {
            continue;
        }
        let (wa, wb) = (width(&a), width(&b));
        if wa < min_width || wb < min_width {
            continue;
        }
        // Balance of the pieces' weights, by area as a proxy (cheap, and the weight follows).
        let share = area(&a) / (area(&a) + area(&b));
        let balance = 1.0 - (2.0 * share - 1.0).abs();
        let elong = |q: &[DVec2], wq: f64| (wq / length(q).max(1e-9)).min(1.0);
        let compact = 0.5 * (elong(&a, wa) + elong(&b, wb));
        // Trapezoids and quadrilaterals over triangles: a field of triangles reads as
        // shattered glass, not as planes.
        let sides = 0.25 * ((a.len() >= 4) as u8 + (b.len() >= 4) as u8) as f64;
        let e = chord(poly, p, d);
        let crossed = e.map_or(0.0, |(e0, e1)| weights.crossed(e0, e1));
        let score = balance + compact + sides + bonus * (balance > 0.2) as u8 as f64
            - PROTECT_PENALTY * (crossed / PROTECT_CELLS).min(1.0);
        if best.as_ref().is_none_or(|(s, _, _, _)| score > *s) {
            best = Some((score, a, b, e));
        }
    }
    best.map(|(_, a, b, e)| {
        if let Some((e0, e1)) = e {
            ends.extend([e0, e1]);
        }
        (a, b)
    })
}

/// Whether `p` lies inside convex `poly` (either orientation).
fn contains(poly: &[DVec2], p: DVec2) -> bool {
    let n = poly.len();
    let (mut pos, mut neg) = (false, false);
    for k in 0..n {
        let (a, b) = (poly[k], poly[(k + 1) % n]);
        let c = (b - a).perp_dot(p - a);
        pos |= c > 0.0;
        neg |= c < 0.0;
    }
    !(pos && neg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_tile_the_canvas_and_respect_the_width() {
        let values = vec![1.0; 40 * 30];
        let wts = Weights { columns: 40, rows: 30, values: &values, protect: &[], width: 400.0, height: 300.0 };
        let leaves = split(&wts, &[], 60, 8.0, 0.08 * 120000.0, 3);
        assert!(leaves.len() >= 50 && leaves.len() <= 61, "{}", leaves.len());
        let total: f64 = leaves.iter().map(|l| signed_area(l).abs()).sum();
        assert!((total - 120000.0).abs() < 1e-6, "{total}");
        assert!(leaves.iter().all(|l| width(l) >= 8.0 - 1e-9));
        assert!(leaves.iter().all(|l| signed_area(l).abs() <= 0.08 * 120000.0 + 1e-6));
        assert_eq!(leaves, split(&wts, &[], 60, 8.0, 0.08 * 120000.0, 3));
    }

    #[test]
    fn planes_are_smaller_where_the_density_is_higher() {
        // Density 8 on the left half, 1 on the right.
        let values: Vec<f64> = (0..40 * 30).map(|i| if i % 40 < 20 { 8.0 } else { 1.0 }).collect();
        let wts = Weights { columns: 40, rows: 30, values: &values, protect: &[], width: 400.0, height: 300.0 };
        let leaves = split(&wts, &[], 80, 4.0, 1e9, 1);
        let left = leaves.iter().filter(|l| centroid(l).x < 200.0).count();
        assert!(left > 2 * (leaves.len() - left), "{left} of {}", leaves.len());
    }

    #[test]
    fn cut_ends_never_sit_a_few_pixels_apart() {
        // Seeded cuts end on earlier ends near them: any two distinct corners of the planes are
        // at least the snap distance apart (an end nearer would have moved onto the other).
        let values: Vec<f64> = (0..40 * 30).map(|i| 1.0 + ((i * 7919) % 13) as f64).collect();
        let wts = Weights { columns: 40, rows: 30, values: &values, protect: &[], width: 640.0, height: 480.0 };
        let min_width = 16.0;
        let leaves = split(&wts, &[], 150, min_width, 0.08 * 640.0 * 480.0, 5);
        let mut corners: Vec<DVec2> = leaves.iter().flatten().copied().collect();
        corners.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
        corners.dedup_by(|a, b| (*a - *b).length() < 1e-6);
        let snap = SNAP_SHARE * min_width;
        let mut closest = f64::INFINITY;
        for (i, a) in corners.iter().enumerate() {
            for b in &corners[i + 1..] {
                closest = closest.min((*a - *b).length());
            }
        }
        assert!(closest >= snap - 1e-6, "corners {closest:.2} px apart (snap {snap})");
        let total: f64 = leaves.iter().map(|l| signed_area(l).abs()).sum();
        assert!((total - 640.0 * 480.0).abs() < 1e-3, "{total}");
    }

    #[test]
    fn an_outline_run_becomes_a_cut() {
        let values = vec![1.0; 40 * 30];
        let wts = Weights { columns: 40, rows: 30, values: &values, protect: &[], width: 400.0, height: 300.0 };
        // A long diagonal run through the canvas: some plane edge lies along it.
        let run = Run { a: DVec2::new(100.0, 50.0), b: DVec2::new(300.0, 250.0) };
        let leaves = split(&wts, &[run], 4, 8.0, 1e9, 1);
        let on_line = |p: DVec2| ((p - run.a).perp_dot((run.b - run.a).normalize())).abs() < 1e-6;
        assert!(leaves.iter().any(|l| l.iter().filter(|p| on_line(**p)).count() >= 2));
    }

    #[test]
    fn lines_keep_off_the_salient_features() {
        // A salient blob of 4 x 4 cells in the middle: with it protected, fewer planes share it.
        let values = vec![1.0; 40 * 30];
        let blob = |i: usize| (18..22).contains(&(i % 40)) && (13..17).contains(&(i / 40));
        let protect: Vec<f64> = (0..40 * 30).map(|i| blob(i) as u8 as f64).collect();
        let sharing = |protect: &[f64]| {
            let wts = Weights { columns: 40, rows: 30, values: &values, protect, width: 400.0, height: 300.0 };
            let leaves = split(&wts, &[], 40, 8.0, 1e9, 7);
            let inside = |l: &Vec<DVec2>| {
                (180..220)
                    .step_by(4)
                    .any(|x| (130..170).step_by(4).any(|y| contains(l, DVec2::new(x as f64 + 0.5, y as f64 + 0.5))))
            };
            leaves.iter().filter(|l| inside(l)).count()
        };
        let (free, kept) = (sharing(&[]), sharing(&protect));
        assert!(kept < free, "planes over the feature: {kept} protected, {free} not");
    }
}
