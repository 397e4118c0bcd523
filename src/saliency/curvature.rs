//! Mean curvature per vertex: the cotangent Laplacian with mixed Voronoi areas (Meyer, Desbrun,
//! Schroeder, Barr 2003), projected on the vertex normal; boundary vertices take their interior
//! neighbours' curvature (Lee et al. 2005: "boundary vertices (hole rims) must not spike").
//!
//! Why this estimator: it is the standard discrete mean-curvature operator (convergent on
//! well-shaped meshes, exact on planes), needs only the one ring, and its mixed area stays
//! positive on obtuse triangles. Why the projection `H = (K . n) / 2` rather than `|K| / 2`:
//! on a rim, or under irregular sampling, `K` gains a large tangential component that is no
//! curvature at all (public implementations using `|K|` put the bunny's most salient vertices
//! on its hole rims); the normal component is the mean curvature and keeps its sign (ridge vs
//! valley). Why rims are filled from the interior: a one-sided ring misses half of the
//! Laplacian, so its estimate is biased whatever is done with it; the surface's curvature
//! there is best known from the nearest complete rings.

use glam::DVec3;
use rayon::prelude::*;

use super::surface::Surface;

/// Per-vertex signed mean curvature of a surface (1/length, positive on convex parts when the
/// triangles wind counter-clockwise seen from outside).
#[derive(Clone, Debug)]
pub struct Curvature {
    pub h: Vec<f64>,
    /// Whether `h` was estimated from the vertex's own complete ring (false: a boundary or
    /// zero-area vertex whose value was filled from its neighbours).
    pub estimated: Vec<bool>,
}

/// A triangle whose doubled area is below this fraction of its squared perimeter scale is
/// degenerate: its cotangents are meaningless, so it contributes nothing.
const DEGENERATE: f64 = 1e-12;

/// One triangle's contribution to one corner: the cotangent Laplacian's terms, the mixed area,
/// the (area-weighted) face normal.
struct Corner {
    lap: DVec3,
    area: f64,
    normal: DVec3,
}

/// Corner `c` (0, 1, 2) of triangle `t`'s contribution, None when the triangle is degenerate:
/// its cotangents are meaningless, so it contributes nothing. Only that corner's terms are
/// formed (each by the same operations in the same order whichever corner is asked for).
#[inline(always)]
fn corner(s: &Surface, t: &[u32; 3], c: usize) -> Option<Corner> {
    let [i, j, k] = t.map(|x| x as usize);
    let (pi, pj, pk) = (s.positions[i], s.positions[j], s.positions[k]);
    let (eij, eik, ejk) = (pj - pi, pk - pi, pk - pj);
    let cross = eij.cross(eik);
    let c2 = cross.length();
    let (lij, lik, ljk) = (eij.length_squared(), eik.length_squared(), ejk.length_squared());
    let scale = lij + lik + ljk;
    if !(c2 > DEGENERATE * scale) {
        return None;
    }
    // Cotangent of the angle at each corner: dot / |cross| of the two edges leaving it.
    let cot_i = eij.dot(eik) / c2;
    let cot_j = (-eij).dot(ejk) / c2;
    let cot_k = eik.dot(ejk) / c2;
    let lap = match c {
        0 => cot_k * (pi - pj) + cot_j * (pi - pk),
        1 => cot_k * (pj - pi) + cot_i * (pj - pk),
        _ => cot_j * (pk - pi) + cot_i * (pk - pj),
    };
    let a = 0.5 * c2;
    // Mixed area (Meyer Fig. 4): Voronoi area for non-obtuse triangles, else A/2 at the
    // obtuse corner and A/4 at the others.
    let area = if cot_i < 0.0 || cot_j < 0.0 || cot_k < 0.0 {
        if [cot_i, cot_j, cot_k][c] < 0.0 { a / 2.0 } else { a / 4.0 }
    } else {
        match c {
            0 => (lij * cot_k + lik * cot_j) / 8.0,
            1 => (lij * cot_k + ljk * cot_i) / 8.0,
            _ => (lik * cot_j + ljk * cot_i) / 8.0,
        }
    };
    Some(Corner { lap, area, normal: cross })
}

