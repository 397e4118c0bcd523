//! The inner loops of the clustered Gaussian means (`approx`), in f32 over candidates laid out
//! in contiguous arrays padded to a multiple of `LANES`, written so the compiler vectorises
//! them: no branches (masks multiply), a polynomial exp, partial sums kept per lane.
//!
//! Why f32 and a hand-written exp: these loops are the whole cost of saliency on large meshes;
//! eight f32 lanes per AVX2 instruction, and an exp the compiler can vectorise (libm's cannot
//! be), make them about 4x faster than f64 with `f64::exp`. Their rounding (relative 2e-7) is
//! far below the approximation's own error (1e-3 of the result). The exact method
//! (`levels::gaussian_means`) stays in f64 with `f64::exp`.
//!
//! Why the same bits everywhere: each kernel is compiled twice, for the baseline x86-64 and for
//! AVX2 (picked at run time, unless `CUBIST_NO_SIMD=1`), and both perform the same IEEE operations in the same order
//! (additions and multiplications only, no fused multiply-add, per-lane sums added in a fixed
//! order), so the result does not depend on the CPU, nor on the thread count.

use glam::DVec3;

/// Candidates per vector; arrays handed to the kernels have a length that is a multiple of it.
pub const LANES: usize = 8;

/// f32 1.0, as bits: `f32::from_bits(ONE & mask)` is 1.0 where the mask is all ones, else 0.0.
const ONE: u32 = 0x3f80_0000;

/// A 0/1 factor from a condition, without a branch.
#[inline(always)]
fn select(c: bool) -> f32 {
    f32::from_bits(ONE & (c as u32).wrapping_neg())
}

/// exp(x) for x <= 0, clamped below at -80 (giving ~1.8e-35, not 0): Cody-Waite range
/// reduction to |r| <= ln 2 / 2 and a degree-6 Taylor polynomial; relative error below 2e-7.
#[inline(always)]
pub fn exp_neg(x: f32) -> f32 {
    // 1.5 * 2^23: adding it rounds to an integer and leaves that integer in the low bits.
    const MAGIC: f32 = 12_582_912.0;
    let x = x.max(-80.0);
    let t = x * std::f32::consts::LOG2_E + MAGIC;
    let k = t - MAGIC;
    let r = (x - k * 0.693_359_4) - k * -2.121_944_4e-4;
    let mut p = 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    // 2^k: the integer k sits in t's low mantissa bits; moved into the exponent field.
    p * f32::from_bits(t.to_bits().wrapping_add(127) << 23)
}

/// exp(x) for x <= 0 in f64 (clamped below at -700): the same reduction with a degree-12
/// Taylor polynomial; relative error below 4e-16, vectorisable (libm's is not).
#[inline(always)]
pub fn exp_neg64(x: f64) -> f64 {
    // 1.5 * 2^52, as MAGIC above.
    const MAGIC: f64 = 6_755_399_441_055_744.0;
    const LN2_HI: f64 = 6.931_471_803_691_238e-1;
    const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
    let x = x.max(-700.0);
    let t = x * std::f64::consts::LOG2_E + MAGIC;
    let k = t - MAGIC;
    let r = (x - k * LN2_HI) - k * LN2_LO;
    let mut p = 1.0 / 479_001_600.0;
    for c in [39_916_800.0, 3_628_800.0, 362_880.0, 40_320.0, 5_040.0, 720.0, 120.0, 24.0, 6.0, 2.0, 1.0, 1.0] {
        p = p * r + 1.0 / c;
    }
    p * f64::from_bits(t.to_bits().wrapping_add(1023) << 52)
}

/// Sum over lanes, in f64, in lane order.
#[inline(always)]
fn lanes_sum(a: &[f32; LANES]) -> f64 {
    a.iter().fold(0.0f64, |s, x| s + *x as f64)
}

/// One sigma's constants, in f32.
#[derive(Clone, Copy, Debug)]
pub struct Kernel {
    /// The cut-off 2 sigma and its square.
    pub cut: f32,
    pub cut2: f32,
    /// Squared distances are clamped to (cut + one cell)^2 (where the ramp is 0 already) before
    /// the expansions of d, so that far or padding candidates stay finite.
    pub clamp2: f32,
    /// 1 / (2 sigma^2), 1 / sigma^2.
    pub inv: f32,
    pub inv_s2: f32,
    /// 1 / cell side: the width of the cut-off ramp is one cell.
    pub inv_c: f32,
    pub inv_cut: f32,
}

