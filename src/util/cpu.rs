//! Run-time CPU feature dispatch and the switch that turns it off.
//!
//! Kernels compiled twice (for the baseline x86-64 and for an instruction set detected at run
//! time) are written to give the same bits on either path. `CUBIST_NO_SIMD=1` forces the
//! baseline path anyway, so a farm node can render with what every x86-64 CPU has, and a
//! suspected difference between nodes with different CPU features can be ruled out without
//! another build (docs/farm.md).

use std::sync::OnceLock;

/// The environment variable that, set to anything but empty or `0`, forces the baseline path.
pub const NO_SIMD_ENV: &str = "CUBIST_NO_SIMD";

/// Whether kernels may use instruction sets detected at run time: read once from
/// `CUBIST_NO_SIMD`, so one process never mixes both paths.
pub fn simd_allowed() -> bool {
    static ALLOWED: OnceLock<bool> = OnceLock::new();
    *ALLOWED.get_or_init(|| match std::env::var_os(NO_SIMD_ENV) {
        Some(v) => v.is_empty() || v == "0",
        None => true,
    })
}

/// Whether AVX2 kernels run: the CPU has AVX2 and `CUBIST_NO_SIMD` is not set.
#[cfg(target_arch = "x86_64")]
pub fn avx2() -> bool {
    simd_allowed() && std::arch::is_x86_feature_detected!("avx2")
}
