//! Mesh saliency of a huge mesh through a bounded-size proxy (million-triangle
//! scenes): what `SaliencyMethod::Auto` does for meshes of more than `PROXY_ABOVE` vertices.
//!
//! The mesh is clustered on a uniform grid (Rossignac and Borrel's vertex clustering) of cells
//! `CELL_EPS` x eps a side (eps: the method's 0.3% of the bounding-box diagonal): each occupied cell
//! becomes one proxy vertex at the centroid of the mesh vertices in it, and each triangle whose
//! corners fall in three different cells becomes a proxy triangle (duplicates dropped).
//! Saliency is computed on the proxy as on any mesh (`analyse`, `Analysed::saliency` with
//! `Auto`), with the full mesh's eps, and every mesh vertex takes its cell's value. When the
//! proxy would not hold under half the mesh's vertices, the mesh is computed directly.
//!
//! Why this is enough: saliency is a difference of Gaussian means of curvature at sigma = 2 to
//! 6 eps, and cells of 0.7 eps resolve every scale the definition looks at; detail below a
//! cell reaches saliency only through those means. The picture reads saliency per pixel, and at
//! 1000 x 1000 a cell is about a pixel of the mesh's extent. The price: values are constant
//! over a cell, and curvature is estimated on a smoothed surface. Errors against the direct
//! computation: docs/saliency.md ("Proxy").
//!
//! Cost: one pass over the vertices and one over the triangles (bucket sorts of the cell keys
//! and of the mapped triangles), then saliency of the proxy, whose size follows the
//! surface's area in eps^2 (about 250K vertices for a closed blob; `MAX_PROXY` at most: coarser
//! cells beyond, with a larger error), not the input's vertex count. Deterministic and
//! independent of the vertex and triangle order: centroids are summed in fixed point (exact
//! integer sums), cells and triangles sorted.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::surface::remap_triangles;
use super::{SaliencyMethod, analyse, levels};
use crate::util::sort::{leading_bits_shift, sort_by_buckets};

/// `Auto` computes saliency through a proxy for meshes with more vertices than this (item 1's
/// meshes up to 300K vertices, and a margin, keep the direct computation and its stated errors).
pub const PROXY_ABOVE: usize = 400_000;

/// Cell side of the proxy, in eps.
pub const CELL_EPS: f64 = 0.7;

/// Cluster cells of the proxy's clustered Gaussian means: sigma / `PROXY_BETA` (the direct
/// computation's `approx::BETA` is 4). Why coarser: the clustered work per unit of area goes
/// as beta^4 (clusters within reach of a group x groups, both ~beta^2 on a surface), so 2.5 does
/// about a sixth of it, and the clustered error it adds stays far below the proxy's own
/// (docs/saliency.md, "Proxy"). 2 is where the error starts to grow (mean 0.096 -> 0.100 on the
/// test below).
pub const PROXY_BETA: f64 = 2.5;

/// At most this many proxy vertices: cells grow by sqrt(2) until the proxy fits.
pub const MAX_PROXY: usize = 600_000;

/// Fixed-point scale of the centroid sums: positions relative to the bounding box's corner,
/// in units of its largest side / 2^32 (0.2 nm on a 1 m mesh); sums of up to 2^31 vertices fit.
const FIXED: f64 = 4_294_967_296.0;

