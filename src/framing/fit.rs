//! `fit`: how far behind the scene a converging (or planar) camera's focal centre must go for
//! every sampled vertex to lie within a share of its half-angles; `framing`
//! places the `fit` framing's C with it and `compose` starts each candidate's C from it.

use glam::DVec3;

use crate::camera::{CameraFrame, CameraKind};

/// Angles (horizontal, vertical) from the view axis at which a camera with focal centre `c`
/// sees `p`, for `p` in front of `c`. Spherical: the inverse of `Spherical::outward`;
/// cylindrical: horizontal only; planar: the tangent-plane angles of eq 4.1.
fn view_angles(kind: CameraKind, f: &CameraFrame, c: DVec3, p: DVec3) -> (f64, f64) {
    let w = p - c;
    let (x, y, z) = (w.dot(f.right), w.dot(f.up), -w.dot(f.forward));
    match kind {
        CameraKind::Cylindrical => (x.atan2(z).abs(), 0.0),
        CameraKind::Planar => (x.atan2(z).abs(), y.atan2(z).abs()),
        _ => {
            let len = w.length().max(1e-300);
            ((x / len).clamp(-1.0, 1.0).asin().abs(), y.atan2(z).abs())
        }
    }
}

/// The view half-angles a fitted scene may reach: `fill` of the camera's half-angles, each
/// capped at 80 deg (so C stays outside the scene even at 360 deg). None when the image has no
/// room (a zero angle where the camera needs one).
fn fit_limits(kind: CameraKind, half: (f64, f64), fill: f64) -> Option<(f64, f64)> {
    let cap = 80f64.to_radians();
    let lim = if kind == CameraKind::Planar {
        // The planar camera maps tan(angle) linearly to the image: fill in tangent space.
        let t = |h: f64| (fill * h.tan()).atan().min(cap);
        (t(half.0), t(half.1))
    } else {
        ((fill * half.0).min(cap), (fill * half.1).min(cap))
    };
    let no_room = lim.0 <= 0.0 || (kind != CameraKind::Cylindrical && lim.1 <= 0.0);
    (!no_room).then_some(lim)
}

/// Distance k behind `axis` (along the view) for the focal centre: the smallest k at which
/// every sampled vertex is in front of C and within `fill` of the half-angles (each
/// capped at 80 deg, so C stays outside the scene even at 360 deg).
pub(super) fn fit_depth(
    points: &[DVec3],
    kind: CameraKind,
    f: &CameraFrame,
    axis: DVec3,
    half: (f64, f64),
    radius: f64,
    fill: f64,
) -> f64 {
    let Some(lim) = fit_limits(kind, half, fill) else { return 1e6 * radius };
    let depth_max = points.iter().map(|p| (*p - axis).dot(f.forward)).fold(f64::NEG_INFINITY, f64::max);
    let k_min = depth_max.max(-radius) + 0.02 * radius;
    let quick = QuickLimits::new(kind, lim);
    let fits_at = |c: DVec3, p: &DVec3| {
        quick.within(kind, f, c, *p).unwrap_or_else(|| {
            let (a, b) = view_angles(kind, f, c, *p);
            a <= lim.0 && (kind == CameraKind::Cylindrical || b <= lim.1)
        })
    };
    // Whether every point fits with C at depth k: the same test at every k as testing all
    // `points`, with fewer points (24 bisections of 50 steps over 30,000 points
    // were most of framing's time). A point `QuickLimits` finds clearly within at some k is
    // within at every larger k (moving C back along the view only lowers x/z, y/z and x/|w|;
    // the margin is far above the rounding), so once a test at k fails and no later test is
    // below k (`raise`), such points are dropped from `open`.
    // (`open` borrows `points` until the first drop, and the list of points kept is
    // built in a buffer reused from test to test: no copy of 30,000 points per call.)
    let mut open: std::borrow::Cow<'_, [DVec3]> = std::borrow::Cow::Borrowed(points);
    let mut spare: Vec<DVec3> = Vec::new();
    let mut fits = |k: f64, raise: bool| {
        let c = axis + f.forward * k;
        if !raise {
            return open.iter().all(|p| fits_at(c, p));
        }
        let mut all = true;
        spare.clear();
        for p in open.iter() {
            match quick.within(kind, f, c, *p) {
                Some(true) => {}
                q => {
                    all &= q.unwrap_or_else(|| fits_at(c, p));
                    spare.push(*p);
                }
            }
        }
        if !all {
            let kept = std::mem::take(&mut spare);
            if let std::borrow::Cow::Owned(old) = std::mem::replace(&mut open, std::borrow::Cow::Owned(kept)) {
                spare = old;
            }
        }
        all
    };
    if points.is_empty() || fits(k_min, true) {
        return k_min;
    }
    let mut hi = k_min + radius;
    // Not raised here: the bisection below tests depths under these.
    while !fits(hi, false) {
        hi = k_min + (hi - k_min) * 2.0;
        if hi > 1e6 * radius {
            return 1e6 * radius;
        }
    }
    let mut lo = k_min;
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        // Every later test is above `mid` when it fails.
        if fits(mid, true) { hi = mid } else { lo = mid }
    }
    hi
}

