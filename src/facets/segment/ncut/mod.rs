//! k-way normalized cut of the region graph (Shi and Malik 2000; Yu and Shi 2003): the top
//! eigenvectors of D^-1/2 W D^-1/2, discretised by Yu and Shi's rotation, then made exactly
//! k spatially connected segments where the graph allows.
//!
//! One eigendecomposition (k = the largest level's N) serves every level: the k-way relaxation
//! of level N uses the N leading eigenvectors of the same matrix.
//!
//! `eigen`: the eigensolver (dense or shift-and-invert, faer); `simd`: the register state
//! faer leaves behind; `discretise`: Yu and Shi's rotation; `partition`: exactly k
//! connected segments.

mod discretise;
mod eigen;
mod partition;
mod simd;

use faer::Mat;

pub use discretise::discretise;
pub use eigen::{DENSE_LIMIT, Solver, embed, embed_with};
pub use partition::{Partition, Shortfall, connected_pieces, partition};
pub(crate) use simd::clear_upper_simd_state;

/// The leading eigenvectors of D^-1/2 W D^-1/2, columns in decreasing eigenvalue order, and the
/// degrees d (so that D^-1/2 times a column is the relaxed cut indicator).
pub struct Embedding {
    pub vectors: Mat<f64>,
    pub values: Vec<f64>,
    pub degrees: Vec<f64>,
}

/// The eigensolver failed (faer's QR iteration did not converge).
#[derive(Debug)]
pub struct NoConvergence;
