//! k-way normalized cut of the region graph (Shi and Malik 2000; Yu and Shi 2003): the top
//! eigenvectors of D^-1/2 W D^-1/2, discretised by Yu and Shi's rotation, then made exactly
//! k spatially connected segments where the graph allows.
//!
//! One eigendecomposition (k = the largest level's N) serves every level: the k-way relaxation
//! of level N uses the N leading eigenvectors of the same matrix.

use std::collections::BTreeMap;

use faer::diag::Diag;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::evd::self_adjoint_evd;
use faer::linalg::svd::svd;
use faer::{Mat, MatRef, Par};

use super::graph::RegionGraph;
use super::superpixels::Dsu;
use crate::util::rng::{splitmix64, unit_f64};

/// Graphs up to this many nodes are solved densely (faer's self-adjoint EVD); larger ones by
/// shift-and-invert subspace iteration (`shift_invert`).
pub const DENSE_LIMIT: usize = 300;

/// A symmetric sparse matrix: the normalised affinity D^-1/2 W D^-1/2 of a graph or subgraph.
#[derive(Debug)]
struct NormalisedAffinity {
    diag: Vec<f64>,
    offsets: Vec<usize>,
    targets: Vec<u32>,
    values: Vec<f64>,
}

impl NormalisedAffinity {
    /// Of the subgraph on `nodes` (all nodes when None), degrees counted inside it.
    fn new(g: &RegionGraph, nodes: Option<&[u32]>) -> (NormalisedAffinity, Vec<f64>) {
        let all: Vec<u32>;
        let nodes = match nodes {
            Some(n) => n,
            None => {
                all = (0..g.len() as u32).collect();
                &all
            }
        };
        let mut local = vec![u32::MAX; g.len()];
        for (k, &i) in nodes.iter().enumerate() {
            local[i as usize] = k as u32;
        }
        let mut degree = vec![0f64; nodes.len()];
        let mut offsets = vec![0usize];
        let mut targets = Vec::new();
        let mut raw = Vec::new();
        for (k, &i) in nodes.iter().enumerate() {
            degree[k] = g.self_loops[i as usize];
            for (j, w) in g.neighbours(i as usize) {
                let l = local[j];
                if l != u32::MAX {
                    degree[k] += w;
                    targets.push(l);
                    raw.push(w);
                }
            }
            offsets.push(targets.len());
        }
        let inv: Vec<f64> = degree.iter().map(|d| 1.0 / d.sqrt()).collect();
        let diag: Vec<f64> =
            nodes.iter().enumerate().map(|(k, &i)| g.self_loops[i as usize] * inv[k] * inv[k]).collect();
        let mut values = raw;
        for k in 0..nodes.len() {
            for e in offsets[k]..offsets[k + 1] {
                values[e] *= inv[k] * inv[targets[e] as usize];
            }
        }
        (NormalisedAffinity { diag, offsets, targets, values }, degree)
    }

    fn n(&self) -> usize {
        self.diag.len()
    }
}

impl NormalisedAffinity {
    /// out = M x, column by column.
    fn apply(&self, x: MatRef<'_, f64>) -> Mat<f64> {
        let n = self.n();
        Mat::from_fn(n, x.ncols(), |i, c| {
            let mut s = self.diag[i] * x[(i, c)];
            for e in self.offsets[i]..self.offsets[i + 1] {
                s += self.values[e] * x[(self.targets[e] as usize, c)];
            }
            s
        })
    }
}

/// The leading eigenvectors of D^-1/2 W D^-1/2, columns in decreasing eigenvalue order, and the
/// degrees d (so that D^-1/2 times a column is the relaxed cut indicator).
pub struct Embedding {
    pub vectors: Mat<f64>,
    pub values: Vec<f64>,
    pub degrees: Vec<f64>,
}

/// Clears the upper halves of this thread's vector registers (VZEROUPPER). faer's kernels
/// (AVX2/AVX-512, picked at run time) can return with that state dirty, after which SSE code
/// (the rest of this crate, built for baseline x86-64) runs several times slower on the thread:
/// measured, SLIC took 4x longer after an eigensolve, and every later stage of the render
/// would pay too. Called after each use of faer.
pub(crate) fn clear_upper_simd_state() {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "avx")]
        unsafe fn zeroupper() {
            std::arch::x86_64::_mm256_zeroupper();
        }
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: AVX is available (checked above); VZEROUPPER only zeroes upper halves.
            unsafe { zeroupper() }
        }
    }
}

