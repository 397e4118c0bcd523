//! Run-time CPU feature dispatch and the switch that turns it off.
//!
//! Kernels compiled twice (for the baseline x86-64 and for an instruction set detected at run
//! time) are written to give the same bits on either path. `CUBIST_NO_SIMD=1` forces the
//! baseline path anyway, so a farm node can render with what every x86-64 CPU has, and a
//! suspected difference between nodes with different CPU features can be ruled out without
//! another build (docs/farm.md).

use std::ffi::OsStr;
use std::sync::OnceLock;

/// The environment variable that, set to anything but empty or `0`, forces the baseline path.
pub const NO_SIMD_ENV: &str = "CUBIST_NO_SIMD";

/// Whether a value of `CUBIST_NO_SIMD` (None: unset) leaves run-time dispatch on.
fn allows(value: Option<&OsStr>) -> bool {
    value.is_none_or(|v| v.is_empty() || v == "0")
}

/// Whether kernels may use instruction sets detected at run time: read once from
/// `CUBIST_NO_SIMD`, so one process never mixes both paths.
pub fn simd_allowed() -> bool {
    static ALLOWED: OnceLock<bool> = OnceLock::new();
    *ALLOWED.get_or_init(|| allows(std::env::var_os(NO_SIMD_ENV).as_deref()))
}

/// Whether AVX2 kernels run: the CPU has AVX2 and `CUBIST_NO_SIMD` is not set.
pub fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    let detected = std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    let detected = false;
    simd_allowed() && detected
}

/// The kernels' path in a few words, for `--verbose`: `avx2`, or `baseline` and why.
pub fn describe() -> &'static str {
    if avx2() {
        "avx2"
    } else if !simd_allowed() {
        "baseline (CUBIST_NO_SIMD)"
    } else {
        "baseline (no AVX2 on this CPU)"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_set_value_other_than_0_turns_dispatch_off() {
        assert!(allows(None));
        assert!(allows(Some(OsStr::new(""))));
        assert!(allows(Some(OsStr::new("0"))));
        assert!(!allows(Some(OsStr::new("1"))));
        assert!(!allows(Some(OsStr::new("yes"))));
    }
}
