//! The measures of "What we measure", each a pure function of a render's buffers, so
//! each is unit-tested on pictures whose answer is known.

use glam::DVec2;

use crate::facets::planes::outlines::{simplify_chain, simplify_ring};
use crate::facets::{FacetLayout, FacetMap, fill_polygon};

/// Straight planes: the facet boundaries as chains between junctions (points where three or
/// more facets meet, or the image border), through the middles of their pixel edges, each simplified by Douglas-Peucker at `tolerance`
/// pixels; the share of the simplified length on segments at least `min_run` pixels long.
/// Returns (share, total simplified length in pixels); share 1 when there is no boundary.
pub fn straight_share(map: &FacetMap, tolerance: f64, min_run: f64) -> (f64, f64) {
    let (w, h) = (map.width as usize, map.height as usize);
    let id = |x: usize, y: usize| map.ids[y * w + x];
    let vw = w + 1;
    // Boundary edges on the pixel-corner lattice: horizontal edge (x, y) -> (x + 1, y) between
    // pixels (x, y - 1) and (x, y); vertical edge (x, y) -> (x, y + 1) between (x - 1, y) and (x, y).
    let hor = |x: usize, y: usize| y > 0 && y < h && id(x, y - 1) != id(x, y);
    let ver = |x: usize, y: usize| x > 0 && x < w && id(x - 1, y) != id(x, y);
    let mut degree = vec![0u8; vw * (h + 1)];
    for y in 0..=h {
        for x in 0..=w {
            let mut d = 0;
            if x < w && hor(x, y) {
                d += 1;
            }
            if x > 0 && hor(x - 1, y) {
                d += 1;
            }
            if y < h && ver(x, y) {
                d += 1;
            }
            if y > 0 && ver(x, y - 1) {
                d += 1;
            }
            degree[y * vw + x] = d;
        }
    }
    let junction = |x: usize, y: usize| -> bool {
        let d = degree[y * vw + x];
        if d == 0 {
            return false;
        }
        if d != 2 {
            return true;
        }
        // Three facets around the corner make a junction even with two edges (cannot happen
        // for two facets only, but a corner of the image border can).
        let mut around = Vec::with_capacity(4);
        for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let (px, py) = (x as i64 + dx - 1, y as i64 + dy - 1);
            if px >= 0 && py >= 0 && (px as usize) < w && (py as usize) < h {
                let v = id(px as usize, py as usize);
                if !around.contains(&v) {
                    around.push(v);
                }
            }
        }
        around.len() >= 3
    };
    // Visited edges, by key (x, y, vertical?).
    let mut used = vec![false; 2 * vw * (h + 1)];
    let slot = |k: (usize, usize, bool)| 2 * (k.1 * vw + k.0) + k.2 as usize;
    // The edges at a vertex: (edge key, other end).
    type Edge = ((usize, usize, bool), (usize, usize));
    let edges_at = |x: usize, y: usize| -> Vec<Edge> {
        let mut v = Vec::with_capacity(4);
        if x < w && hor(x, y) {
            v.push(((x, y, false), (x + 1, y)));
        }
        if x > 0 && hor(x - 1, y) {
            v.push(((x - 1, y, false), (x - 1, y)));
        }
        if y < h && ver(x, y) {
            v.push(((x, y, true), (x, y + 1)));
        }
        if y > 0 && ver(x, y - 1) {
            v.push(((x, y - 1, true), (x, y - 1)));
        }
        v
    };
    let (mut total, mut straight) = (0.0, 0.0);
    let mut account = |chain: &[DVec2], closed: bool| {
        let simplified = if closed { simplify_ring(chain, tolerance) } else { simplify_chain(chain, tolerance) };
        let n = simplified.len();
        let segs = if closed { n } else { n.saturating_sub(1) };
        for k in 0..segs {
            let len = (simplified[(k + 1) % n] - simplified[k]).length();
            total += len;
            if len >= min_run {
                straight += len;
            }
        }
    };
    let walk = |start: (usize, usize), first: ((usize, usize, bool), (usize, usize)), used: &mut Vec<bool>| {
        // Points at the middle of each boundary pixel edge (as marching squares places them:
        // a digital straight line then stays within ~0.7 px of its chord), with the chain's
        // end vertices.
        let mut chain = vec![DVec2::new(start.0 as f64, start.1 as f64)];
        let (mut key, mut at) = first;
        let mut from = start;
        loop {
            used[slot(key)] = true;
            chain.push(DVec2::new(from.0 as f64 + at.0 as f64, from.1 as f64 + at.1 as f64) * 0.5);
            from = at;
            if junction(at.0, at.1) || at == start {
                chain.push(DVec2::new(at.0 as f64, at.1 as f64));
                break;
            }
            let Some(next) = edges_at(at.0, at.1).into_iter().find(|(k, _)| !used[slot(*k)]) else { break };
            key = next.0;
            at = next.1;
        }
        chain
    };
    for y in 0..=h {
        for x in 0..=w {
            if !junction(x, y) {
                continue;
            }
            for e in edges_at(x, y) {
                if used[slot(e.0)] {
                    continue;
                }
                let chain = walk((x, y), e, &mut used);
                account(&chain, false);
            }
        }
    }
    // Closed loops with no junction (a facet inside another).
    for y in 0..=h {
        for x in 0..=w {
            for e in edges_at(x, y) {
                if used[slot(e.0)] {
                    continue;
                }
                let mut chain = walk((x, y), e, &mut used);
                // Back at the start: a loop of edge midpoints.
                chain.pop();
                chain.remove(0);
                account(&chain, true);
            }
        }
    }
    if total <= 0.0 { (1.0, 0.0) } else { (straight / total, total) }
}