/// The eigensolver failed (faer's QR iteration did not converge).
#[derive(Debug)]
pub struct NoConvergence;

/// How `embed_with` solves the eigenproblem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Solver {
    /// Dense up to `DENSE_LIMIT` nodes (or when k is over half of them), else shift-invert.
    Auto,
    Dense,
    ShiftInvert,
}

/// Computes `k` leading eigenpairs of the graph's (or the subgraph's) normalised affinity.
pub fn embed(g: &RegionGraph, nodes: Option<&[u32]>, k: usize, seed: u64) -> Result<Embedding, NoConvergence> {
    embed_with(g, nodes, k, seed, Solver::Auto)
}

/// `embed` with a chosen solver.
pub fn embed_with(
    g: &RegionGraph,
    nodes: Option<&[u32]>,
    k: usize,
    seed: u64,
    solver: Solver,
) -> Result<Embedding, NoConvergence> {
    let (op, degrees) = NormalisedAffinity::new(g, nodes);
    let n = op.n();
    let k = k.min(n);
    if n == 0 || k == 0 {
        return Ok(Embedding { vectors: Mat::zeros(n, 0), values: Vec::new(), degrees });
    }
    let iterative = match solver {
        Solver::Auto => n > DENSE_LIMIT && 2 * k < n,
        Solver::Dense => false,
        Solver::ShiftInvert => k < n,
    };
    let solved = if iterative { shift_invert(&op, k, seed) } else { dense(&op, k) };
    clear_upper_simd_state();
    let (vectors, values) = solved?;
    Ok(Embedding { vectors, values, degrees })
}

/// Dense self-adjoint EVD (sequential: the same bits on any thread count).
fn dense(op: &NormalisedAffinity, k: usize) -> Result<(Mat<f64>, Vec<f64>), NoConvergence> {
    let n = op.n();
    let mut a = Mat::<f64>::zeros(n, n);
    for i in 0..n {
        a[(i, i)] = op.diag[i];
        for e in op.offsets[i]..op.offsets[i + 1] {
            a[(i, op.targets[e] as usize)] = op.values[e];
        }
    }
    let mut s = Diag::<f64>::zeros(n);
    let mut u = Mat::<f64>::zeros(n, n);
    let par = Par::Seq;
    let mut buf = MemBuffer::new(faer::linalg::evd::self_adjoint_evd_scratch::<f64>(
        n,
        faer::linalg::evd::ComputeEigenvectors::Yes,
        par,
        Default::default(),
    ));
    self_adjoint_evd(a.as_ref(), s.as_mut(), Some(u.as_mut()), par, MemStack::new(&mut buf), Default::default())
        .map_err(|_| NoConvergence)?;
    // Eigenvalues ascend: take the last k, largest first.
    let vectors = Mat::from_fn(n, k, |i, j| u[(i, n - 1 - j)]);
    let values = (0..k).map(|j| s[n - 1 - j]).collect();
    Ok((vectors, values))
}

/// Shift of the shift-and-invert: the solver iterates with (I - M + SHIFT I)^-1, whose
/// largest eigenvalues 1 / (lambda + SHIFT) are M's largest (lambda = 1 - mu the normalised
/// Laplacian's smallest). Positive, so disconnected components (lambda = 0) stay solvable.
const SHIFT: f64 = 1e-7;
/// Subspace iterations: each multiplies the error in eigenvector j by about
/// (lambda_j + SHIFT) / (lambda_b + SHIFT), b = k + k/4 (at least 8 more). Measured on the
/// 1000 x 1000 still life and Venus (about 1700 regions, k = 120), the relaxed normalized cut
/// sum(1 - mu_j) of the block is 0.4% and 1.1% above the dense optimum after 4 iterations
/// (0.1% and 0.5% after 5, at 30% more time); for k = 30 it is exact to 1e-6.
const SUBSPACE_ITERATIONS: usize = 4;