/// Cotangent-Laplacian mean curvature (Meyer et al. 2003, eq. 8 with the mixed area of Fig. 4),
/// `H = (K . n) / 2` with `K = L / (2 A_mixed)`, `L = sum_j (cot a_ij + cot b_ij)(x_i - x_j)` and
/// `n` the area-weighted normal. See the module doc for why.
pub fn mean_curvature(s: &Surface, edges: &[(u32, u32, u32)]) -> Curvature {
    let n = s.len();
    // Each vertex sums its triangles' contributions in triangle order (what a sequential loop
    // over the triangles adds), in parallel over vertices: the same bits on any thread count.
    let mut start = vec![0u32; n + 1];
    for t in &s.triangles {
        for &i in t {
            start[i as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut incident = vec![0u32; s.triangles.len() * 3];
    for (ti, t) in s.triangles.iter().enumerate() {
        for (k, &i) in t.iter().enumerate() {
            incident[fill[i as usize] as usize] = (ti * 3 + k) as u32;
            fill[i as usize] += 1;
        }
    }
    drop(fill);
    let mut boundary = vec![false; n];
    for &(a, b, count) in edges {
        if count == 1 {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
    }
    // Each triangle's corner terms are computed at each of its three vertices rather than
    // stored: `corner` is a pure function (the same bits as a stored copy), and the copies
    // (176 bytes a triangle) cost more in fresh pages and memory traffic than the arithmetic.
    let (mut h, estimated): (Vec<f64>, Vec<bool>) = (0..n)
        .into_par_iter()
        .map(|v| {
            if boundary[v] {
                return (0.0, false);
            }
            let (mut lap, mut area, mut normal) = (DVec3::ZERO, 0.0f64, DVec3::ZERO);
            for &c in &incident[start[v] as usize..start[v + 1] as usize] {
                if let Some(corner) = corner(s, &s.triangles[c as usize / 3], c as usize % 3) {
                    lap += corner.lap;
                    normal += corner.normal;
                    area += corner.area;
                }
            }
            let nrm = normal.normalize_or_zero();
            if !(area > 0.0) || nrm == DVec3::ZERO {
                return (0.0, false);
            }
            let value = lap.dot(nrm) / (4.0 * area);
            if value.is_finite() { (value, true) } else { (0.0, false) }
        })
        .unzip();
    fill_from_neighbours(&mut h, &estimated, edges);
    Curvature { h, estimated }
}

/// Gives each vertex without an estimate the mean of its neighbours that have one, ring by
/// ring (Jacobi order: each round reads only earlier rounds, so the result is order-free).
/// Vertices no estimate reaches keep 0.
fn fill_from_neighbours(h: &mut [f64], estimated: &[bool], edges: &[(u32, u32, u32)]) {
    let n = h.len();
    let mut known: Vec<bool> = estimated.to_vec();
    if known.iter().all(|&k| k) {
        return;
    }
    loop {
        let mut sum = vec![0.0f64; n];
        let mut count = vec![0u32; n];
        for &(a, b, _) in edges {
            let (a, b) = (a as usize, b as usize);
            if known[a] && !known[b] {
                sum[b] += h[a];
                count[b] += 1;
            }
            if known[b] && !known[a] {
                sum[a] += h[b];
                count[a] += 1;
            }
        }
        let mut progressed = false;
        for v in 0..n {
            if !known[v] && count[v] > 0 {
                h[v] = sum[v] / count[v] as f64;
                known[v] = true;
                progressed = true;
            }
        }
        if !progressed {
            break;
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use glam::Vec3;

    /// An icosphere of `levels` subdivisions, radius `r`, as positions and triangles.
    pub fn icosphere(levels: u32, r: f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let m = crate::scene::default::icosphere("icosphere", levels, r, 0);
        (m.positions, m.triangles)
    }

    fn curvature_of(p: &[Vec3], t: &[[u32; 3]]) -> (Surface, Curvature) {
        let s = Surface::new(p, t);
        let e = s.edges();
        let c = mean_curvature(&s, &e);
        (s, c)
    }

    #[test]
    fn sphere_has_mean_curvature_one_over_r() {
        for r in [0.5f32, 2.0] {
            let (p, t) = icosphere(3, r);
            let (_, c) = curvature_of(&p, &t);
            for h in &c.h {
                assert!((h * r as f64 - 1.0).abs() < 0.02, "H r = {}", h * r as f64);
            }
            assert!(c.estimated.iter().all(|&e| e));
        }
    }

    #[test]
    fn inverted_winding_flips_the_sign() {
        let (p, t) = icosphere(2, 1.0);
        let flipped: Vec<[u32; 3]> = t.iter().map(|[a, b, c]| [*a, *c, *b]).collect();
        let (_, c) = curvature_of(&p, &flipped);
        assert!(c.h.iter().all(|h| (h + 1.0).abs() < 0.03));
    }

    /// A grid of (n+1)^2 vertices over [-1,1]^2 at height f(x, y).
    pub fn height_grid(n: u32, f: impl Fn(f32, f32) -> f32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (-1.0 + 2.0 * i as f32 / n as f32, -1.0 + 2.0 * j as f32 / n as f32);
                p.push(Vec3::new(x, y, f(x, y)));
            }
        }
        let mut t = Vec::new();
        let id = |i: u32, j: u32| j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                t.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                t.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        (p, t)
    }

    #[test]
    fn plane_is_flat_even_at_its_boundary() {
        let (p, t) = height_grid(10, |_, _| 0.0);
        let (_, c) = curvature_of(&p, &t);
        assert!(c.h.iter().all(|h| h.abs() < 1e-9));
        assert_eq!(c.estimated.iter().filter(|e| !**e).count(), 40);
    }

    #[test]
    fn cylinder_has_half_the_sphere_curvature() {
        // Open cylinder of radius 1: H = 1/2; its two rims must not spike.
        let (rings, seg) = (20u32, 48u32);
        let mut p = Vec::new();
        for j in 0..=rings {
            for i in 0..seg {
                let a = i as f32 / seg as f32 * std::f32::consts::TAU;
                p.push(Vec3::new(a.cos(), -1.0 + 2.0 * j as f32 / rings as f32, -a.sin()));
            }
        }
        let mut t = Vec::new();
        for j in 0..rings {
            for i in 0..seg {
                let (a, b) = (j * seg + i, j * seg + (i + 1) % seg);
                t.push([a, b, b + seg]);
                t.push([a, b + seg, a + seg]);
            }
        }
        let (_, c) = curvature_of(&p, &t);
        for h in &c.h {
            assert!((h - 0.5).abs() < 0.01, "H = {h}");
        }
    }

    #[test]
    fn spherical_cap_rim_does_not_spike() {
        // The upper half of an icosphere: its rim vertices keep the sphere's curvature.
        let (p, t) = icosphere(3, 1.0);
        let cap: Vec<[u32; 3]> = t.into_iter().filter(|f| f.iter().all(|&i| p[i as usize].y > -0.05)).collect();
        let (_, c) = curvature_of(&p, &cap);
        assert!(c.estimated.iter().any(|e| !e));
        for h in &c.h {
            assert!((h - 1.0).abs() < 0.05, "H = {h}");
        }
    }

    /// The estimator as a plain serial loop: every triangle's three corners formed together and
    /// added to its vertices in triangle order (the layout `mean_curvature` had before it formed
    /// each corner at its vertex), then the same projection and rim filling.
    fn reference_curvature(s: &Surface, edges: &[(u32, u32, u32)]) -> Vec<f64> {
        let n = s.len();
        let (mut lap, mut area, mut normal) = (vec![DVec3::ZERO; n], vec![0.0f64; n], vec![DVec3::ZERO; n]);
        for t in &s.triangles {
            let [i, j, k] = t.map(|x| x as usize);
            let (pi, pj, pk) = (s.positions[i], s.positions[j], s.positions[k]);
            let (eij, eik, ejk) = (pj - pi, pk - pi, pk - pj);
            let cross = eij.cross(eik);
            let c2 = cross.length();
            let scale = eij.length_squared() + eik.length_squared() + ejk.length_squared();
            if !(c2 > DEGENERATE * scale) {
                continue;
            }
            let cot_i = eij.dot(eik) / c2;
            let cot_j = (-eij).dot(ejk) / c2;
            let cot_k = eik.dot(ejk) / c2;
            let l = [
                cot_k * (pi - pj) + cot_j * (pi - pk),
                cot_k * (pj - pi) + cot_i * (pj - pk),
                cot_j * (pk - pi) + cot_i * (pk - pj),
            ];
            let a = 0.5 * c2;
            let ar = if cot_i < 0.0 || cot_j < 0.0 || cot_k < 0.0 {
                [cot_i, cot_j, cot_k].map(|c| if c < 0.0 { a / 2.0 } else { a / 4.0 })
            } else {
                let (lij, lik, ljk) = (eij.length_squared(), eik.length_squared(), ejk.length_squared());
                [
                    (lij * cot_k + lik * cot_j) / 8.0,
                    (lij * cot_k + ljk * cot_i) / 8.0,
                    (lik * cot_j + ljk * cot_i) / 8.0,
                ]
            };
            for (c, v) in [i, j, k].into_iter().enumerate() {
                lap[v] += l[c];
                normal[v] += cross;
                area[v] += ar[c];
            }
        }
        let mut boundary = vec![false; n];
        for &(a, b, count) in edges {
            if count == 1 {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
            }
        }
        let mut h = vec![0.0; n];
        let mut estimated = vec![false; n];
        for v in 0..n {
            let nrm = normal[v].normalize_or_zero();
            if boundary[v] || !(area[v] > 0.0) || nrm == DVec3::ZERO {
                continue;
            }
            let value = lap[v].dot(nrm) / (4.0 * area[v]);
            if value.is_finite() {
                h[v] = value;
                estimated[v] = true;
            }
        }
        fill_from_neighbours(&mut h, &estimated, edges);
        h
    }

    #[test]
    fn same_bits_as_the_serial_per_triangle_sums() {
        use crate::util::rng::rand01;
        // An irregular open surface (jittered grid: obtuse triangles, a rim) and a jittered
        // sphere cap; the vertex-parallel sums must give the serial loop's bits exactly.
        let (mut p, t) = height_grid(24, |x, y| 0.3 * (3.0 * x).sin() * (2.0 * y).cos());
        for (i, q) in p.iter_mut().enumerate() {
            q.x += 0.03 * (rand01(7, 0, i as u64) as f32 - 0.5);
            q.y += 0.03 * (rand01(7, 1, i as u64) as f32 - 0.5);
        }
        let (sp, st) = icosphere(3, 1.0);
        let sp: Vec<Vec3> =
            sp.iter().enumerate().map(|(i, q)| *q * (1.0 + 0.05 * rand01(9, 0, i as u64) as f32)).collect();
        let cap: Vec<[u32; 3]> = st.into_iter().filter(|f| f.iter().all(|&i| sp[i as usize].y > -0.3)).collect();
        for (p, t) in [(p, t), (sp, cap)] {
            let s = Surface::new(&p, &t);
            let e = s.edges();
            let got = mean_curvature(&s, &e).h;
            let want = reference_curvature(&s, &e);
            assert_eq!(
                got.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                want.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
            );
            assert!(got.iter().any(|h| h.abs() > 0.1));
        }
    }

    #[test]
    fn degenerate_triangles_give_no_nan() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::new(2.0, 0.0, 0.0), Vec3::Y, Vec3::new(1e-30, 1e-30, 0.0)];
        let t = vec![[0, 1, 2], [0, 1, 3], [0, 4, 1], [1, 2, 3]];
        let (_, c) = curvature_of(&p, &t);
        assert!(c.h.iter().all(|h| h.is_finite()));
    }
}
