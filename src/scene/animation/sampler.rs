//! glTF 2.0 animation samplers (the specification's "Animations" section and its Appendix C,
//! "Animation sampler interpolation modes"): keyframe times, values, and STEP, LINEAR and
//! CUBICSPLINE interpolation, with the quaternion rules for rotations.
//!
//! Evaluated in f64 from the file's f32 keys. Times before the first key give the first
//! key's value and times after the last the last one's (the specification's clamping).
//! Finding the interval is a binary search: the cost of a sample is logarithmic in the
//! number of keys, whatever a file holds.

use glam::{DQuat, DVec3, DVec4};

/// How values between keyframes are computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    /// The previous key's value until the next key.
    Step,
    /// Linear; spherical linear (slerp) along the shorter arc for rotations.
    Linear,
    /// Cubic Hermite spline with the file's in- and out-tangents (three values per key: in-tangent,
    /// value, out-tangent); rotations are normalised afterwards.
    CubicSpline,
}

/// One sampler: `times` strictly increasing (checked by `new`), `values` holding `width`
/// numbers per element and one element per key (three for cubic splines).
#[derive(Clone, Debug, PartialEq)]
pub struct Sampler {
    times: Vec<f32>,
    values: Vec<f32>,
    width: usize,
    interpolation: Interpolation,
}

impl Sampler {
    /// Checks what sampling relies on: at least one key, finite and strictly increasing times
    /// (the specification's rule; equal times would make a zero-length interval), finite
    /// values, and exactly one element per key (three for cubic splines) of `width` numbers.
    pub fn new(
        times: Vec<f32>,
        values: Vec<f32>,
        width: usize,
        interpolation: Interpolation,
    ) -> Result<Sampler, String> {
        if times.is_empty() {
            return Err("its input accessor has no keyframe".into());
        }
        if width == 0 {
            return Err("its output has no component per element".into());
        }
        if let Some(i) = times.iter().position(|t| !t.is_finite()) {
            return Err(format!("keyframe time {i} is not finite"));
        }
        if let Some(i) = times.windows(2).position(|w| w[1] <= w[0]) {
            return Err(format!(
                "keyframe times are not strictly increasing ({} then {} at key {})",
                times[i],
                times[i + 1],
                i + 1
            ));
        }
        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        let expected = times.len() as u64 * per_key;
        if !values.len().is_multiple_of(width) || (values.len() / width) as u64 != expected {
            return Err(format!(
                "{} output elements for {} keyframes (of {width} number(s) each); {} needs {expected}",
                values.len() as f64 / width as f64,
                times.len(),
                if per_key == 3 { "a cubic spline (in-tangent, value, out-tangent per key)" } else { "this" }
            ));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(format!("output value {i} is not finite"));
        }
        Ok(Sampler { times, values, width, interpolation })
    }

    /// Time of the last keyframe, seconds.
    pub fn end(&self) -> f32 {
        *self.times.last().expect("checked non-empty")
    }

    /// Time of the first keyframe, seconds.
    pub fn start(&self) -> f32 {
        self.times[0]
    }

    pub fn width(&self) -> usize {
        self.width
    }

    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    /// Element `e` (0 in-tangent, 1 value, 2 out-tangent for cubic splines; 0 otherwise) of key `k`.
    fn element(&self, k: usize, e: usize) -> &[f32] {
        let per_key = if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        let start = (k * per_key + e) * self.width;
        &self.values[start..start + self.width]
    }

    /// The key's value (the spline vertex for cubic splines).
    fn value(&self, k: usize) -> &[f32] {
        self.element(k, if self.interpolation == Interpolation::CubicSpline { 1 } else { 0 })
    }

    /// Where `t` falls: `Key(k)` on or outside the keys (clamped), `Between(k, u, dt)` strictly
    /// inside interval k at fraction u of its length dt.
    fn locate(&self, t: f64) -> Locus {
        let n = self.times.len();
        if !(t > self.times[0] as f64) {
            // Before the first key, and NaN, clamp to it.
            return Locus::Key(0);
        }
        if t >= self.times[n - 1] as f64 {
            return Locus::Key(n - 1);
        }
        // The last key at or before t: times[k] <= t < times[k + 1].
        let k = self.times.partition_point(|&x| x as f64 <= t) - 1;
        let (t0, t1) = (self.times[k] as f64, self.times[k + 1] as f64);
        if t == t0 {
            return Locus::Key(k);
        }
        Locus::Between(k, (t - t0) / (t1 - t0), t1 - t0)
    }