/// `fit_depth`'s test without the trigonometry where its answer is clear (its
/// bisection evaluated atan2/asin 50 x 30,000 times per candidate, 0.25 s of a 2.2 s render):
/// an angle's limit compared as the ratio its tangent (or sine) is, with a relative margin of
/// 1e-7, a billion times the rounding of `view_angles`' functions, so wherever this answers it
/// answers as `view_angles` does; near the limit (and behind C, or for non-finite input) it
/// answers None and the angles decide.
struct QuickLimits {
    /// tan of the horizontal limit (planar, cylindrical) or its sine (spherical).
    h: f64,
    /// tan of the vertical limit.
    v: f64,
}

impl QuickLimits {
    const MARGIN: f64 = 1e-7;

    fn new(kind: CameraKind, lim: (f64, f64)) -> QuickLimits {
        let h = match kind {
            CameraKind::Cylindrical | CameraKind::Planar => lim.0.tan(),
            _ => lim.0.sin(),
        };
        QuickLimits { h, v: lim.1.tan() }
    }

    /// `ratio` (>= 0 or NaN) against `limit`: Some when it is clearly within or beyond.
    #[inline(always)]
    fn side(ratio: f64, limit: f64) -> Option<bool> {
        if ratio < limit * (1.0 - Self::MARGIN) {
            Some(true)
        } else if ratio > limit * (1.0 + Self::MARGIN) {
            Some(false)
        } else {
            None
        }
    }