/// The k leading eigenpairs by subspace iteration with shift-and-invert (a sparse supernodal
/// Cholesky factor of the shifted normalised Laplacian, faer, sequential) and a final Rayleigh-Ritz projection. The
/// normalised affinity of a region graph has its top eigenvalues packed within 1e-3 of 1
/// (the self-loops dominate), which stalls Krylov methods on M itself; inverted, they spread
/// out by orders of magnitude. Start block seeded: the same result on every run.
fn shift_invert(op: &NormalisedAffinity, k: usize, seed: u64) -> Result<(Mat<f64>, Vec<f64>), NoConvergence> {
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::linalg::cholesky::{CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky};
    use faer::sparse::{SparseColMat, Triplet};
    let n = op.n();
    let b = (k + (k / 4).max(8)).min(n);
    let mut triplets = Vec::with_capacity(n + op.values.len());
    for i in 0..n {
        triplets.push(Triplet::new(i as u32, i as u32, 1.0 + SHIFT - op.diag[i]));
        for e in op.offsets[i]..op.offsets[i + 1] {
            triplets.push(Triplet::new(i as u32, op.targets[e], -op.values[e]));
        }
    }
    let a = SparseColMat::<u32, f64>::try_new_from_triplets(n, n, &triplets).map_err(|_| NoConvergence)?;
    // Supernodal even where faer's heuristic picks simplicial: with a block of ~150
    // right-hand sides its dense kernels solve 3-4x faster (measured at n = 1700).
    let params = CholeskySymbolicParams {
        supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
        ..Default::default()
    };
    let symbolic = factorize_symbolic_cholesky(a.symbolic(), faer::Side::Lower, SymmetricOrdering::Amd, params)
        .map_err(|_| NoConvergence)?;
    let par = Par::Seq;
    let mut values = vec![0f64; symbolic.len_val()];
    let mut buf = MemBuffer::new(symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default()));
    let llt = symbolic
        .factorize_numeric_llt(
            &mut values,
            a.as_ref(),
            faer::Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .map_err(|_| NoConvergence)?;
    let mut solve_buf = MemBuffer::new(symbolic.solve_in_place_scratch::<f64>(b, par));
    let mut q = Mat::<f64>::from_fn(n, b, |i, j| unit_f64(splitmix64(seed ^ splitmix64((i * b + j) as u64))) - 0.5);
    for _ in 0..SUBSPACE_ITERATIONS {
        llt.solve_in_place_with_conj(faer::Conj::No, q.as_mut(), par, MemStack::new(&mut solve_buf));
        q = q.qr().compute_thin_Q();
    }
    // Rayleigh-Ritz on M: T = Q^T M Q.
    let mq = op.apply(q.as_ref());
    let t = q.transpose() * &mq;
    let t = Mat::from_fn(b, b, |i, j| 0.5 * (t[(i, j)] + t[(j, i)]));
    let evd = t.self_adjoint_eigen(faer::Side::Lower).map_err(|_| NoConvergence)?;
    let u = evd.U();
    let s = evd.S();
    // Ascending: the last k are the largest.
    let pick = Mat::from_fn(b, k, |i, j| u[(i, b - 1 - j)]);
    let vectors = &q * &pick;
    let values = (0..k).map(|j| s[b - 1 - j]).collect();
    Ok((vectors, values))
}

/// Most rotation updates of the discretisation (it settles in 5 to 20).
const MAX_ROTATIONS: usize = 50;
/// The discretisation stops when its objective improves by less than this, relatively (at
/// k = 120 on a 1000 px still life that is after 15 updates, the last 4 of which had gained
/// 0.06% together).
const ROTATION_TOLERANCE: f64 = 1e-4;

/// Yu and Shi's discretisation (ICCV 2003): the k-way partition nearest, up to a rotation R, to
/// the relaxed solution. Rows of X* = D^-1/2 Z are normalised to X~; R starts from k rows of
/// X~ as mutually orthogonal as possible (the first one drawn with `seed`), then alternates
/// X = one-hot argmax of X~ R and R = V U^T from the SVD X^T X~ = U S V^T until the objective
/// trace(S) stops improving (`ROTATION_TOLERANCE`) or the partition stops changing.
pub fn discretise(emb: &Embedding, k: usize, seed: u64) -> Vec<u32> {
    let labels = rotate(emb, k, seed);
    clear_upper_simd_state();
    labels
}