impl Kernel {
    pub fn new(sigma: f64, cell: f64) -> Kernel {
        let cut = 2.0 * sigma;
        Kernel {
            cut: cut as f32,
            cut2: (cut * cut) as f32,
            clamp2: ((cut + cell) * (cut + cell)) as f32,
            inv: (1.0 / (2.0 * sigma * sigma)) as f32,
            inv_s2: (1.0 / (sigma * sigma)) as f32,
            inv_c: (1.0 / cell) as f32,
            inv_cut: (1.0 / cut) as f32,
        }
    }
}

/// Defines `$name` running `$body` compiled for AVX2 when the CPU has it (and `CUBIST_NO_SIMD`
/// does not force the baseline: `util::cpu`), else for the baseline (same operations, same
/// bits: see the module doc).
macro_rules! dispatch {
    ($(#[$doc:meta])* $name:ident = $body:ident ($($arg:ident : $ty:ty),*) -> $ret:ty) => {
        $(#[$doc])*
        pub fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if crate::util::cpu::avx2() {
                #[target_feature(enable = "avx2")]
                unsafe fn avx2($($arg: $ty),*) -> $ret {
                    $body($($arg),*)
                }
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe { avx2($($arg),*) };
            }
            $body($($arg),*)
        }
    };
}

dispatch!(
    /// Exact sums for one target point `p`, in f64: (sum of w h, sum of w) over the candidate
    /// points (x, y, z, h), w = exp(-d^2 / (2 sigma^2)) for d^2 < `cut2`, else 0. Distances are
    /// computed as `neighbourhood::dist2` computes them, so the neighbourhoods are exactly the
    /// exact method's (only the exp differs, by 1e-16).
    exact_sum = exact_body(cut2: f64, inv: f64, x: &[f64], y: &[f64], z: &[f64], h: &[f64], p: DVec3) -> (f64, f64)
);

/// Lanes of the f64 kernel.
pub const LANES64: usize = 4;

#[inline(always)]
fn exact_body(cut2: f64, inv: f64, x: &[f64], y: &[f64], z: &[f64], h: &[f64], p: DVec3) -> (f64, f64) {
    let mut num = [0.0f64; LANES64];
    let mut den = [0.0f64; LANES64];
    let chunks = x.chunks_exact(LANES64).zip(y.chunks_exact(LANES64)).zip(z.chunks_exact(LANES64));
    for (((x, y), z), h) in chunks.zip(h.chunks_exact(LANES64)) {
        let mut w = [0.0f64; LANES64];
        for l in 0..LANES64 {
            let (dx, dy, dz) = (x[l] - p.x, y[l] - p.y, z[l] - p.z);
            let d2 = dx * dx + dy * dy + dz * dz;
            w[l] = exp_neg64(-d2 * inv) * f64::from_bits(1f64.to_bits() & ((d2 < cut2) as u64).wrapping_neg());
        }
        for l in 0..LANES64 {
            num[l] += w[l] * h[l];
            den[l] += w[l];
        }
    }
    ((num[0] + num[1]) + (num[2] + num[3]), (den[0] + den[1]) + (den[2] + den[3]))
}

/// What one target group receives from the source clusters: the sums at its expansion point
/// and their gradients (for the first-order step to each vertex).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Expansion {
    pub num: f64,
    pub den: f64,
    pub grad_num: DVec3,
    pub grad_den: DVec3,
}

impl Expansion {
    /// G at `d` from the expansion point: the ratio of the first-order sums, or the plain ratio
    /// where the step would take the weight below half (far outside the group's extent).
    pub fn at(&self, d: DVec3) -> f64 {
        let (n, w) = (self.num + self.grad_num.dot(d), self.den + self.grad_den.dot(d));
        if w > 0.5 * self.den { n / w } else { self.num / self.den }
    }
}

dispatch!(
    /// Clustered sums at the point `m`: each source cluster (centroid x, y, z; `count`
    /// vertices; `h_sum` their summed curvature) weighs exp(-d^2 / (2 sigma^2)) times the
    /// fraction of it inside the cut-off, a ramp one cell wide centred on 2 sigma: a cluster
    /// straddling the cut-off counts in part, as its vertices do (its vertices spread about
    /// half a cell either side of its centroid).
    clustered_sum = clustered_body(k: &Kernel, x: &[f32], y: &[f32], z: &[f32], count: &[f32], h_sum: &[f32], m: [f32; 3]) -> Expansion
);

