//! Small helpers several stages share, each written once: seeded random numbers (`rng`),
//! pixel-grid neighbours (`grid`), compressed adjacency rows (`csr`), atomic file writes
//! (`files`), sorting by buckets (`sort`) and hashing numbers in bulk (`hash`).

pub mod csr;
pub mod files;
pub mod grid;
pub mod hash;
pub mod limits;
pub mod rng;
pub mod sort;
