//! Exactly k spatially connected segments per level: discretise, split into connected pieces,
//! merge or bipartition until k remain.

use std::collections::BTreeMap;

use super::{Embedding, NoConvergence, discretise, embed};
use crate::facets::segment::graph::RegionGraph;
use crate::facets::segment::superpixels::Dsu;

/// Why a level has a segment count other than the one asked for.
#[derive(Clone, Debug, PartialEq)]
pub enum Shortfall {
    /// Fewer regions (superpixels) than segments asked for.
    TooFewRegions,
    /// More object pieces than segments asked for while objects are hard walls.
    ObjectWalls,
}

/// A level's segmentation of the region graph.
#[derive(Clone, Debug)]
pub struct Partition {
    /// Segment of each region, 0..count, numbered in order of their first region.
    pub labels: Vec<u32>,
    pub count: usize,
    pub shortfall: Option<Shortfall>,
}

/// The k-way normalized cut of `g` from its embedding: Yu-Shi discretisation, then every
/// segment made one connected piece (of one object when `hard_objects`), then greedy merges
/// of the adjacent pair whose union raises the normalized cut least, or bipartitions (Shi
/// and Malik's Fiedler-vector sweep) of the largest-volume segment, until exactly k segments
/// remain, unless there are fewer regions than k or the object walls leave more pieces.
pub fn partition(
    g: &RegionGraph,
    emb: &Embedding,
    k: usize,
    hard_objects: bool,
    seed: u64,
) -> Result<Partition, NoConvergence> {
    let n = g.len();
    let target = k.min(n).max(1);
    let mut labels = discretise(emb, target, seed);
    labels = connected_pieces(g, &labels, hard_objects);
    let mut count = labels.iter().map(|&l| l as usize + 1).max().unwrap_or(0);
    let mut shortfall = None;
    if count > target {
        count = merge(g, &mut labels, count, target, hard_objects);
        if count > target {
            shortfall = Some(Shortfall::ObjectWalls);
        }
    }
    while count < target {
        if !split_largest(g, &mut labels, count, seed)? {
            break;
        }
        count += 1;
    }
    if count < k {
        shortfall = Some(Shortfall::TooFewRegions);
    }
    let (labels, count) = renumber(&labels);
    Ok(Partition { labels, count, shortfall })
}

/// Splits every segment into its connected pieces (through graph edges; across an object
/// boundary only when objects are not hard walls).
pub fn connected_pieces(g: &RegionGraph, labels: &[u32], hard_objects: bool) -> Vec<u32> {
    let n = g.len();
    let mut dsu = Dsu::new(n);
    for i in 0..n {
        for (j, _) in g.neighbours(i) {
            if j > i && labels[i] == labels[j] && (!hard_objects || g.regions[i].object == g.regions[j].object) {
                dsu.union(i as u32, j as u32);
            }
        }
    }
    let roots: Vec<u32> = (0..n as u32).map(|i| dsu.find(i)).collect();
    renumber(&roots).0
}

/// Labels renumbered 0.. in order of first appearance.
fn renumber(labels: &[u32]) -> (Vec<u32>, usize) {
    let mut map: BTreeMap<u32, u32> = BTreeMap::new();
    let out = labels
        .iter()
        .map(|l| {
            let next = map.len() as u32;
            *map.entry(*l).or_insert(next)
        })
        .collect();
    (out, map.len())
}