/// Per-vertex saliency of `positions` / `triangles` (the mesh's order; 0 for vertices on no
/// usable triangle) computed on a proxy of cells `CELL_EPS` x eps. None when the mesh has no
/// usable triangle or the proxy would not be under half its size.
pub fn proxy_saliency(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<Vec<f32>> {
    proxy_saliency_with(positions, triangles, CELL_EPS, None, PROXY_BETA).map(|(v, _)| v)
}

/// `proxy_saliency` with cells of `cell_eps` x eps, eps given (None: the method's), and clustered
/// means with cells of sigma / `beta` where the proxy is not summed exactly; also returns the
/// proxy's vertex count.
pub fn proxy_saliency_with(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    cell_eps: f64,
    eps: Option<f64>,
    beta: f64,
) -> Option<(Vec<f32>, usize)> {
    let n = positions.len();
    let usable = |t: &[u32; 3]| t.iter().all(|&i| (i as usize) < n && positions[i as usize].is_finite());
    let mut used = vec![false; n];
    for t in triangles.iter().filter(|t| usable(t)) {
        for &i in t {
            used[i as usize] = true;
        }
    }
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (p, _) in positions.iter().zip(&used).filter(|(_, u)| **u) {
        lo = lo.min(p.as_dvec3());
        hi = hi.max(p.as_dvec3());
    }
    if !lo.is_finite() {
        return None;
    }
    let extent = (hi - lo).max_element();
    let diagonal = (hi - lo).length();
    let eps = eps.unwrap_or_else(|| levels::epsilon(diagonal, 0.0));
    if !(extent > 0.0) || !(eps > 0.0) {
        return None;
    }
    let mut cell = cell_eps * eps;
    let (cells, clusters) = loop {
        let dims = ((hi - lo) / cell).floor().as_u64vec3() + 1;
        // Keys must fit in 63 bits (21 per axis): coarser cells otherwise.
        if dims.max_element() >= 1 << 21 {
            cell *= 2.0;
            continue;
        }
        let cell_of = |p: Vec3| {
            let q = ((p.as_dvec3() - lo) / cell).floor().as_u64vec3().min(dims - 1);
            (q.x << 42) | (q.y << 21) | q.z
        };
        // Every vertex mapped (unused ones to index u32::MAX, never a vertex's), then those
        // dropped: an indexed collect writes in place, a parallel filter collects in pieces.
        let mut keyed: Vec<(u64, u32)> = (0..n as u32)
            .into_par_iter()
            .map(|i| if used[i as usize] { (cell_of(positions[i as usize]), i) } else { (0, u32::MAX) })
            .collect();
        keyed.retain(|k| k.1 != u32::MAX);
        // By the keys' leading 16 bits (x and the top of y), then within each bucket: the
        // order a sort of the (distinct) pairs gives.
        let max_key = ((dims.x - 1) << 42) | ((dims.y - 1) << 21) | (dims.z - 1);
        let shift = leading_bits_shift(max_key, 16);
        sort_by_buckets(&mut keyed, 1 << 16, |k| (k.0 >> shift) as usize);
        let mut clusters = 0usize;
        let mut last = u64::MAX;
        for &(k, _) in &keyed {
            if k != last {
                clusters += 1;
                last = k;
            }
        }
        if clusters > MAX_PROXY {
            cell *= std::f64::consts::SQRT_2;
            continue;
        }
        break (keyed, clusters);
    };
    if 2 * clusters > cells.len() {
        return None;
    }
    // Cluster ids in key order; centroids in fixed point.
    let mut cluster_of = vec![u32::MAX; n];
    let mut sums: Vec<([i64; 3], i64)> = Vec::with_capacity(clusters);
    let mut last = u64::MAX;
    for &(k, i) in &cells {
        if k != last {
            sums.push(([0; 3], 0));
            last = k;
        }
        let q = (positions[i as usize].as_dvec3() - lo) / extent * FIXED;
        let s = sums.last_mut().expect("pushed");
        for (acc, c) in s.0.iter_mut().zip(q.to_array()) {
            *acc += c as i64;
        }
        s.1 += 1;
        cluster_of[i as usize] = (sums.len() - 1) as u32;
    }
    drop(cells);
    let proxy_positions: Vec<Vec3> = sums
        .iter()
        .map(|(s, count)| {
            let q = DVec3::new(s[0] as f64, s[1] as f64, s[2] as f64) / *count as f64;
            (lo + q / FIXED * extent).as_vec3()
        })
        .collect();
    let mut proxy_triangles = remap_triangles(triangles, &cluster_of, usable);
    proxy_triangles.dedup();
    let mut a = analyse(&proxy_positions, &proxy_triangles);
    // The full mesh's eps: a mesh this dense is never coarse, and the proxy's longer edges
    // must not raise it.
    a.eps = eps;
    let values = a.saliency_with_beta(SaliencyMethod::Auto, beta);
    let per_proxy = a.to_mesh_order(&values);
    let values = cluster_of
        .iter()
        .map(|&c| if c == u32::MAX { 0.0 } else { per_proxy.get(c as usize).copied().unwrap_or(0.0) })
        .collect();
    Some((values, clusters))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::saliency::approx;

    /// A bumpy sphere of ~4 n^2 triangles (the scale bench's surface).
    fn bumpy(n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let mut p = Vec::new();
        for j in 0..=n {
            let th = std::f32::consts::PI * j as f32 / n as f32;
            for i in 0..2 * n {
                let ph = std::f32::consts::PI * i as f32 / n as f32;
                let d = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
                let bump =
                    0.08 * (5.0 * d.x).sin() * (4.0 * d.y).cos() + 0.03 * (13.0 * d.z).sin() * (11.0 * d.x).sin();
                p.push(d * (1.0 + bump));
            }
        }
        let v = |i: u32, j: u32| j * 2 * n + i % (2 * n);
        let mut t = Vec::new();
        for j in 0..n {
            for i in 0..2 * n {
                if j > 0 {
                    t.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                }
                if j + 1 < n {
                    t.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
                }
            }
        }
        (p, t)
    }

    fn errors(a: &[f32], b: &[f32]) -> (f32, f32) {
        let d: Vec<f32> = a.iter().zip(b).map(|(x, y)| (x - y).abs()).collect();
        (d.iter().copied().fold(0.0, f32::max), d.iter().sum::<f32>() / d.len() as f32)
    }

    /// The proxy against the direct computation (`Auto` on the full mesh) with the same eps,
    /// four mesh edges long (a mesh this much finer than eps is what gets a proxy): bounded
    /// mean error, and the proxy really is smaller. Prints the errors docs/saliency.md states.
    #[test]
    fn proxy_is_close_to_the_full_computation() {
        let (p, t) = bumpy(200);
        let eps = 0.06;
        let mut a = analyse(&p, &t);
        a.eps = eps;
        let full = a.to_mesh_order(&a.saliency(SaliencyMethod::Auto));
        for (cell, beta, bound) in [
            (0.5, PROXY_BETA, 0.1),
            (CELL_EPS, approx::BETA, 0.1),
            (CELL_EPS, PROXY_BETA, 0.1),
            (CELL_EPS, 3.0, 0.1),
            (1.0, PROXY_BETA, 0.12),
        ] {
            let t0 = std::time::Instant::now();
            let (proxy, size) = proxy_saliency_with(&p, &t, cell, Some(eps), beta).unwrap();
            let dt = t0.elapsed().as_secs_f64();
            let (max, mean) = errors(&proxy, &full);
            eprintln!(
                "proxy cells {cell} eps, beta {beta}: {size} of {} vertices: max {max:.4}, mean {mean:.4} ({dt:.2} s)",
                p.len()
            );
            assert!(2 * size < p.len(), "{size}");
            assert!(mean < bound, "cells {cell} eps: max {max}, mean {mean}");
        }
    }

    /// Same values whatever the order of the vertices and triangles.
    #[test]
    fn proxy_ignores_order() {
        let (p, t) = bumpy(40);
        let a = proxy_saliency_with(&p, &t, 1.0, Some(0.3), PROXY_BETA).unwrap().0;
        let n = p.len() as u32;
        let perm = |i: u32| (i * 7919) % n;
        let mut q = vec![Vec3::ZERO; p.len()];
        for (i, x) in p.iter().enumerate() {
            q[perm(i as u32) as usize] = *x;
        }
        let mut u: Vec<[u32; 3]> = t.iter().map(|tri| tri.map(perm)).collect();
        u.reverse();
        let b = proxy_saliency_with(&q, &u, 1.0, Some(0.3), PROXY_BETA).unwrap().0;
        for i in 0..p.len() {
            assert_eq!(a[i].to_bits(), b[perm(i as u32) as usize].to_bits(), "vertex {i}");
        }
    }

    #[test]
    fn nothing_usable_is_none() {
        assert!(proxy_saliency(&[Vec3::ZERO; 3], &[[0, 1, 2]]).is_none());
        assert!(proxy_saliency(&[Vec3::ZERO, Vec3::X], &[[0, 1, 5]]).is_none());
        // A mesh no finer than its cells: computed directly.
        let (p, t) = bumpy(20);
        assert!(proxy_saliency_with(&p, &t, 1.0, Some(0.01), PROXY_BETA).is_none());
    }
}