    /// The sampled value at time `t` (seconds), `width` numbers: translations, scales and morph
    /// weights (rotations: `sample_rotation`).
    pub fn sample(&self, t: f64, out: &mut [f64]) {
        debug_assert_eq!(out.len(), self.width);
        let read = |s: &[f32], out: &mut [f64]| out.iter_mut().zip(s).for_each(|(o, v)| *o = *v as f64);
        match self.locate(t) {
            Locus::Key(k) => read(self.value(k), out),
            Locus::Between(k, u, dt) => match self.interpolation {
                Interpolation::Step => read(self.value(k), out),
                Interpolation::Linear => {
                    let (a, b) = (self.value(k), self.value(k + 1));
                    for i in 0..self.width {
                        out[i] = (1.0 - u) * a[i] as f64 + u * b[i] as f64;
                    }
                }
                Interpolation::CubicSpline => {
                    let [h00, h10, h01, h11] = hermite(u);
                    let (v0, b0) = (self.element(k, 1), self.element(k, 2));
                    let (a1, v1) = (self.element(k + 1, 0), self.element(k + 1, 1));
                    for i in 0..self.width {
                        out[i] =
                            h00 * v0[i] as f64 + h10 * dt * b0[i] as f64 + h01 * v1[i] as f64 + h11 * dt * a1[i] as f64;
                    }
                }
            },
        }
    }

    /// A 3-vector channel (translation, scale) at time `t`.
    pub fn sample_vec3(&self, t: f64) -> DVec3 {
        let mut v = [0.0; 3];
        self.sample(t, &mut v[..self.width.min(3)]);
        DVec3::from(v)
    }

    /// A rotation channel (quaternions x, y, z, w) at time `t`, unit length: slerp along the
    /// shorter arc for LINEAR, the spline then normalised for CUBICSPLINE (Appendix C). A key
    /// of zero length (invalid, but seen) reads as the identity rather than NaN.
    pub fn sample_rotation(&self, t: f64) -> DQuat {
        let q = |s: &[f32]| DVec4::new(s[0] as f64, s[1] as f64, s[2] as f64, s[3] as f64);
        let v = match (self.locate(t), self.interpolation) {
            (Locus::Key(k), _) | (Locus::Between(k, _, _), Interpolation::Step) => q(self.value(k)),
            (Locus::Between(k, u, _), Interpolation::Linear) => {
                slerp(unit(q(self.value(k))), unit(q(self.value(k + 1))), u)
            }
            (Locus::Between(..), Interpolation::CubicSpline) => {
                let mut v = [0.0; 4];
                self.sample(t, &mut v);
                DVec4::from(v)
            }
        };
        let v = unit(v);
        DQuat::from_xyzw(v.x, v.y, v.z, v.w)
    }
}

enum Locus {
    Key(usize),
    Between(usize, f64, f64),
}

/// The cubic Hermite basis at u: weights of v_k, dt b_k, v_k+1, dt a_k+1 (Appendix C).
fn hermite(u: f64) -> [f64; 4] {
    let (u2, u3) = (u * u, u * u * u);
    [2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u, -2.0 * u3 + 3.0 * u2, u3 - u2]
}

fn unit(v: DVec4) -> DVec4 {
    v.try_normalize().unwrap_or(DVec4::W)
}

