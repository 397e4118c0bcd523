//! A mesh welded by exact position into a canonical surface: the vertex set and triangle list
//! saliency is defined on, independent of split normals/UV seams and of vertex/triangle order.
//!
//! Why canonical: vertices are sorted by position and triangles by their (rotated) vertex ids,
//! so every later sum runs in the same order for any permutation of the input, and results
//! are bit-identical under reordering (a tested property), not merely close.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::util::csr::Csr;
use crate::util::sort::{leading_bits_shift, sort_by_buckets};

/// Marks an input vertex that is on no triangle (or has a non-finite position).
pub const NOT_ON_SURFACE: u32 = u32::MAX;

/// The welded surface of one mesh, in the mesh's own coordinates (f64).
#[derive(Clone, Debug)]
pub struct Surface {
    /// Distinct positions of vertices used by a triangle, sorted lexicographically.
    pub positions: Vec<DVec3>,
    /// Triangles over `positions`, winding kept, smallest id first, sorted; triangles that
    /// collapse under welding (a repeated vertex) are dropped.
    pub triangles: Vec<[u32; 3]>,
    /// For each input vertex, its index in `positions`, or `NOT_ON_SURFACE`.
    pub vertex_of: Vec<u32>,
}

/// -0.0 and 0.0 are the same position.
fn key(p: Vec3) -> [f32; 3] {
    [p.x + 0.0, p.y + 0.0, p.z + 0.0]
}

/// An integer ordered as `(x, y, z)` by `f32::total_cmp`: one comparison instead of three.
fn sort_key(p: &[f32; 3]) -> u128 {
    let ordered = |x: f32| {
        let b = x.to_bits();
        if b >> 31 == 1 { !b } else { b | 0x8000_0000 }
    };
    (ordered(p[0]) as u128) << 64 | (ordered(p[1]) as u128) << 32 | ordered(p[2]) as u128
}

/// The `usable` triangles with their corners mapped through `map` (welding, clustering),
/// those that collapse (a repeated corner) dropped, each rotated to start at its smallest id
/// (winding kept), sorted: the same list whatever the input's vertex or triangle order.
pub fn remap_triangles(
    triangles: &[[u32; 3]],
    map: &[u32],
    usable: impl Fn(&[u32; 3]) -> bool + Sync,
) -> Vec<[u32; 3]> {
    // A parallel filter (collected in pieces, then copied): on a proxy most triangles collapse,
    // and an indexed map of every triangle would allocate for all of them.
    let mut tris: Vec<[u32; 3]> = triangles
        .par_iter()
        .filter(|t| usable(t))
        .map(|t| t.map(|i| map[i as usize]))
        .filter(|[a, b, c]| a != b && b != c && a != c)
        .map(|[a, b, c]| {
            if a < b && a < c {
                [a, b, c]
            } else if b < c {
                [b, c, a]
            } else {
                [c, a, b]
            }
        })
        .collect();
    // By the first corner's leading 16 bits, then within each bucket: a sort's order.
    let max = tris.par_iter().map(|t| t[0]).max().unwrap_or(0) as u64;
    let shift = leading_bits_shift(max, 16);
    sort_by_buckets(&mut tris, 1 << 16, |t| (t[0] as u64 >> shift) as usize);
    tris
}