#[inline(always)]
fn clustered_body(k: &Kernel, x: &[f32], y: &[f32], z: &[f32], count: &[f32], h_sum: &[f32], m: [f32; 3]) -> Expansion {
    let mut a = [[0.0f32; LANES]; 8];
    for c in 0..x.len() / LANES {
        let r = c * LANES..(c + 1) * LANES;
        let (x, y, z) = (&x[r.clone()], &y[r.clone()], &z[r.clone()]);
        let (count, h_sum) = (&count[r.clone()], &h_sum[r]);
        let (mut w, mut gs) = ([0.0f32; LANES], [0.0f32; LANES]);
        let (mut dx, mut dy, mut dz) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        for l in 0..LANES {
            dx[l] = x[l] - m[0];
            dy[l] = y[l] - m[1];
            dz[l] = z[l] - m[2];
            let d2 = dx[l] * dx[l] + dy[l] * dy[l] + dz[l] * dz[l];
            let g = exp_neg(-d2 * k.inv);
            // d and 1/d where the ramp needs them (within half a cell of 2 sigma) without a
            // square root or a division: second-order expansions about d = 2 sigma (relative
            // errors below 1e-3 and 1% there), monotonic up to the clamp, beyond which the
            // ramp is 0 (so no mask is needed, and weights are continuous in the target point).
            let d2c = d2.min(k.clamp2);
            let u = d2c - k.cut2;
            let d = k.cut + u * (0.5 * k.inv_cut) - u * u * (0.125 * k.inv_cut * k.inv_cut * k.inv_cut);
            let inv_d = k.inv_cut * (1.5 - 0.5 * d2c * k.inv_cut * k.inv_cut);
            let f = ((k.cut - d) * k.inv_c + 0.5).clamp(0.0, 1.0);
            let on_ramp = select((f > 0.0) & (f < 1.0));
            // Weight and the factor of its gradient with respect to the target point along
            // the offset: d/dx [f g] = offset (f g / sigma^2 + g / (c d)) on the ramp.
            let gf = g * f;
            w[l] = gf;
            gs[l] = gf * k.inv_s2 + g * k.inv_c * inv_d * on_ramp;
        }
        for l in 0..LANES {
            let (wn, wh) = (w[l] * count[l], w[l] * h_sum[l]);
            let (gn, gh) = (gs[l] * count[l], gs[l] * h_sum[l]);
            a[0][l] += wh;
            a[1][l] += wn;
            a[2][l] += gh * dx[l];
            a[3][l] += gh * dy[l];
            a[4][l] += gh * dz[l];
            a[5][l] += gn * dx[l];
            a[6][l] += gn * dy[l];
            a[7][l] += gn * dz[l];
        }
    }
    let s = |i: usize| lanes_sum(&a[i]);
    Expansion { num: s(0), den: s(1), grad_num: DVec3::new(s(2), s(3), s(4)), grad_den: DVec3::new(s(5), s(6), s(7)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_is_accurate_over_the_range_used() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let x = -20.0 * i as f64 / 100_000.0;
            let e = exp_neg(x as f32) as f64;
            let t = (x as f32 as f64).exp();
            worst = worst.max(((e - t) / t).abs());
        }
        assert!(worst < 3e-7, "relative error {worst}");
        assert_eq!(exp_neg(0.0), 1.0);
        assert!(exp_neg(f32::NEG_INFINITY) > 0.0 && exp_neg(-1e30) < 1e-34);
    }

    fn candidates(n: usize, seed: u64) -> [Vec<f32>; 5] {
        let r = |i: usize, k: u64| {
            crate::util::rng::unit_f64(crate::util::rng::splitmix64(seed ^ (i as u64 * 5 + k))) as f32
        };
        [
            (0..n).map(|i| r(i, 0) * 2.0 - 1.0).collect(),
            (0..n).map(|i| r(i, 1) * 2.0 - 1.0).collect(),
            (0..n).map(|i| r(i, 2) * 0.2).collect(),
            (0..n).map(|i| 1.0 + (r(i, 3) * 4.0).floor()).collect(),
            (0..n).map(|i| r(i, 4) - 0.5).collect(),
        ]
    }

    #[test]
    fn exp64_is_accurate() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let x = -30.0 * i as f64 / 100_000.0;
            worst = worst.max(((exp_neg64(x) - x.exp()) / x.exp()).abs());
        }
        assert!(worst < 1e-15, "relative error {worst}");
    }

    #[test]
    fn exact_kernel_matches_the_definition() {
        let [x, y, z, _, h] = candidates(LANES * 40, 3).map(|v| v.iter().map(|&a| a as f64).collect::<Vec<f64>>());
        let (s, p) = (0.3f64, DVec3::new(0.1, -0.2, 0.05));
        let (num, den) = exact_sum(4.0 * s * s, 1.0 / (2.0 * s * s), &x, &y, &z, &h, p);
        let (mut n2, mut d2s) = (0.0f64, 0.0f64);
        for i in 0..x.len() {
            let d2 = crate::saliency::neighbourhood::dist2(DVec3::new(x[i], y[i], z[i]), p);
            if d2 < 4.0 * s * s {
                let w = (-d2 / (2.0 * s * s)).exp();
                n2 += w * h[i];
                d2s += w;
            }
        }
        assert!((num - n2).abs() < 1e-12 * d2s && (den - d2s).abs() < 1e-12 * d2s, "{num} {n2} {den} {d2s}");
    }

    /// Central differences of the clustered sums against their gradient, about `m`.
    fn check_gradient(c: &[Vec<f32>; 5], m: [f32; 3], step: f32, tol: f64) {
        let [x, y, z, n, h] = c;
        let k = Kernel::new(0.3, 0.075);
        let e = clustered_sum(&k, x, y, z, n, h, m);
        for axis in 0..3 {
            let (mut p, mut q) = (m, m);
            p[axis] += step;
            q[axis] -= step;
            let (a, b) = (clustered_sum(&k, x, y, z, n, h, p), clustered_sum(&k, x, y, z, n, h, q));
            for (fd, g) in [
                ((a.den - b.den) / (2.0 * step as f64), e.grad_den.to_array()[axis]),
                ((a.num - b.num) / (2.0 * step as f64), e.grad_num.to_array()[axis]),
            ] {
                assert!((fd - g).abs() <= tol * g.abs().max(1e-3), "axis {axis}: {fd} vs {g}");
            }
        }
    }

    #[test]
    fn clustered_gradient_matches_finite_differences() {
        // Well inside the cut-off (2 sigma = 0.6): the Gaussian's own gradient.
        let [x, y, z, n, h] = candidates(8 * 20, 5);
        let inside = [x.iter().map(|v| v * 0.25).collect(), y.iter().map(|v| v * 0.25).collect(), z, n, h];
        check_gradient(&inside, [0.05, 0.02, 0.1], 1e-3, 0.01);
        // One cluster on the cut-off's ramp (0.6 +- 0.0375 away), alone and padded.
        for d in [0.58f32, 0.6, 0.62] {
            let mut one: [Vec<f32>; 5] = [vec![d], vec![0.0], vec![0.0], vec![3.0], vec![0.7]];
            for (v, pad) in one.iter_mut().zip([1e30, 1e30, 1e30, 0.0, 0.0]) {
                v.resize(LANES, pad);
            }
            check_gradient(&one, [0.0, 0.0, 0.0], 1e-3, 0.02);
        }
    }

    #[test]
    fn avx2_and_baseline_give_the_same_bits() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            let [x, y, z, c, h] = candidates(8 * 77, 9);
            let k = Kernel::new(0.25, 0.0625);
            let [x64, y64, z64, h64] = [&x, &y, &z, &h].map(|v| v.iter().map(|&a| a as f64).collect::<Vec<f64>>());
            for p in [[0.0f32, 0.0, 0.0], [0.3, -0.4, 0.1], [0.9, 0.9, 0.0]] {
                let p64 = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                assert_eq!(
                    exact_sum(0.25, 8.0, &x64, &y64, &z64, &h64, p64),
                    exact_body(0.25, 8.0, &x64, &y64, &z64, &h64, p64)
                );
                assert_eq!(clustered_sum(&k, &x, &y, &z, &c, &h, p), clustered_body(&k, &x, &y, &z, &c, &h, p));
            }
            return;
        }
        // Only an AVX2 CPU has both kernels to compare. libtest cannot mark a test skipped at
        // run time, so it says so on stderr directly (not captured: shown in every run), and
        // CUBIST_REQUIRE_AVX2=1 turns the skip into a failure on a machine that must have AVX2.
        let why = "this CPU has no AVX2, only the baseline kernels run";
        assert!(std::env::var("CUBIST_REQUIRE_AVX2").as_deref() != Ok("1"), "required: {why}");
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "SKIPPED: avx2_and_baseline_give_the_same_bits: {why}");
    }
}