/// Greedy merging of adjacent segments: each step joins the allowed pair (A, B) whose union
/// changes Ncut = sum_S cut(S) / vol(S) least,
///   delta = (cut A + cut B - 2 W(A,B)) / (vol A + vol B) - cut A / vol A - cut B / vol B,
/// until `target` segments remain or no allowed pair is left. Returns the count.
fn merge(g: &RegionGraph, labels: &mut [u32], count: usize, target: usize, hard_objects: bool) -> usize {
    let mut vol = vec![0f64; count];
    let mut cut = vec![0f64; count];
    let mut object = vec![0u32; count];
    let mut between: BTreeMap<(u32, u32), f64> = BTreeMap::new();
    for i in 0..g.len() {
        let a = labels[i];
        vol[a as usize] += g.degrees[i];
        object[a as usize] = g.regions[i].object;
        for (j, w) in g.neighbours(i) {
            let b = labels[j];
            if a != b {
                cut[a as usize] += w;
                if a < b {
                    *between.entry((a, b)).or_insert(0.0) += w;
                }
            }
        }
    }
    let mut alive = vec![true; count];
    let mut forward: Vec<u32> = (0..count as u32).collect();
    let mut remaining = count;
    while remaining > target {
        let mut best: Option<(f64, (u32, u32))> = None;
        for (&(a, b), &w) in &between {
            if hard_objects && object[a as usize] != object[b as usize] {
                continue;
            }
            let (ca, cb, va, vb) = (cut[a as usize], cut[b as usize], vol[a as usize], vol[b as usize]);
            let delta = (ca + cb - 2.0 * w) / (va + vb) - ca / va - cb / vb;
            if best.is_none_or(|(d, _)| delta < d) {
                best = Some((delta, (a, b)));
            }
        }
        let Some((_, (a, b))) = best else { break };
        // Join b into a.
        let w_ab = between.remove(&(a, b)).unwrap_or(0.0);
        cut[a as usize] = cut[a as usize] + cut[b as usize] - 2.0 * w_ab;
        vol[a as usize] += vol[b as usize];
        alive[b as usize] = false;
        forward[b as usize] = a;
        let moved: Vec<((u32, u32), f64)> =
            between.iter().filter(|((x, y), _)| *x == b || *y == b).map(|(k, v)| (*k, *v)).collect();
        for (key, w) in moved {
            between.remove(&key);
            let other = if key.0 == b { key.1 } else { key.0 };
            let nk = if a < other { (a, other) } else { (other, a) };
            *between.entry(nk).or_insert(0.0) += w;
        }
        remaining -= 1;
    }
    let resolve = |mut s: u32| {
        while forward[s as usize] != s {
            s = forward[s as usize];
        }
        s
    };
    for l in labels.iter_mut() {
        *l = resolve(*l);
    }
    let (renumbered, c) = renumber(labels);
    labels.copy_from_slice(&renumbered);
    debug_assert!(alive.iter().filter(|a| **a).count() == c);
    c
}

/// Bipartitions the segment of largest volume that has at least two regions, by a sweep of
/// its subgraph's Fiedler vector (D^-1/2 times the second eigenvector of its normalised
/// affinity) for the cut of least Ncut. False when every segment is a single region.
fn split_largest(g: &RegionGraph, labels: &mut [u32], count: usize, seed: u64) -> Result<bool, NoConvergence> {
    let mut vol = vec![0f64; count];
    let mut size = vec![0usize; count];
    for i in 0..g.len() {
        vol[labels[i] as usize] += g.degrees[i];
        size[labels[i] as usize] += 1;
    }
    let Some(s) = (0..count).filter(|&s| size[s] >= 2).max_by(|&a, &b| vol[a].total_cmp(&vol[b]).then(b.cmp(&a)))
    else {
        return Ok(false);
    };
    let nodes: Vec<u32> = (0..g.len() as u32).filter(|&i| labels[i as usize] as usize == s).collect();
    let emb = embed(g, Some(&nodes), 2, seed ^ 0xF1ED)?;
    let m = nodes.len();
    let fiedler: Vec<f64> = if emb.vectors.ncols() >= 2 {
        (0..m).map(|k| emb.vectors[(k, 1)] / emb.degrees[k].sqrt()).collect()
    } else {
        (0..m).map(|k| k as f64).collect()
    };
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| fiedler[a].total_cmp(&fiedler[b]).then(a.cmp(&b)));
    let mut local = vec![u32::MAX; g.len()];
    for (k, &i) in nodes.iter().enumerate() {
        local[i as usize] = k as u32;
    }
    let total: f64 = emb.degrees.iter().sum();
    let mut inside = vec![false; m];
    let (mut cut, mut vol_p) = (0f64, 0f64);
    let mut best = (f64::INFINITY, 1usize);
    for (step, &k) in order.iter().enumerate().take(m - 1) {
        inside[k] = true;
        vol_p += emb.degrees[k];
        for (j, w) in g.neighbours(nodes[k] as usize) {
            let l = local[j];
            if l != u32::MAX {
                cut += if inside[l as usize] { -w } else { w };
            }
        }
        let rest = total - vol_p;
        let ncut = if vol_p > 0.0 && rest > 0.0 { cut / vol_p + cut / rest } else { f64::INFINITY };
        if ncut < best.0 {
            best = (ncut, step + 1);
        }
    }
    for &k in &order[best.1..] {
        labels[nodes[k] as usize] = count as u32;
    }
    Ok(true)
}