    /// Whether `p` seen from `c` is within both limits, when that is clear.
    #[inline(always)]
    fn within(&self, kind: CameraKind, f: &CameraFrame, c: DVec3, p: DVec3) -> Option<bool> {
        let w = p - c;
        let (x, y, z) = (w.dot(f.right), w.dot(f.up), -w.dot(f.forward));
        // Behind C or beside it (angles of 90 deg and more, or NaN): the angles decide.
        if !(z > 0.0) {
            return None;
        }
        let a = match kind {
            CameraKind::Cylindrical | CameraKind::Planar => Self::side(x.abs() / z, self.h),
            _ => {
                let len = w.length();
                if !(len > 1e-300) {
                    return None;
                }
                Self::side(x.abs() / len, self.h)
            }
        };
        if kind == CameraKind::Cylindrical || a == Some(false) {
            return a;
        }
        match (a, Self::side(y.abs() / z, self.v)) {
            (_, Some(false)) => Some(false),
            (Some(true), Some(true)) => Some(true),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fit_depth` as it was before it dropped points: every point tested at every depth.
    fn fit_depth_every_point(
        points: &[DVec3],
        kind: CameraKind,
        f: &CameraFrame,
        axis: DVec3,
        half: (f64, f64),
        radius: f64,
        fill: f64,
    ) -> f64 {
        let Some(lim) = fit_limits(kind, half, fill) else { return 1e6 * radius };
        let depth_max = points.iter().map(|p| (*p - axis).dot(f.forward)).fold(f64::NEG_INFINITY, f64::max);
        let k_min = depth_max.max(-radius) + 0.02 * radius;
        let fits = |k: f64| {
            let c = axis + f.forward * k;
            points.iter().all(|p| {
                let (a, b) = view_angles(kind, f, c, *p);
                a <= lim.0 && (kind == CameraKind::Cylindrical || b <= lim.1)
            })
        };
        if points.is_empty() || fits(k_min) {
            return k_min;
        }
        let mut hi = k_min + radius;
        while !fits(hi) {
            hi = k_min + (hi - k_min) * 2.0;
            if hi > 1e6 * radius {
                return 1e6 * radius;
            }
        }
        let mut lo = k_min;
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if fits(mid) { hi = mid } else { lo = mid }
        }
        hi
    }

    /// Dropping the points that fit at every larger depth changes no answer: the same depth,
    /// to the bit, as testing every point at every step, for every camera kind, on clouds of
    /// several shapes, axes and angles.
    #[test]
    fn fit_depth_matches_testing_every_point() {
        let mut seed = 987654321u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut cases, mut bisected) = (0, 0);
        for trial in 0..24 {
            let dir = DVec3::new(rnd(), rnd(), rnd() - 1.5);
            let (f, _) = CameraFrame::new(DVec3::ZERO, dir, DVec3::Y).unwrap();
            let scale = DVec3::new(0.2 + rnd().abs(), 0.2 + rnd().abs() * 2.0, 0.2 + rnd().abs());
            let n = 200 + trial * 150;
            let points: Vec<DVec3> = (0..n).map(|_| DVec3::new(rnd(), rnd(), rnd()) * scale).collect();
            let axis = DVec3::new(rnd(), rnd(), rnd()) * 0.2;
            for kind in [CameraKind::Spherical, CameraKind::Cylindrical, CameraKind::Planar] {
                for (half, fill) in [((1.2, 0.8), 0.8), ((1.3, 1.3), 0.94), ((0.3, 0.2), 0.9), ((1.48, 1.48), 0.94)] {
                    let fast = fit_depth(&points, kind, &f, axis, half, 1.0, fill);
                    let every = fit_depth_every_point(&points, kind, &f, axis, half, 1.0, fill);
                    assert_eq!(
                        fast.to_bits(),
                        every.to_bits(),
                        "{kind:?} trial {trial} half {half:?}: {fast} vs {every}"
                    );
                    cases += 1;
                    let k_min =
                        points.iter().map(|p| (*p - axis).dot(f.forward)).fold(f64::NEG_INFINITY, f64::max) + 0.02;
                    bisected += (fast > k_min && fast < 1e5) as usize;
                }
            }
        }
        assert_eq!(cases, 24 * 3 * 4);
        // Most cases must reach the bisection (else the test shows nothing).
        assert!(bisected > cases * 3 / 4, "{bisected} of {cases} bisected");
    }

    /// Wherever `QuickLimits` answers, it answers as the angles do, for every camera kind,
    /// on points spread around C and points placed just inside and outside each limit.
    #[test]
    fn quick_limits_agree_with_view_angles() {
        let (f, _) = CameraFrame::new(DVec3::ZERO, DVec3::new(0.3, -0.2, -1.0), DVec3::Y).unwrap();
        let c = DVec3::new(0.1, 0.2, 0.3);
        let lim = (0.9, 0.6);
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for kind in [CameraKind::Spherical, CameraKind::Cylindrical, CameraKind::Planar] {
            let quick = QuickLimits::new(kind, lim);
            let (mut decided, mut total) = (0, 0);
            for i in 0..20_000 {
                let p = if i % 2 == 0 {
                    c + DVec3::new(rnd(), rnd(), rnd()) * 3.0
                } else {
                    // On a limit, up to 1e-6 rad off: within or beyond by less than the margin.
                    let (ha, va) = (lim.0 + 1e-6 * rnd(), lim.1 + 1e-6 * rnd());
                    let r = 0.5 + rnd().abs();
                    let (x, y, z) = match kind {
                        CameraKind::Spherical => (ha.sin(), ha.cos() * va.sin(), ha.cos() * va.cos()),
                        _ => (ha.tan(), va.tan(), 1.0),
                    };
                    c + (f.right * x * rnd().signum() + f.up * y * rnd().signum() - f.forward * z) * r
                };
                let (a, b) = view_angles(kind, &f, c, p);
                let exact = a <= lim.0 && (kind == CameraKind::Cylindrical || b <= lim.1);
                total += 1;
                if let Some(q) = quick.within(kind, &f, c, p) {
                    decided += 1;
                    assert_eq!(q, exact, "{kind:?} at {p}: quick {q}, angles {exact} ({a}, {b})");
                }
            }
            // The shortcut must actually decide most points (else it saves nothing).
            assert!(decided > total / 2, "{kind:?}: decided {decided} of {total}");
        }
    }
}