impl Surface {
    /// Welds `positions` by exact value over the vertices `triangles` use. Triangles with an
    /// out-of-range index or a non-finite corner are ignored.
    pub fn new(positions: &[Vec3], triangles: &[[u32; 3]]) -> Surface {
        let n = positions.len();
        let usable = |t: &[u32; 3]| t.iter().all(|&i| (i as usize) < n && positions[i as usize].is_finite());
        let mut used = vec![false; n];
        for t in triangles.iter().filter(|t| usable(t)) {
            for &i in t {
                used[i as usize] = true;
            }
        }
        let mut order: Vec<u32> = (0..n as u32).filter(|&i| used[i as usize]).collect();
        // Ties (equal positions) keep no particular order: they are welded into one vertex.
        order.par_sort_unstable_by_key(|&i| sort_key(&key(positions[i as usize])));
        let mut vertex_of = vec![NOT_ON_SURFACE; n];
        let mut welded: Vec<DVec3> = Vec::new();
        let mut last: Option<[f32; 3]> = None;
        for &i in &order {
            let k = key(positions[i as usize]);
            if last != Some(k) {
                welded.push(DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64));
                last = Some(k);
            }
            vertex_of[i as usize] = (welded.len() - 1) as u32;
        }
        let tris = remap_triangles(triangles, &vertex_of, usable);
        Surface { positions: welded, triangles: tris, vertex_of }
    }

    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Axis-aligned bounds of the surface's vertices.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.positions.iter().fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
    }

    /// Length of the bounding box's diagonal (0 for an empty surface).
    pub fn diagonal(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let (lo, hi) = self.bounds();
        (hi - lo).length()
    }

    /// Each undirected edge once, as (smaller id, larger id, number of triangles using it), sorted.
    pub fn edges(&self) -> Vec<(u32, u32, u32)> {
        // (a, b) packed as a << 32 | b: a plain integer sort.
        // Indexed (triangle, corner) in order: collected in place.
        let mut e: Vec<u64> = (0..self.triangles.len() * 3)
            .into_par_iter()
            .map(|x| {
                let (t, k) = (&self.triangles[x / 3], x % 3);
                let (a, b) = (t[k], t[(k + 1) % 3]);
                (a.min(b) as u64) << 32 | a.max(b) as u64
            })
            .collect();
        // In place: `sort_by_buckets` was about as fast here and needs a second copy of the keys.
        e.par_sort_unstable();
        let mut out: Vec<(u32, u32, u32)> = Vec::with_capacity(e.len() / 2 + 1);
        for (a, b) in e.into_iter().map(|k| ((k >> 32) as u32, k as u32)) {
            match out.last_mut() {
                Some(l) if l.0 == a && l.1 == b => l.2 += 1,
                _ => out.push((a, b, 1)),
            }
        }
        out
    }

    /// Mean length of the distinct edges (0 without edges).
    pub fn mean_edge_length(&self, edges: &[(u32, u32, u32)]) -> f64 {
        if edges.is_empty() {
            return 0.0;
        }
        let sum: f64 =
            edges.iter().map(|&(a, b, _)| (self.positions[a as usize] - self.positions[b as usize]).length()).sum();
        sum / edges.len() as f64
    }

    /// Total triangle area.
    pub fn area(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }
}

/// Each vertex's neighbours through an edge, in compressed rows (ascending ids).
#[derive(Clone, Debug, Default)]
pub struct Adjacency(Csr);

impl Adjacency {
    /// From the surface's edges (a, b, triangles using it), as `Surface::edges` lists them.
    pub fn new(vertices: usize, edges: &[(u32, u32, u32)]) -> Adjacency {
        let pairs: Vec<(u32, u32)> = edges.iter().map(|&(a, b, _)| (a, b)).collect();
        let mut csr = Csr::from_undirected(vertices, &pairs);
        csr.edges = Vec::new(); // only the neighbours are kept
        Adjacency(csr)
    }

    /// The neighbours of `v`.
    pub fn of(&self, v: usize) -> &[u32] {
        self.0.neighbours(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn welds_split_vertices_and_drops_collapsed_triangles() {
        // Two triangles of a quad with the shared edge duplicated (a UV seam), plus a triangle
        // that collapses once welded and an unused vertex.
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-0.0, 0.0, 0.0), // same as 0
            Vec3::new(1.0, 1.0, 0.0),  // same as 2
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(5.0, 5.0, 5.0), // unused
        ];
        let t = vec![[0, 1, 2], [3, 4, 5], [0, 3, 1]];
        let s = Surface::new(&p, &t);
        assert_eq!(s.len(), 4);
        assert_eq!(s.triangles.len(), 2);
        assert_eq!(s.vertex_of[0], s.vertex_of[3]);
        assert_eq!(s.vertex_of[2], s.vertex_of[4]);
        assert_eq!(s.vertex_of[6], NOT_ON_SURFACE);
        let e = s.edges();
        assert_eq!(e.len(), 5);
        let adj = Adjacency::new(s.len(), &e);
        let (a, c) = (s.vertex_of[0] as usize, s.vertex_of[2]);
        assert_eq!(adj.of(a).len(), 3);
        assert!(adj.of(a).contains(&c));
        assert_eq!(e.iter().filter(|x| x.2 == 2).count(), 1);
    }

    #[test]
    fn winding_is_kept_when_rotating() {
        let p = vec![Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)];
        let s = Surface::new(&p, &[[0, 1, 2]]);
        // Canonical ids: (0,0,0)=0, (1,1,0)=1, (2,0,0)=2; input order 2,0,1 rotates to 0,1,2.
        assert_eq!(s.triangles, vec![[0, 1, 2]]);
        let s2 = Surface::new(&p, &[[0, 2, 1]]);
        assert_eq!(s2.triangles, vec![[0, 2, 1]]);
    }

    #[test]
    fn bad_indices_and_non_finite_corners_are_ignored() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(f32::NAN, 0.0, 0.0)];
        let s = Surface::new(&p, &[[0, 1, 2], [0, 1, 9], [0, 1, 3]]);
        assert_eq!(s.triangles.len(), 1);
        assert_eq!(s.vertex_of[3], NOT_ON_SURFACE);
    }
}
