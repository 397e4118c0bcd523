//! A workaround for a CPU state faer's kernels leave behind.

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
