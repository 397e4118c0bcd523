//! Small helpers several stages share, each written once: seeded random numbers (`rng`),
//! pixel-grid neighbours (`grid`), a region's edge as a straight line (`edge_line`),
//! compressed adjacency rows (`csr`), atomic file writes (`files`), sorting by buckets
//! (`sort`), hashing numbers in bulk (`hash`) and run-time CPU feature dispatch (`cpu`).

pub mod cpu;
pub mod csr;
pub mod edge_line;
pub mod files;
pub mod grid;
pub mod hash;
pub mod limits;
pub mod rng;
pub mod sort;
