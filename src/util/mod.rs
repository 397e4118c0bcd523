//! Small helpers several stages share, each written once: seeded random numbers (`rng`),
//! pixel-grid neighbours (`grid`), compressed adjacency rows (`csr`) and atomic file writes
//! (`files`).

pub mod csr;
pub mod files;
pub mod grid;
pub mod limits;
pub mod rng;
