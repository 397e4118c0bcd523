//! Patch faceting (thesis 4.3.1, Fig. 4.4): convex quadrilaterals painted in
//! succession, later ones occluding earlier ones, until every pixel is covered.
//!
//! Edge length a..2a with a = sqrt(2 w h r_occ / (5 n_p)) (eq 4.3). Each quad's centre is a
//! random pixel not yet covered; its corners are one random point from each of the four
//! regions around the centre: corner = centre + (+-u, +-v) with u, v uniform in [a/2, a], so
//! adjacent corners are a..2a apart along the edge's main axis (Fig. 4.4).
//!
//! The quads are generated on a canvas of about 1000 x 1000 pixels with the image's aspect
//! (the project's "pixels at 1000 px" convention) and stored in normalised coordinates, so a
//! preview and the final render of one seed share one layout, whatever their resolutions.

use glam::DVec2;

use super::{FacetLayout, FacetPolygon, MAX_FACETS, fill_polygon};
use crate::error::{Error, Result};
use crate::util::rng::rand01;
use crate::util::rng::splitmix64;

const STREAM: u64 = 0x0070_6174_6368; // "patch"

/// Canvas size for an aspect ratio: w h ~ 10^6, w / h = aspect.
pub fn canvas(aspect: f64) -> (u32, u32) {
    let w = (1000.0 * aspect.sqrt()).round().clamp(1.0, 1.0e7) as u32;
    let h = (1000.0 / aspect.sqrt()).round().clamp(1.0, 1.0e7) as u32;
    (w.max(1), h.max(1))
}

/// Eq 4.3: the quads' base edge length a, pixels of a w x h canvas.
pub fn edge_length(w: u32, h: u32, r_occ: f64, n_p: u32) -> f64 {
    (2.0 * w as f64 * h as f64 * r_occ / (5.0 * n_p.max(1) as f64)).sqrt()
}

/// The quadrilateral around `c` (pixel coordinates) for quad number `q`: one corner per
/// quadrant, in angular order, so it contains `c` and is convex (see the property test).
pub fn quad(c: DVec2, a: f64, seed: u64, q: u64) -> [DVec2; 4] {
    let r = |k: u64| a * (0.5 + 0.5 * rand01(seed, STREAM, q * 8 + k));
    // Quadrants in angular order (y down): (+,+), (-,+), (-,-), (+,-).
    [c + DVec2::new(r(0), r(1)), c + DVec2::new(-r(2), r(3)), c + DVec2::new(-r(4), -r(5)), c + DVec2::new(r(6), -r(7))]
}

/// Paints quads in succession until every canvas pixel is covered. The next centre is the
/// first uncovered pixel in a seeded random permutation of the canvas: a uniform draw among
/// the uncovered pixels, in O(1) amortised per draw.
pub fn layout(n_p: u32, r_occ: f64, aspect: f64, seed: u64) -> Result<FacetLayout> {
    let (w, h) = canvas(aspect);
    let a = edge_length(w, h, r_occ, n_p);
    let n = w as usize * h as usize;
    let mut order: Vec<u32> = (0..n as u32).collect();
    // Fisher-Yates with a counter-based hash: the same permutation everywhere.
    for i in (1..n).rev() {
        let j = (splitmix64(seed ^ splitmix64(STREAM ^ (i as u64))) % (i as u64 + 1)) as usize;
        order.swap(i, j);
    }
    let mut covered = vec![false; n];
    let mut polygons = Vec::new();
    for &p in &order {
        if covered[p as usize] {
            continue;
        }
        let q = polygons.len() as u32;
        if q >= MAX_FACETS {
            return Err(Error::setting(
                "occlusion",
                format!(
                    "patch faceting needs more than {MAX_FACETS} quadrilaterals to cover the image; \
                     raise --occlusion or lower --patch-count"
                ),
            ));
        }
        let c = DVec2::new((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
        let corners = quad(c, a, seed, q as u64);
        fill_polygon(&corners, w, h, |i| covered[i] = true);
        // The centre lies inside its quad, so this only guards rounding on a pixel boundary.
        covered[p as usize] = true;
        polygons.push(FacetPolygon {
            facet: q,
            points: corners.iter().map(|v| [v.x / w as f64, v.y / h as f64]).collect(),
        });
    }
    Ok(FacetLayout { facet_count: polygons.len() as u32, base: None, sites: Vec::new(), polygons })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn cross(o: DVec2, a: DVec2, b: DVec2) -> f64 {
        (a - o).perp_dot(b - o)
    }

    #[test]
    fn eq_4_3() {
        // a = sqrt(2 w h r_occ / (5 n_p)): 1000 x 1000, r_occ 3, n_p 80 -> sqrt(15000).
        assert!((edge_length(1000, 1000, 3.0, 80) - 15000f64.sqrt()).abs() < 1e-9);
        assert_eq!(canvas(1.0), (1000, 1000));
        let (w, h) = canvas(16.0 / 9.0);
        assert!(((w * h) as f64 - 1e6).abs() < 2e3 && (w as f64 / h as f64 - 16.0 / 9.0).abs() < 1e-2);
    }

    proptest! {
        #[test]
        fn quads_are_convex_contain_their_centre_and_have_edges_a_to_2a(
            seed in 0u64..1000, q in 0u64..1000, a in 1.0f64..300.0,
        ) {
            let c = DVec2::new(500.0, 400.0);
            let p = quad(c, a, seed, q);
            for k in 0..4 {
                let (p0, p1, p2) = (p[k], p[(k + 1) % 4], p[(k + 2) % 4]);
                // Same turn direction at every corner: convex.
                prop_assert!(cross(p0, p1, p2) > 0.0, "corner {} is reflex: {:?}", k, p);
                // The centre is on the inner side of every edge.
                prop_assert!(cross(p0, p1, c) > 0.0);
                let len = (p1 - p0).length();
                prop_assert!(len >= a * (1.0 - 1e-9) && len <= 2.0 * a * 1.0308, "edge {} = {} for a = {}", k, len, a);
            }
        }
    }

    #[test]
    fn paints_until_covered_at_any_size() {
        let l = layout(80, 3.0, 4.0 / 3.0, 11).unwrap();
        assert!(l.validate().is_ok());
        assert!(l.facet_count >= 20, "{} quads", l.facet_count);
        assert_eq!(l, layout(80, 3.0, 4.0 / 3.0, 11).unwrap(), "seeded");
        for (w, h) in [(40, 30), (400, 300), (1155, 866)] {
            let m = l.rasterize(w, h);
            // Rasterised at its own canvas size every pixel is covered by some quad; at other
            // sizes a few sliver pixels may take a neighbour's facet. Most facets stay visible.
            assert!(m.used_facets() as f64 >= 0.5 * l.facet_count as f64 || w < 100, "{w}x{h}");
        }
    }

    #[test]
    fn more_occlusion_means_bigger_quads() {
        let few = layout(80, 6.0, 1.0, 1).unwrap().facet_count;
        let many = layout(80, 1.0, 1.0, 1).unwrap().facet_count;
        assert!(many > few, "r_occ 1: {many} quads, r_occ 6: {few}");
    }
}
