//! Step 4: rings simplified (Douglas-Peucker, between junctions) and short edges merged.

use glam::DVec2;

use super::junctions::Junctions;

/// Douglas-Peucker simplification of a closed ring at `tolerance`: split at the point farthest
/// from the first, simplify both chains. Returns fewer than 3 points for a ring that collapses.
pub fn simplify_ring(ring: &[DVec2], tolerance: f64) -> Vec<DVec2> {
    let n = ring.len();
    if n < 4 {
        return ring.to_vec();
    }
    let far = (1..n)
        .max_by(|&a, &b| (ring[a] - ring[0]).length_squared().total_cmp(&(ring[b] - ring[0]).length_squared()))
        .unwrap_or(n / 2);
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[far] = true;
    let chain_a: Vec<usize> = (0..=far).collect();
    let chain_b: Vec<usize> = (far..n).chain(std::iter::once(0)).collect();
    for chain in [&chain_a, &chain_b] {
        dp(ring, chain, tolerance, &mut keep);
    }
    (0..n).filter(|&i| keep[i]).map(|i| ring[i]).collect()
}

/// Douglas-Peucker simplification of an open chain at `tolerance`, its two ends kept.
pub fn simplify_chain(chain: &[DVec2], tolerance: f64) -> Vec<DVec2> {
    let n = chain.len();
    if n < 3 {
        return chain.to_vec();
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    let all: Vec<usize> = (0..n).collect();
    dp(chain, &all, tolerance, &mut keep);
    (0..n).filter(|&i| keep[i]).map(|i| chain[i]).collect()
}

/// Removes corners of a closed ring until every edge is at least `min_edge` long (or the ring
/// is a triangle): of the shortest edge's two ends, the corner nearer the line through its
/// neighbours goes (the one whose removal moves the outline least). A curve traced pixel by
/// pixel simplifies to many short edges where it bends; each would be drawn as a facet border
/// too short to read as a straight stroke (runs of at least 1% of the diagonal).
pub fn merge_short_edges(ring: Vec<DVec2>, min_edge: f64) -> Vec<DVec2> {
    merge_short(ring, true, min_edge)
}

/// `merge_short_edges` of a closed ring (`closed`) or of an open chain whose two ends stay
/// (a stretch between two junctions, `simplify_between`): an edge at an end loses its other
/// corner.
pub(super) fn merge_short(mut points: Vec<DVec2>, closed: bool, min_edge: f64) -> Vec<DVec2> {
    let min2 = min_edge * min_edge;
    let least = if closed { 3 } else { 2 };
    while points.len() > least {
        let n = points.len();
        let edges = if closed { n } else { n - 1 };
        let (k, len2) = (0..edges)
            .map(|k| (k, (points[(k + 1) % n] - points[k]).length_squared()))
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
            .unwrap_or((0, f64::INFINITY));
        if len2 >= min2 {
            break;
        }
        // Distance of corner i from the line through its neighbours.
        let off = |i: usize| {
            let (p, q, r) = (points[(i + n - 1) % n], points[i], points[(i + 1) % n]);
            let d = r - p;
            let len = d.length();
            if len > 0.0 { (d.perp_dot(q - p)).abs() / len } else { (q - p).length() }
        };
        let (a, b) = (k, (k + 1) % n);
        // An open chain's ends stay: with more than two points, every edge has a corner
        // between the ends.
        let drop = if !closed && a == 0 {
            b
        } else if !closed && b == n - 1 {
            a
        } else if off(b) < off(a) {
            b
        } else {
            a
        };
        points.remove(drop);
    }
    points
}

/// `simplify_ring` then `merge_short_edges` of a traced ring (corners on the pixel-corner
/// lattice), split at every junction it passes (`Junctions`): each stretch between two
/// junctions is simplified on its own with its ends kept, at its junctions' group points. A
/// stretch of boundary two layers share is the same lattice path between the same two
/// junctions in both, so it comes out the same in both, and the planes the layers cut meet on
/// one line instead of leaving slivers and kinks between two simplifications of it (each
/// within `tolerance`, on different sides). A stretch within one group no longer than the
/// junctions' `reach` is dropped (its ends are one point). A ring through no junction is simplified whole,
/// as before (its start is its first vertex in scan order, the same in every layer).
pub(super) fn simplify_between(ring: &[DVec2], junctions: &Junctions, tolerance: f64, min_edge: f64) -> Vec<DVec2> {
    let n = ring.len();
    // The corners, and every junction along the edges between them: (point, group, lattice
    // steps from the ring's start).
    let mut points: Vec<(DVec2, Option<u32>, usize)> = Vec::with_capacity(n);
    let mut walked = 0;
    for k in 0..n {
        let (p, q) = (ring[k], ring[(k + 1) % n]);
        let (x0, y0) = (p.x as i64, p.y as i64);
        let (dx, dy) = ((q.x as i64 - x0).signum(), (q.y as i64 - y0).signum());
        let steps = (q.x as i64 - x0).abs().max((q.y as i64 - y0).abs());
        for s in 0..steps {
            let (x, y) = (x0 + dx * s, y0 + dy * s);
            match junctions.group_at(x, y) {
                Some(g) => points.push((junctions.point[g as usize], Some(g), walked)),
                None if s == 0 => points.push((p, None, walked)),
                None => {}
            }
            walked += 1;
        }
    }
    let Some(first) = points.iter().position(|p| p.1.is_some()) else {
        return merge_short_edges(simplify_ring(ring, tolerance), min_edge);
    };
    points.rotate_left(first);
    let m = points.len();
    let mut out = Vec::with_capacity(m);
    let mut a = 0;
    while a < m {
        let b = (a + 1..m).find(|&i| points[i].1.is_some()).unwrap_or(m);
        let end = points[b % m];
        let length = (end.2 + if b == m { walked } else { 0 }) - points[a].2;
        if end.1 == points[a].1 && length as f64 <= junctions.reach {
            a = b;
            continue;
        }
        let chain: Vec<DVec2> = (a..=b).map(|i| points[i % m].0).collect();
        let merged = merge_short(simplify_chain(&chain, tolerance), false, min_edge);
        // The chain's end is the next one's start.
        out.extend_from_slice(&merged[..merged.len() - 1]);
        a = b;
    }
    out
}

/// Douglas-Peucker over `ring[chain[..]]`, marking kept points (iterative, no recursion depth).
pub(super) fn dp(ring: &[DVec2], chain: &[usize], tol: f64, keep: &mut [bool]) {
    let mut stack = vec![(0usize, chain.len() - 1)];
    while let Some((a, b)) = stack.pop() {
        if b <= a + 1 {
            continue;
        }
        let (p, q) = (ring[chain[a]], ring[chain[b]]);
        let d = q - p;
        let len = d.length();
        let mut best = (0.0, a);
        for k in a + 1..b {
            let r = ring[chain[k]] - p;
            let dist = if len > 0.0 { (d.x * r.y - d.y * r.x).abs() / len } else { r.length() };
            if dist > best.0 {
                best = (dist, k);
            }
        }
        if best.0 > tol {
            keep[chain[best.1]] = true;
            stack.push((a, best.1));
            stack.push((best.1, b));
        }
    }
}