/// Whole-canvas planes: the share of the canvas covered by polygonal facets (polygons or
/// Voronoi sites of the layout; Segment's leftover level-1 segments keep their pixel outline
/// and do not count), rasterised at `width` x `height`.
pub fn plane_coverage(layout: &FacetLayout, width: u32, height: u32) -> f64 {
    if !layout.sites.is_empty() || layout.base.is_none() {
        return 1.0;
    }
    let n = width as usize * height as usize;
    let mut covered = vec![false; n];
    for p in &layout.polygons {
        let pts: Vec<DVec2> = p.points.iter().map(|q| DVec2::new(q[0] * width as f64, q[1] * height as f64)).collect();
        fill_polygon(&pts, width, height, |i| covered[i] = true);
    }
    covered.iter().filter(|&&c| c).count() as f64 / n.max(1) as f64
}

/// The largest facet's share of the canvas.
pub fn largest_facet(map: &FacetMap) -> f64 {
    let mut area = vec![0u64; map.facet_count as usize];
    for &i in &map.ids {
        area[i as usize] += 1;
    }
    area.iter().copied().max().unwrap_or(0) as f64 / map.ids.len().max(1) as f64
}

/// Subject fill: (mean coverage of the pre-render, i.e. the share of the canvas showing
/// geometry; the share of the canvas taken by the bounding box of pixels more than half
/// covered).
pub fn subject_fill(coverage: &[f32], width: u32, height: u32) -> (f64, f64) {
    let (w, h) = (width as usize, height as usize);
    let fill = coverage.iter().map(|&c| c.clamp(0.0, 1.0) as f64).sum::<f64>() / coverage.len().max(1) as f64;
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for (i, &c) in coverage.iter().enumerate() {
        if c > 0.5 {
            let (x, y) = (i % w, i / w);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
    }
    let bbox = if x0 == usize::MAX { 0.0 } else { ((x1 - x0 + 1) * (y1 - y0 + 1)) as f64 / (w * h).max(1) as f64 };
    (fill, bbox)
}

/// Ghost share: the share of the canvas showing geometry in the final image where the
/// pre-render showed background, in facets whose view was re-aimed: the sum over pixels of
/// re-aimed facets of max(0, final coverage - pre-render coverage), over the canvas.
pub fn ghost_share(map: &FacetMap, moved: &[bool], pre: &[f32], fin: &[f32]) -> f64 {
    let mut s = 0.0;
    for (i, &id) in map.ids.iter().enumerate() {
        if moved.get(id as usize).copied().unwrap_or(false) {
            s += (fin[i] - pre[i]).max(0.0) as f64;
        }
    }
    s / map.ids.len().max(1) as f64
}

/// Per-plane light: the share of facets (of at least `min_pixels`) whose luminance `lum`
/// varies across them by a gradient of at least `min_range` of the image's range (its 1st to
/// 99th percentile): a least-squares plane L = a + b x + c y over the facet's pixels whose
/// values span at least that over the facet, and which explains at least `min_r2` of the
/// facet's variance (a gradient, not noise or a stray edge). Returns (share, facets counted).
pub fn plane_light(map: &FacetMap, lum: &[f32], min_pixels: usize, min_range: f64, min_r2: f64) -> (f64, usize) {
    let n = map.facet_count as usize;
    let w = map.width as usize;
    let mut sorted: Vec<f32> = lum.to_vec();
    sorted.sort_by(f32::total_cmp);
    let q = |p: f64| sorted.get(((sorted.len().saturating_sub(1)) as f64 * p) as usize).copied().unwrap_or(0.0) as f64;
    let range = (q(0.99) - q(0.01)).max(1e-6);
    // Sums for the normal equations, per facet (x, y centred on the facet later).
    #[derive(Clone, Copy, Default)]
    struct S {
        n: f64,
        x: f64,
        y: f64,
        xx: f64,
        xy: f64,
        yy: f64,
        l: f64,
        xl: f64,
        yl: f64,
        ll: f64,
    }
    let mut s = vec![S::default(); n];
    for (i, &id) in map.ids.iter().enumerate() {
        let (x, y, l) = ((i % w) as f64, (i / w) as f64, lum[i] as f64);
        let t = &mut s[id as usize];
        t.n += 1.0;
        t.x += x;
        t.y += y;
        t.xx += x * x;
        t.xy += x * y;
        t.yy += y * y;
        t.l += l;
        t.xl += x * l;
        t.yl += y * l;
        t.ll += l * l;
    }
    // Slopes (b, c) per facet from the centred normal equations.
    // (slope b, slope c, mean x, mean y, r²), or None for too few pixels.
    type Fit = (f64, f64, f64, f64, f64);
    let fits: Vec<Option<Fit>> = s
        .iter()
        .map(|t| {
            if (t.n as usize) < min_pixels.max(3) {
                return None;
            }
            let (mx, my, ml) = (t.x / t.n, t.y / t.n, t.l / t.n);
            let sxx = t.xx - t.n * mx * mx;
            let sxy = t.xy - t.n * mx * my;
            let syy = t.yy - t.n * my * my;
            let sxl = t.xl - t.n * mx * ml;
            let syl = t.yl - t.n * my * ml;
            let sll = t.ll - t.n * ml * ml;
            let det = sxx * syy - sxy * sxy;
            if det.abs() < 1e-9 {
                return None;
            }
            let b = (sxl * syy - syl * sxy) / det;
            let c = (syl * sxx - sxl * sxy) / det;
            let explained = b * sxl + c * syl;
            let r2 = if sll > 1e-12 { explained / sll } else { 0.0 };
            Some((b, c, mx, my, r2))
        })
        .collect();
    // The fitted plane's span over each facet's own pixels.
    let mut span = vec![(f64::INFINITY, f64::NEG_INFINITY); n];
    for (i, &id) in map.ids.iter().enumerate() {
        if let Some((b, c, mx, my, _)) = fits[id as usize] {
            let v = b * ((i % w) as f64 - mx) + c * ((i / w) as f64 - my);
            let e = &mut span[id as usize];
            *e = (e.0.min(v), e.1.max(v));
        }
    }
    let (mut counted, mut lit) = (0usize, 0usize);
    for f in 0..n {
        if let Some((_, _, _, _, r2)) = fits[f] {
            counted += 1;
            if span[f].1 - span[f].0 >= min_range * range && r2 >= min_r2 {
                lit += 1;
            }
        }
    }
    (if counted == 0 { 0.0 } else { lit as f64 / counted as f64 }, counted)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::facets::FacetPolygon;
    use crate::facets::voronoi;

    fn map(w: u32, h: u32, f: impl Fn(u32, u32) -> u32) -> FacetMap {
        let ids: Vec<u32> = (0..w * h).map(|i| f(i % w, i / w)).collect();
        let facet_count = ids.iter().max().unwrap() + 1;
        FacetMap { width: w, height: h, ids, facet_count }
    }

    #[test]
    fn a_straight_diagonal_is_all_straight_and_a_staircase_of_big_steps_is_not() {
        let m = map(200, 100, |x, y| (2 * y > x) as u32);
        let (s, len) = straight_share(&m, 1.0, 10.0);
        assert!(s > 0.99, "{s}");
        assert!((len - (200f64.powi(2) + 100f64.powi(2)).sqrt()).abs() < 3.0, "{len}");
        // Steps of 6 px: every simplified segment is shorter than 10 px.
        let m = map(120, 120, |x, y| ((y / 6) > (x / 6)) as u32);
        let (s, _) = straight_share(&m, 1.0, 10.0);
        assert!(s < 0.05, "{s}");
    }

    #[test]
    fn junctions_split_chains() {
        // Three vertical stripes and a 30 px horizontal cut through the middle one: four
        // vertical chains of 50 px between the junctions, one of 30 px.
        let m = map(90, 100, |x, y| {
            if x < 30 {
                0
            } else if x < 60 {
                1 + (y >= 50) as u32
            } else {
                3
            }
        });
        let (s, len) = straight_share(&m, 1.0, 25.0);
        assert!((len - 230.0).abs() < 2.0, "{len}");
        assert!((s - 1.0).abs() < 1e-9);
        let (s, _) = straight_share(&m, 1.0, 40.0);
        assert!((s - 200.0 / len).abs() < 0.01, "{s}");
        let (s, _) = straight_share(&m, 1.0, 60.0);
        assert!((s - 0.0).abs() < 1e-9, "a 50 px chain is not a 60 px run: {s}");
    }

    #[test]
    fn an_enclosed_facet_is_a_closed_loop() {
        let m = map(50, 50, |x, y| ((10..40).contains(&x) && (10..40).contains(&y)) as u32);
        let (s, len) = straight_share(&m, 1.0, 5.0);
        // Through the edge middles, each corner is cut by half a pixel.
        assert!((len - 120.0).abs() < 3.0, "{len}");
        assert!((s - 1.0).abs() < 1e-9);
    }

    #[test]
    fn voronoi_is_mostly_straight() {
        let l = voronoi::layout(150, 15, 4.0 / 3.0, 0);
        let m = l.rasterize(640, 480);
        let (s, _) = straight_share(&m, 1.0, 8.0);
        assert!(s > 0.9, "{s}");
    }

    #[test]
    fn coverage_largest_fill_ghosts() {
        let layout = FacetLayout {
            facet_count: 2,
            base: Some(crate::facets::LabelImage { width: 1, height: 1, labels: vec![0] }),
            sites: vec![],
            polygons: vec![FacetPolygon { facet: 1, points: vec![[0.0, 0.0], [0.5, 0.0], [0.5, 1.0], [0.0, 1.0]] }],
        };
        assert!((plane_coverage(&layout, 10, 10) - 0.5).abs() < 1e-12);
        let m = layout.rasterize(10, 10);
        assert!((largest_facet(&m) - 0.5).abs() < 1e-12);
        let pre: Vec<f32> = (0..100).map(|i| if i % 10 < 2 { 1.0 } else { 0.0 }).collect();
        let (fill, bbox) = subject_fill(&pre, 10, 10);
        assert!((fill - 0.2).abs() < 1e-6 && (bbox - 0.2).abs() < 1e-12);
        // Facet 1 (left half) re-aimed: its 30 background pixels now show geometry.
        let fin: Vec<f32> = (0..100).map(|i| if i % 10 < 5 { 1.0 } else { 0.0 }).collect();
        assert!((ghost_share(&m, &[false, true], &pre, &fin) - 0.3).abs() < 1e-6);
        assert_eq!(ghost_share(&m, &[false, false], &pre, &fin), 0.0);
    }

    #[test]
    fn plane_light_counts_gradients_not_noise_or_flat() {
        let m = map(60, 20, |x, _| x / 20);
        let lum: Vec<f32> = (0..1200u32)
            .map(|i| {
                let (x, y) = (i % 60, i / 60);
                match x / 20 {
                    0 => 0.2 + 0.03 * (x % 20) as f32,                    // a gradient across facet 0
                    1 => 0.5 + if (x + y) % 2 == 0 { 0.3 } else { -0.3 }, // noise
                    _ => 0.6,                                             // flat
                }
            })
            .collect();
        let (share, counted) = plane_light(&m, &lum, 50, 0.15, 0.3);
        assert_eq!(counted, 3);
        assert!((share - 1.0 / 3.0).abs() < 1e-9, "{share}");
    }
}
