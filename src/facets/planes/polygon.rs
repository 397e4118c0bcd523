//! Plane geometry for the planes faceting: clipping a polygon by a half-plane
//! (Sutherland-Hodgman), by a convex polygon, signed areas.
//!
//! Hand-written because it is a few dozen lines of textbook code over `glam`'s vectors, and the
//! polygon crates (geo, i_overlay) bring their own number types and a heavy dependency tree for
//! the one operation needed here: cutting a ring by the lines of a convex plane.

use glam::DVec2;

/// Keeps the part of `ring` on the side of the line through `a` with normal `n` where
/// (p - a) . n <= 0 (Sutherland-Hodgman, one edge). Works on any ring, convex or not: inside
/// the half-plane, a point's even-odd membership is unchanged, and what is cut off becomes
/// edges lying on the line (degenerate, zero-area), which the even-odd fill ignores.
pub fn clip_half_plane(ring: &[DVec2], a: DVec2, n: DVec2) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(ring.len() + 4);
    if ring.is_empty() {
        return out;
    }
    let side = |p: DVec2| (p - a).dot(n);
    let mut prev = ring[ring.len() - 1];
    let mut prev_s = side(prev);
    for &p in ring {
        let s = side(p);
        if s <= 0.0 {
            if prev_s > 0.0 {
                out.push(prev + (p - prev) * (prev_s / (prev_s - s)));
            }
            out.push(p);
        } else if prev_s <= 0.0 {
            out.push(prev + (p - prev) * (prev_s / (prev_s - s)));
        }
        prev = p;
        prev_s = s;
    }
    out
}

/// Clips `ring` to the convex polygon `cell` (either orientation).
pub fn clip_to_convex(ring: &[DVec2], cell: &[DVec2]) -> Vec<DVec2> {
    let orient = signed_area(cell).signum();
    let mut r = ring.to_vec();
    for k in 0..cell.len() {
        if r.is_empty() {
            break;
        }
        let (a, b) = (cell[k], cell[(k + 1) % cell.len()]);
        let d = b - a;
        // Outward normal of edge a -> b for this orientation.
        let n = DVec2::new(d.y, -d.x) * orient;
        r = clip_half_plane(&r, a, n);
    }
    r
}

/// Signed area (shoelace): positive for counter-clockwise rings in a y-up frame, i.e. clockwise
/// on screen (y down).
pub fn signed_area(ring: &[DVec2]) -> f64 {
    let n = ring.len();
    if n < 3 {
        return 0.0;
    }
    let mut s = 0.0;
    for k in 0..n {
        let (a, b) = (ring[k], ring[(k + 1) % n]);
        s += a.x * b.y - b.x * a.y;
    }
    0.5 * s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<DVec2> {
        vec![DVec2::new(x0, y0), DVec2::new(x1, y0), DVec2::new(x1, y1), DVec2::new(x0, y1)]
    }

    #[test]
    fn half_plane_clip_of_a_square() {
        let s = square(0.0, 0.0, 2.0, 2.0);
        let c = clip_half_plane(&s, DVec2::new(1.0, 0.0), DVec2::X);
        assert!((signed_area(&c).abs() - 2.0).abs() < 1e-12, "{c:?}");
        assert!(c.iter().all(|p| p.x <= 1.0 + 1e-12));
        assert!(clip_half_plane(&s, DVec2::new(-1.0, 0.0), DVec2::X).is_empty());
        assert_eq!(clip_half_plane(&s, DVec2::new(3.0, 0.0), DVec2::X).len(), 4);
    }

    #[test]
    fn convex_clip_keeps_the_intersection_of_a_concave_ring() {
        // An L-shaped ring (area 3) clipped to the unit square at its corner: area 1.
        let l = vec![
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(2.0, 1.0),
            DVec2::new(1.0, 1.0),
            DVec2::new(1.0, 2.0),
            DVec2::new(0.0, 2.0),
        ];
        assert!((signed_area(&l).abs() - 3.0).abs() < 1e-12);
        let c = clip_to_convex(&l, &square(0.5, 0.5, 1.5, 1.5));
        assert!((signed_area(&c).abs() - 0.75).abs() < 1e-12, "{}", signed_area(&c));
        // Reversed cell orientation gives the same.
        let mut cell = square(0.5, 0.5, 1.5, 1.5);
        cell.reverse();
        assert!((signed_area(&clip_to_convex(&l, &cell)).abs() - 0.75).abs() < 1e-12);
    }
}