/// Spherical linear interpolation of unit quaternions along the shorter arc (Appendix C: when
/// the dot product is negative one key is negated, as q and -q are the same rotation); nearly
/// equal keys fall back to a normalised lerp, where slerp's sin(theta) division loses precision.
pub fn slerp(a: DVec4, b: DVec4, u: f64) -> DVec4 {
    let mut d = a.dot(b);
    let b = if d < 0.0 {
        d = -d;
        -b
    } else {
        b
    };
    if d > 0.9995 {
        return unit(a * (1.0 - u) + b * u);
    }
    let theta = d.clamp(-1.0, 1.0).acos();
    let s = theta.sin();
    a * (((1.0 - u) * theta).sin() / s) + b * ((u * theta).sin() / s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(times: &[f32], values: &[f32], width: usize, i: Interpolation) -> Sampler {
        Sampler::new(times.to_vec(), values.to_vec(), width, i).unwrap()
    }

    fn at(sampler: &Sampler, t: f64) -> Vec<f64> {
        let mut out = vec![0.0; sampler.width()];
        sampler.sample(t, &mut out);
        out
    }

    #[test]
    fn step_holds_the_previous_key() {
        let sm = s(&[0.0, 1.0, 2.0], &[1.0, 5.0, -3.0], 1, Interpolation::Step);
        assert_eq!(at(&sm, -1.0), vec![1.0], "before the first key: clamped");
        assert_eq!(at(&sm, 0.0), vec![1.0]);
        assert_eq!(at(&sm, 0.999), vec![1.0]);
        assert_eq!(at(&sm, 1.0), vec![5.0]);
        assert_eq!(at(&sm, 1.5), vec![5.0]);
        assert_eq!(at(&sm, 7.0), vec![-3.0], "after the last key: clamped");
        assert_eq!(at(&sm, f64::NAN), vec![1.0]);
    }

    #[test]
    fn linear_interpolates_each_component() {
        let sm = s(&[1.0, 3.0], &[0.0, 10.0, -2.0, 20.0, 0.0, 2.0], 3, Interpolation::Linear);
        // t = 1.5: u = 0.25.
        assert_eq!(sm.sample_vec3(1.5), DVec3::new(5.0, 7.5, -1.0));
        assert_eq!(sm.sample_vec3(0.0), DVec3::new(0.0, 10.0, -2.0));
        assert_eq!(sm.sample_vec3(3.0), DVec3::new(20.0, 0.0, 2.0));
    }

    #[test]
    fn cubic_spline_by_hand() {
        // One component, keys at t = 0 and t = 2 (dt = 2): v0 = 1, b0 (out-tangent) = 3,
        // a1 (in-tangent) = -1, v1 = 4. At u = 0.5: h = [0.5, 0.125, 0.5, -0.125], so
        // p = 0.5 * 1 + 0.125 * 2 * 3 + 0.5 * 4 - 0.125 * 2 * (-1) = 0.5 + 0.75 + 2 + 0.25 = 3.5.
        let sm = s(&[0.0, 2.0], &[9.0, 1.0, 3.0, -1.0, 4.0, 9.0], 1, Interpolation::CubicSpline);
        assert!((at(&sm, 1.0)[0] - 3.5).abs() < 1e-12, "{:?}", at(&sm, 1.0));
        // At the keys: the spline vertices, never the tangents.
        assert_eq!(at(&sm, 0.0), vec![1.0]);
        assert_eq!(at(&sm, 2.0), vec![4.0]);
        assert_eq!(at(&sm, -5.0), vec![1.0]);
        assert_eq!(at(&sm, 5.0), vec![4.0]);
        // u = 0.25: h = [0.84375, 0.140625, 0.15625, -0.046875]:
        // 0.84375 + 0.140625 * 6 + 0.15625 * 4 - 0.046875 * 2 * (-1) = 2.40625.
        assert!((at(&sm, 0.5)[0] - 2.40625).abs() < 1e-12);
    }

    #[test]
    fn slerp_by_hand_and_along_the_shorter_arc() {
        // Identity to 90 deg about Y: halfway is 45 deg about Y.
        let h = std::f32::consts::FRAC_1_SQRT_2;
        let sm = s(&[0.0, 1.0], &[0.0, 0.0, 0.0, 1.0, 0.0, h, 0.0, h], 4, Interpolation::Linear);
        let q = sm.sample_rotation(0.5);
        let expected = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_4);
        assert!(q.abs_diff_eq(expected, 1e-7), "{q:?}");
        // A quarter of the way: 22.5 deg, not the lerp's angle.
        let q = sm.sample_rotation(0.25);
        assert!(q.abs_diff_eq(DQuat::from_rotation_y(std::f64::consts::FRAC_PI_8), 1e-7), "{q:?}");
        // The same end rotation written as -q: still the 45 deg short way, not 315 deg.
        let sm = s(&[0.0, 1.0], &[0.0, 0.0, 0.0, 1.0, 0.0, -h, 0.0, -h], 4, Interpolation::Linear);
        let q = sm.sample_rotation(0.5);
        assert!((q.angle_between(DQuat::IDENTITY) - std::f64::consts::FRAC_PI_4).abs() < 1e-6, "{q:?}");
    }

    #[test]
    fn cubic_rotations_are_normalised() {
        // Zero tangents between identity and 180 deg about Z: the spline's midpoint has length
        // 1/sqrt(2) before normalisation.
        let v = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        let mut values = v.to_vec();
        values.extend([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        let sm = s(&[0.0, 1.0], &values, 4, Interpolation::CubicSpline);
        let q = sm.sample_rotation(0.5);
        assert!((q.length() - 1.0).abs() < 1e-12);
        assert!(q.abs_diff_eq(DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2), 1e-12), "{q:?}");
    }

    #[test]
    fn malformed_samplers_are_refused_with_a_reason() {
        let err = |t: &[f32], v: &[f32], w, i| Sampler::new(t.to_vec(), v.to_vec(), w, i).unwrap_err();
        assert!(err(&[], &[], 1, Interpolation::Linear).contains("no keyframe"));
        assert!(err(&[0.0, 0.0], &[1.0, 2.0], 1, Interpolation::Linear).contains("strictly increasing"));
        assert!(err(&[1.0, 0.5], &[1.0, 2.0], 1, Interpolation::Step).contains("strictly increasing"));
        assert!(err(&[0.0, f32::NAN], &[1.0, 2.0], 1, Interpolation::Step).contains("not finite"));
        let e = err(&[0.0, 1.0], &[1.0, 2.0], 1, Interpolation::CubicSpline);
        assert!(e.contains("2 output elements for 2 keyframes") && e.contains("needs 6"), "{e}");
        assert!(err(&[0.0], &[f32::INFINITY], 1, Interpolation::Step).contains("output value 0"));
        // A single key (the specification asks two of a spline) is read as a constant.
        let one = s(&[0.5], &[0.0, 7.0, 0.0], 1, Interpolation::CubicSpline);
        assert_eq!(at(&one, 3.0), vec![7.0]);
    }

    #[test]
    fn a_zero_quaternion_reads_as_the_identity() {
        let sm = s(&[0.0], &[0.0, 0.0, 0.0, 0.0], 4, Interpolation::Step);
        assert_eq!(sm.sample_rotation(0.0), DQuat::IDENTITY);
    }
}
