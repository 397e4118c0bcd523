//! The region adjacency graph of the superpixels and its affinities: the pixel graph of Shi and
//! Malik's normalized cut, restricted to cuts along superpixel boundaries.
//!
//! On the 4-neighbour pixel graph with affinity w_pq, a cut along superpixel boundaries costs
//! the sum of w_pq over the pixel pairs it separates, and a region's volume is the sum of its
//! pixels' degrees. So regions i and j get W_ij = (number of 4-neighbour pixel pairs they
//! share) x a_ij, and region i a self-loop W_ii = 2 x (pairs inside it) + (its pixels, each
//! pixel's affinity to itself) (inside a superpixel the affinity is taken as 1): the normalized cut of the region graph is then exactly the
//! pixel graph's, for every segmentation made of whole superpixels.

use std::collections::BTreeMap;

use rayon::prelude::*;

use super::SegmentWeights;
use super::superpixels::{FEATURES, Features, Superpixels, feature_distance};
use crate::util::csr::Csr;

/// Superpixel `i`'s statistics.
#[derive(Clone, Debug)]
pub struct Region {
    pub area: u32,
    /// Mean pre-scaled features (see `superpixels::Features`).
    pub mean: [f32; FEATURES],
    /// The object of its pixels (all one object when objects separate the superpixels; else
    /// that of its first pixel).
    pub object: u32,
    /// Pixel pairs (4-neighbour) inside the region.
    pub inner_pairs: u32,
}

/// A symmetric weighted graph: nodes 0..n with self-loops and CSR adjacency.
#[derive(Clone, Debug)]
pub struct RegionGraph {
    pub regions: Vec<Region>,
    /// `offsets[i]..offsets[i+1]` indexes node i's neighbours in `targets`/`weights`/`lengths`.
    pub offsets: Vec<usize>,
    pub targets: Vec<u32>,
    /// W_ij = shared boundary length x affinity.
    pub weights: Vec<f64>,
    /// Shared boundary length, pixel pairs.
    pub lengths: Vec<u32>,
    /// W_ii = 2 x inner pairs + area.
    pub self_loops: Vec<f64>,
    /// d_i = W_ii + sum_j W_ij.
    pub degrees: Vec<f64>,
}

/// Smallest affinity of adjacent regions (before the object factor): cutting along the
/// strongest edge costs this fraction of a cut through a flat region. Without a floor, the
/// contrasts of a rendered image (exp(-100) between a lit object and the background) leave
/// the graph in dozens of practically disconnected pieces, every grouping of them a "free"
/// cut, and the eigenvectors pick pieces arbitrarily instead of balancing the segments.
pub const EDGE_FLOOR: f64 = 0.01;

/// Affinity of two adjacent regions from their mean features: EDGE_FLOOR + (1 - EDGE_FLOOR)
/// exp(-|F_i - F_j|^2) with F the weighted, scaled features (colour, normal, depth, saliency),
/// times (1 - object weight) across object boundaries (the background counts as one object).
pub fn affinity(a: &Region, b: &Region, weights: &SegmentWeights) -> f64 {
    let mut x = EDGE_FLOOR + (1.0 - EDGE_FLOOR) * (-(feature_distance(&a.mean, &b.mean) as f64)).exp();
    if a.object != b.object {
        x *= 1.0 - (weights.object as f64).clamp(0.0, 1.0);
    }
    x
}

/// Rows per block of the parallel passes (fixed, so sums do not depend on the thread count).
const BLOCK_ROWS: usize = 32;

