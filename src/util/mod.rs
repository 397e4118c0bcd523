//! Small helpers several stages share, each written once: seeded random numbers (`rng`),
//! pixel-grid neighbours (`grid`) and compressed adjacency rows (`csr`).

pub mod csr;
pub mod grid;
pub mod rng;