fn rotate(emb: &Embedding, k: usize, seed: u64) -> Vec<u32> {
    let n = emb.vectors.nrows();
    let k = k.min(emb.vectors.ncols());
    if k <= 1 || n == 0 {
        return vec![0; n];
    }
    // X~, row-major: each region's row contiguous (the loops below run along rows).
    let mut x = vec![0f64; n * k];
    for (i, row) in x.chunks_exact_mut(k).enumerate() {
        let inv_sqrt_d = 1.0 / emb.degrees[i].sqrt();
        for (j, v) in row.iter_mut().enumerate() {
            *v = emb.vectors[(i, j)] * inv_sqrt_d;
        }
        let norm = row.iter().map(|v| v * v).sum::<f64>().sqrt();
        let inv = if norm > 0.0 { 1.0 / norm } else { 0.0 };
        row.iter_mut().for_each(|v| *v *= inv);
    }
    let row = |i: usize| &x[i * k..(i + 1) * k];
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>();
    // Initial rotation: columns are rows of X~, each the least aligned with those before.
    let mut r = Mat::<f64>::zeros(k, k);
    let mut pick = (splitmix64(seed ^ 0x5E6_0000) % n as u64) as usize;
    let mut c = vec![0f64; n];
    for col in 0..k {
        if col > 0 {
            let p = row(pick);
            for (i, ci) in c.iter_mut().enumerate() {
                *ci += dot(row(i), p).abs();
            }
            pick = (0..n).fold(0, |b, i| if c[i] < c[b] { i } else { b });
        }
        for (j, &v) in row(pick).iter().enumerate() {
            r[(j, col)] = v;
        }
    }
    let xm = MatRef::from_row_major_slice(&x, n, k);
    let par = Par::Seq;
    let mut labels = vec![0u32; n];
    let mut last = 0.0;
    let mut xr = Mat::<f64>::zeros(n, k);
    let mut best_value = vec![0f64; n];
    let mut m = vec![0f64; k * k];
    let mut buf = MemBuffer::new(faer::linalg::svd::svd_scratch::<f64>(
        k,
        k,
        faer::linalg::svd::ComputeSvdVectors::Full,
        faer::linalg::svd::ComputeSvdVectors::Full,
        par,
        Default::default(),
    ));
    for iteration in 0..MAX_ROTATIONS {
        faer::linalg::matmul::matmul(xr.as_mut(), faer::Accum::Replace, xm, r.as_ref(), 1.0, par);
        // Row-wise argmax (first maximum), column by column for contiguous reads.
        let mut changed = iteration == 0;
        best_value.fill(f64::NEG_INFINITY);
        let mut best = vec![0u32; n];
        for j in 0..k {
            for (i, &v) in xr.col_as_slice(j).iter().enumerate() {
                if v > best_value[i] {
                    best_value[i] = v;
                    best[i] = j as u32;
                }
            }
        }
        for i in 0..n {
            changed |= labels[i] != best[i];
        }
        labels = best;
        if !changed {
            break; // a fixed point: R would not change again
        }
        // X^T X~: row l sums the rows of X~ labelled l.
        m.fill(0.0);
        for i in 0..n {
            let l = labels[i] as usize;
            for (mj, &v) in m[l * k..(l + 1) * k].iter_mut().zip(row(i)) {
                *mj += v;
            }
        }
        let mut s = Diag::<f64>::zeros(k);
        let mut u = Mat::<f64>::zeros(k, k);
        let mut v = Mat::<f64>::zeros(k, k);
        if svd(
            MatRef::from_row_major_slice(&m, k, k),
            s.as_mut(),
            Some(u.as_mut()),
            Some(v.as_mut()),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .is_err()
        {
            break;
        }
        let objective: f64 = (0..k).map(|j| s[j]).sum();
        if iteration > 0 && (objective - last).abs() <= ROTATION_TOLERANCE * objective.abs().max(1.0) {
            break;
        }
        last = objective;
        // R = V U^T.
        faer::linalg::matmul::matmul(r.as_mut(), faer::Accum::Replace, v.as_ref(), u.transpose(), 1.0, par);
    }
    labels
}

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