impl RegionGraph {
    pub fn build(sp: &Superpixels, features: &Features, weights: &SegmentWeights) -> RegionGraph {
        let (w, h) = (sp.width, sp.height);
        let n = sp.count;
        let labels = &sp.labels;

        // Per block of rows: feature sums, areas, inner pairs and boundary pair keys.
        struct Partial {
            sums: Vec<(u32, [f64; FEATURES], u32, u32)>, // (label, sum, area, inner pairs) sparse
            boundary: Vec<u64>,
        }
        let blocks: Vec<Partial> = (0..h.div_ceil(BLOCK_ROWS))
            .into_par_iter()
            .map(|b| {
                let mut local: BTreeMap<u32, ([f64; FEATURES], u32, u32)> = BTreeMap::new();
                let mut boundary = Vec::new();
                let mut last = u32::MAX;
                let mut acc: ([f64; FEATURES], u32, u32) = ([0.0; FEATURES], 0, 0);
                let mut flush = |label: u32, acc: &mut ([f64; FEATURES], u32, u32)| {
                    if label != u32::MAX && (acc.1 > 0 || acc.2 > 0) {
                        let e = local.entry(label).or_insert(([0.0; FEATURES], 0, 0));
                        for k in 0..FEATURES {
                            e.0[k] += acc.0[k];
                        }
                        e.1 += acc.1;
                        e.2 += acc.2;
                    }
                    *acc = ([0.0; FEATURES], 0, 0);
                };
                for y in b * BLOCK_ROWS..((b + 1) * BLOCK_ROWS).min(h) {
                    for x in 0..w {
                        let p = y * w + x;
                        let l = labels[p];
                        if l != last {
                            flush(last, &mut acc);
                            last = l;
                        }
                        let fp = &features.values[p];
                        for k in 0..FEATURES {
                            acc.0[k] += fp[k] as f64;
                        }
                        acc.1 += 1;
                        if x + 1 < w {
                            let r = labels[p + 1];
                            if r == l {
                                acc.2 += 1;
                            } else {
                                boundary.push(key(l, r));
                            }
                        }
                        if y + 1 < h {
                            let d = labels[p + w];
                            if d == l {
                                acc.2 += 1;
                            } else {
                                boundary.push(key(l, d));
                            }
                        }
                    }
                }
                flush(last, &mut acc);
                Partial { sums: local.into_iter().map(|(l, (s, a, i))| (l, s, a, i)).collect(), boundary }
            })
            .collect();

        let mut sums = vec![[0f64; FEATURES]; n];
        let mut area = vec![0u32; n];
        let mut inner = vec![0u32; n];
        let mut keys = Vec::with_capacity(blocks.iter().map(|b| b.boundary.len()).sum());
        for b in blocks {
            for (l, s, a, i) in b.sums {
                let l = l as usize;
                for k in 0..FEATURES {
                    sums[l][k] += s[k];
                }
                area[l] += a;
                inner[l] += i;
            }
            keys.extend(b.boundary);
        }
        keys.par_sort_unstable();

        // First pixel of each label gives its object.
        let mut object = vec![u32::MAX; n];
        let mut seen = 0;
        for (p, &l) in labels.iter().enumerate() {
            if object[l as usize] == u32::MAX {
                object[l as usize] = features.object[p];
                seen += 1;
                if seen == n {
                    break;
                }
            }
        }
        let regions: Vec<Region> = (0..n)
            .map(|i| {
                let a = area[i].max(1) as f64;
                let mut mean = [0f32; FEATURES];
                for k in 0..FEATURES {
                    mean[k] = (sums[i][k] / a) as f32;
                }
                Region { area: area[i], mean, object: object[i], inner_pairs: inner[i] }
            })
            .collect();

        // Run-length count of the sorted pair keys -> undirected edges with boundary lengths.
        let mut edges: Vec<(u32, u32, u32)> = Vec::new();
        let mut i = 0;
        while i < keys.len() {
            let k = keys[i];
            let mut j = i;
            while j < keys.len() && keys[j] == k {
                j += 1;
            }
            edges.push(((k >> 32) as u32, k as u32, (j - i) as u32));
            i = j;
        }
        RegionGraph::from_edges(regions, &edges, weights)
    }

    /// Builds the CSR graph from undirected edges (a < b, boundary length).
    pub fn from_edges(regions: Vec<Region>, edges: &[(u32, u32, u32)], weights: &SegmentWeights) -> RegionGraph {
        let n = regions.len();
        let pairs: Vec<(u32, u32)> = edges.iter().map(|&(a, b, _)| (a, b)).collect();
        // Rows sorted by target, for determinism.
        let Csr { offsets, targets, edges: edge_of } = Csr::from_undirected(n, &pairs);
        let edge_weight: Vec<f64> = edges
            .iter()
            .map(|&(a, b, len)| len as f64 * affinity(&regions[a as usize], &regions[b as usize], weights))
            .collect();
        let wts: Vec<f64> = edge_of.iter().map(|&e| edge_weight[e as usize]).collect();
        let lengths: Vec<u32> = edge_of.iter().map(|&e| edges[e as usize].2).collect();
        // Each pixel's affinity to itself is 1 (Shi and Malik's W includes the diagonal), so no
        // region has a zero degree, even a one-pixel island behind an object wall.
        let self_loops: Vec<f64> = regions.iter().map(|r| 2.0 * r.inner_pairs as f64 + r.area as f64).collect();
        let degrees: Vec<f64> =
            (0..n).map(|i| self_loops[i] + wts[offsets[i]..offsets[i + 1]].iter().sum::<f64>()).collect();
        RegionGraph { regions, offsets, targets, weights: wts, lengths, self_loops, degrees }
    }

    pub fn len(&self) -> usize {
        self.regions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.regions.is_empty()
    }

    /// Neighbours of `i` with their weights.
    pub fn neighbours(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = self.offsets[i]..self.offsets[i + 1];
        self.targets[r.clone()].iter().zip(&self.weights[r]).map(|(&t, &w)| (t as usize, w))
    }
}

fn key(a: u32, b: u32) -> u64 {
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    ((lo as u64) << 32) | hi as u64
}
