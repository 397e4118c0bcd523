//! Composition: the `compose` framing of the converging cameras, chosen per scene from its
//! vertices, so the subject is framed close with its proportions kept.
//!
//! With the focal centre C behind the subject, a converging camera shows what the lines
//! through C show: the convergence angle only scales that view onto the canvas. The rule:
//! 1. C goes behind the subject, as close as it may while every vertex stays within
//!    `margin` x `MAX_HALF_ANGLE` of the view axis (a few candidate distances further back,
//!    `DEPTH_STEPS`, are measured too). The cap is small: nearer, the converging camera's
//!    reverse perspective swells the parts nearest C into a blob.
//! 2. C slides across the view so the scene's angular extent is centred, then step 1 runs
//!    again from there (`CENTRING_PASSES`).
//! 3. The spans are fitted to the vertices with both axes at the same scale per pixel: the
//!    wider extent sets its span and the other span is widened to match (up to
//!    `ISO_WIDEST`), so a tall or thin subject keeps its proportions with canvas beside it.
//!    A subject taller than the canvas on the cylindrical camera is framed closer, as a
//!    half-length portrait: the band shows part of its height (`TALL_CROP_POWER`,
//!    `TALL_CROP_MAX`), its top, or its foot where its bulk lies (`Seen::bulk_at`).
//! 4. Each candidate's fill is measured by tracing a tiny image; the closest candidate that
//!    fills `FILL_GOAL`, else the closest within `NEAR_BEST` of the best fill, wins.
//! 5. (`framing`) `auto` on a tall scene composes with both converging cameras and keeps the
//!    better (`Composition::better_than`); a subject much wider from another side is seen from
//!    that side when the front fills little (`framing::frame_camera`).
//!
//! Why: filling the canvas by stretching or by a strong wrap made subjects unreadable; a
//! smaller subject in true proportions reads, and the planes fill the canvas around it.
//! docs/design/composition.md keeps the history.

use glam::DVec3;
use rayon::prelude::*;

use super::fit::fit_depth;
use crate::camera::CameraFrame;
use crate::camera::CameraKind;

/// Largest half-angle a vertex may reach from the view axis: spans stay within the thesis's
/// best ambiguity range (120-150 deg, section 5).
pub const MAX_HALF_ANGLE: f64 = 12.0 * std::f64::consts::PI / 180.0;
/// The half-angle caps step 6 tries in turn: the thesis's range first, then a wider wrap.
pub const HALF_ANGLE_CAPS: [f64; 1] = [MAX_HALF_ANGLE];
/// Default `fill` for `compose`: the scene's extent over the canvas's span, per axis.
pub const COMPOSE_FILL: f64 = 0.94;
/// The ratios between the horizontal and vertical scale per pixel (angle or length per pixel)
/// step 4 may allow, least distortion first (step 5 picks one per scene).
pub const ANISOTROPY_STEPS: [f64; 1] = [1.0];
/// The share of the canvas a composition should fill (the subject occupies most of
/// the picture); step 5 takes the least distortion that reaches it.
pub const FILL_GOAL: f64 = 0.5;
/// The widest span a canvas may be widened to so both axes have the same scale per pixel: a
/// thin subject keeps its proportions with empty canvas beside it.
pub const ISO_WIDEST: f64 = 150.0 * std::f64::consts::PI / 180.0;
/// A subject taller than the canvas shows its height divided by (how much taller it is than
/// the canvas, at one scale per pixel) to this power, at most `TALL_CROP_MAX`: its foot, or
/// its top, cropped.
const TALL_CROP_POWER: f64 = 0.5;
const TALL_CROP_MAX: f64 = 1.5;
/// Centring passes of step 2.
const CENTRING_PASSES: usize = 2;
/// Candidate distances of C behind its closest place, in scene radii (step 5).
const DEPTH_STEPS: [f64; 8] = [0.0, 0.0625, 0.125, 0.25, 0.5, 1.0, 2.0, 4.0];
/// Step 5 takes the closest candidate whose fill is at least this share of the best.
pub const NEAR_BEST: f64 = 0.9;

/// What `compose` chose for a spherical or cylindrical camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Composition {
    /// The focal centre C (cylindrical: a point of the focal line at the band's middle).
    pub centre: DVec3,
    /// Horizontal convergence angle, radians.
    pub angle_x: f64,
    /// Spherical: vertical convergence angle, radians. Cylindrical: unused (0).
    pub angle_y: f64,
    /// Cylindrical: the band's height, render units. Spherical: unused (0).
    pub height: f64,
    /// Cylindrical: how far the band's middle lies above the scene's, render units: positive
    /// when a tall subject's foot is cropped, negative when its top is; else 0.
    pub lift: f64,
    /// The share of the canvas it fills (the probe's estimate; 0 until measured).
    pub fill: f64,
    /// Its place in the order of preference among the candidates that reach `FILL_GOAL`
    /// (angle cap, then stretch, then distance); `usize::MAX` when none reached it.
    pub rank: usize,
    /// Which candidate it is (angle cap, stretch, distance, in that order of preference), so
    /// `compose_candidate` can make the same one again from another sample of the scene.
    pub candidate: usize,
}

impl Composition {
    /// Whether `self` is a better composition than `other` (of another camera type, for
    /// `auto`): it reaches `FILL_GOAL` with less wrap or stretch, or, when neither reaches it,
    /// fills more. Ties keep `other`.
    pub fn better_than(&self, other: &Composition) -> bool {
        if self.rank != other.rank {
            return self.rank < other.rank;
        }
        self.rank == usize::MAX && self.fill > other.fill
    }
}

/// Angular (and, for the cylindrical camera, vertical) extents of `points` seen from `c`:
/// (min, max) of the horizontal angle and of the vertical angle (spherical) or height above
/// `c` (cylindrical).
///
/// Why: the extremes of the same angles without an `asin`/`atan2` per point (half
/// of framing's time went to them, 30,000 points a few dozen times per camera). Each angle is
/// a monotone function of a key found without trigonometry: `asin(r)` of its argument r, and
/// `atan2(n, z)` of the slope n / z where z > 0 and |n| <= `SLOPE_CAP` z. The angles are taken
/// only at the points whose key lies within a margin of the keys' extremes (1e-9 in r, 1e-7
/// relative in the slope: an angle 1e-13 radians or more smaller, a thousand times the
/// functions' rounding of one unit in the last place), and at every point without a key (behind
/// or beside C, or steeper than the cap); a point left out is smaller than one kept, so the
/// extremes are those of every point, bit for bit.
fn extents(points: &[DVec3], kind: CameraKind, f: &CameraFrame, c: DVec3) -> ((f64, f64), (f64, f64)) {
    let cylindrical = kind == CameraKind::Cylindrical;
    let view = |p: &DVec3| {
        let w = *p - c;
        (w, w.dot(f.right), w.dot(f.up), -w.dot(f.forward))
    };
    // The horizontal angle's key and its angle: atan2(x, z) (cylindrical) or asin(r).
    let h_key = |w: DVec3, x: f64, z: f64| {
        if cylindrical { slope(x, z) } else { Some((x / w.length().max(1e-300)).clamp(-1.0, 1.0)) }
    };
    let h_angle = |w: DVec3, x: f64, z: f64| {
        if cylindrical { x.atan2(z) } else { (x / w.length().max(1e-300)).clamp(-1.0, 1.0).asin() }
    };
    let h_margin = |k: f64| if cylindrical { 1e-7 * (1.0 + k.abs()) } else { 1e-9 };
    let (mut hk, mut vk) = ((f64::INFINITY, f64::NEG_INFINITY), (f64::INFINITY, f64::NEG_INFINITY));
    // Cylindrical: the height itself, no key needed.
    let mut heights = (f64::INFINITY, f64::NEG_INFINITY);
    for p in points {
        let (w, x, y, z) = view(p);
        if let Some(k) = h_key(w, x, z) {
            hk = (hk.0.min(k), hk.1.max(k));
        }
        if cylindrical {
            heights = (heights.0.min(y), heights.1.max(y));
        } else if let Some(k) = slope(y, z) {
            vk = (vk.0.min(k), vk.1.max(k));
        }
    }
    let near = |k: Option<f64>, ext: (f64, f64), margin: &dyn Fn(f64) -> f64| match k {
        None => true,
        Some(k) => k <= ext.0 + margin(ext.0) || k >= ext.1 - margin(ext.1),
    };
    let slope_margin = |k: f64| 1e-7 * (1.0 + k.abs());
    let mut h = (f64::INFINITY, f64::NEG_INFINITY);
    let mut v = if cylindrical { heights } else { (f64::INFINITY, f64::NEG_INFINITY) };
    for p in points {
        let (w, x, y, z) = view(p);
        if near(h_key(w, x, z), hk, &h_margin) {
            let a = h_angle(w, x, z);
            h = (h.0.min(a), h.1.max(a));
        }
        if !cylindrical && near(slope(y, z), vk, &slope_margin) {
            let b = y.atan2(z);
            v = (v.0.min(b), v.1.max(b));
        }
    }
    if !h.0.is_finite() {
        return ((0.0, 0.0), (0.0, 0.0));
    }
    (h, v)
}

/// Steepest slope n / z `extents` keys `atan2(n, z)` by (about 89.94 deg): beyond it the
/// angle's derivative in the slope (1 / (1 + slope^2)) could shrink a 1e-7 margin in the
/// slope below the functions' rounding, so such points take their angle.
const SLOPE_CAP: f64 = 1e3;

/// `atan2(n, z)`'s key in `extents`: the slope n / z, when z > 0 and |n| <= `SLOPE_CAP` z.
#[inline]
fn slope(n: f64, z: f64) -> Option<f64> {
    (z > 0.0 && n.abs() <= SLOPE_CAP * z).then(|| n / z)
}

/// What the spans of step 3 and 4 read of `points` seen from a focal centre `c`: their
/// `extents` and, for the cylindrical camera, their mean distance from the focal line. It
/// depends on C alone, so it is measured once per centre for the candidates'
/// four stretch ratios (it was measured once per candidate, a quarter of framing's time).
struct Seen {
    c: DVec3,
    h: (f64, f64),
    v: (f64, f64),
    /// Cylindrical: the mean distance from the focal line (at least 1e-9); else unused.
    r: f64,
    /// Cylindrical: the points' width across the view in each of `SLICES` equal bands of
    /// height, from the top down (`bulk_at` reads them); else empty.
    widths: Vec<f64>,
}

impl Seen {
    fn new(points: &[DVec3], kind: CameraKind, f: &CameraFrame, c: DVec3) -> Seen {
        let (h, v) = extents(points, kind, f, c);
        if kind != CameraKind::Cylindrical {
            return Seen { c, h, v, r: 0.0, widths: Vec::new() };
        }
        let centre = c + f.up * (0.5 * (v.0 + v.1));
        let r = mean_distance_from_line(points, f, centre).max(1e-9);
        let mut across = vec![(f64::INFINITY, f64::NEG_INFINITY); SLICES];
        let tall = (v.1 - v.0).max(1e-300);
        for p in points {
            let w = *p - c;
            let k = (((v.1 - w.dot(f.up)) / tall * SLICES as f64) as usize).min(SLICES - 1);
            let x = w.dot(f.right);
            across[k] = (across[k].0.min(x), across[k].1.max(x));
        }
        let widths = across.iter().map(|&(lo, hi)| if lo <= hi { hi - lo } else { 0.0 }).collect();
        Seen { c, h, v, r, widths }
    }

    /// Where a band `1 / crop` of the subject's height is framed: at the subject's top (a
    /// figure keeps its head, a bottle its neck), or at its foot when the band there is
    /// `BULK_GAIN` times as broad (its slices' mean width, the foot's without its lowest
    /// quarter: a guitar's body below its neck, not a statue's plinth nor a walker's stride).
    /// How far its top lies below the subject's, as a share of the subject's height: 0 or
    /// 1 - 1/crop.
    fn bulk_at(&self, crop: f64) -> f64 {
        let shown = ((SLICES as f64 / crop).round() as usize).clamp(1, SLICES);
        let mean = |slices: &[f64]| slices.iter().sum::<f64>() / slices.len().max(1) as f64;
        let top = mean(&self.widths[..shown]);
        let foot = mean(&self.widths[SLICES - shown..SLICES - shown / 4]);
        if foot > BULK_GAIN * top { (SLICES - shown) as f64 / SLICES as f64 } else { 0.0 }
    }
}

/// Bands of height `Seen::widths` measures a subject's bulk in.
const SLICES: usize = 24;
/// A tall subject's crop leaves its top for its foot when the foot is this many times as broad
/// (`Seen::bulk_at`: a figure's, a bottle's, a statue's on its plinth, a walking figure's 0.6-1.2
/// times; a guitar's or a violin's 1.7 times).
const BULK_GAIN: f64 = 1.3;

/// The spans that hold the points seen from C (`Seen`), step 3 and 4 of the rule.
fn spans_seen(
    seen: &Seen,
    kind: CameraKind,
    f: &CameraFrame,
    aspect: f64,
    margin: f64,
    anisotropy: f64,
    max_half: f64,
) -> Composition {
    let Seen { c, h, v, r, .. } = *seen;
    let widest = 2.0 * max_half / margin;
    let span_x = (2.0 * h.0.abs().max(h.1.abs()) / margin).clamp(1e-6, widest);
    let mut angle_x = span_x;
    if kind == CameraKind::Cylindrical {
        // The band is centred on the scene's vertical middle (the focal line's point there).
        let mut centre = c + f.up * (0.5 * (v.0 + v.1));
        let mut lift = 0.0;
        let mut height = ((v.1 - v.0) / margin).max(1e-6);
        // Scale per pixel: angle_x r / width (r = the scene's mean distance from the focal
        // line) against height / rows, both per image height here.
        let sx = angle_x * r / aspect;
        if sx > anisotropy * height {
            height = sx / anisotropy;
        } else if height > anisotropy * sx {
            // A subject taller than the canvas: framed closer, as a half-length portrait
            // rather than a narrow strip, on its top or its foot (`Seen::bulk_at`).
            let crop = (height / (anisotropy * sx)).powf(TALL_CROP_POWER).min(TALL_CROP_MAX);
            let cropped = height / crop;
            lift = 0.5 * (height - cropped) - seen.bulk_at(crop) * height;
            centre += f.up * lift;
            height = cropped;
            angle_x = ((height / anisotropy) * aspect / r).min(ISO_WIDEST);
        }
        return Composition { centre, angle_x, angle_y: 0.0, height, lift, fill: 0.0, rank: usize::MAX, candidate: 0 };
    }
    let mut angle_y = (2.0 * v.0.abs().max(v.1.abs()) / margin).clamp(1e-6, widest);
    // Radians per pixel: angle_x / width against angle_y / height.
    let sx = angle_x / aspect;
    if sx > anisotropy * angle_y {
        angle_y = sx / anisotropy;
    } else if angle_y > anisotropy * sx {
        angle_x = (angle_y / anisotropy * aspect).min(ISO_WIDEST);
    }
    Composition { centre: c, angle_x, angle_y, height: 0.0, lift: 0.0, fill: 0.0, rank: usize::MAX, candidate: 0 }
}

/// The `compose` framing of a spherical or cylindrical camera looking along `f.forward`, with
/// C on the line through `axis` along the view before centring. `margin` in (0, 1]: the
/// scene's extent over each span. `aspect` = width / height. `fill_of` measures the share of the canvas a
/// candidate shows geometry on (a tiny trace, see `framing::probe_fill`).
#[allow(clippy::too_many_arguments)]
pub fn compose(
    points: &[DVec3],
    kind: CameraKind,
    f: &CameraFrame,
    axis: DVec3,
    aspect: f64,
    radius: f64,
    margin: f64,
    fill_of: &(dyn Fn(&Composition) -> f64 + Sync),
) -> Composition {
    let mut fallback: Option<Composition> = None;
    let mut rank = 0;
    for &cap in &HALF_ANGLE_CAPS {
        let (candidates, fills) = candidates_at(points, kind, f, axis, aspect, radius, margin, cap, fill_of);
        if let Some(k) = fills.iter().position(|&v| v >= FILL_GOAL) {
            return Composition { fill: fills[k], rank: rank + k, candidate: rank + k, ..candidates[k] };
        }
        debug_assert_eq!(fills.len(), candidates.len(), "every fill is measured when none reaches the goal");
        rank += candidates.len();
        // A wider wrap is kept only when it fills clearly more.
        let best = fills.iter().copied().fold(0.0, f64::max);
        if fallback.is_none_or(|b| NEAR_BEST * best > b.fill) {
            let k = fills.iter().position(|&v| v >= NEAR_BEST * best).unwrap_or(0);
            fallback = Some(Composition { fill: fills[k], candidate: rank - candidates.len() + k, ..candidates[k] });
        }
    }
    fallback.unwrap_or(Composition {
        centre: axis,
        angle_x: 1.0,
        angle_y: 1.0,
        height: 1.0,
        lift: 0.0,
        fill: 0.0,
        rank: usize::MAX,
        candidate: 0,
    })
}

/// Candidate `candidate` of `compose` (its `Composition::candidate`) alone, with its fill, as
/// `compose` makes it from these `points` (a view ranked on a coarse sample of the
/// scene is composed again on the full sample without searching every candidate). `rank` is
/// the candidate's place when it reaches `FILL_GOAL`, else `usize::MAX`.
#[allow(clippy::too_many_arguments)]
pub fn compose_candidate(
    points: &[DVec3],
    kind: CameraKind,
    f: &CameraFrame,
    axis: DVec3,
    aspect: f64,
    radius: f64,
    margin: f64,
    candidate: usize,
    fill_of: &(dyn Fn(&Composition) -> f64 + Sync),
) -> Composition {
    let per_cap = ANISOTROPY_STEPS.len() * DEPTH_STEPS.len();
    let candidate = candidate.min(HALF_ANGLE_CAPS.len() * per_cap - 1);
    let cap = HALF_ANGLE_CAPS[candidate / per_cap];
    let (a, d) = ((candidate % per_cap) / DEPTH_STEPS.len(), candidate % DEPTH_STEPS.len());
    let first = fit_depth(points, kind, f, axis, (cap, cap), radius, margin);
    let c = centre_at(points, kind, f, axis, first, radius, margin, cap, DEPTH_STEPS[d]);
    let k = spans_seen(&Seen::new(points, kind, f, c), kind, f, aspect, margin, ANISOTROPY_STEPS[a], cap);
    let fill = fill_of(&k);
    Composition { fill, rank: if fill >= FILL_GOAL { candidate } else { usize::MAX }, candidate, ..k }
}

/// Step 1 and 2 for C `step` scene radii behind its closest place: the focal centre.
/// `first`: `fit_depth` at `axis` itself (the same for every step, so found once).
#[allow(clippy::too_many_arguments)]
fn centre_at(
    points: &[DVec3],
    kind: CameraKind,
    f: &CameraFrame,
    axis: DVec3,
    first: f64,
    radius: f64,
    margin: f64,
    cap: f64,
    step: f64,
) -> DVec3 {
    let cylindrical = kind == CameraKind::Cylindrical;
    let half = (cap, cap);
    let place =
        |axis: DVec3, back: f64| axis + f.forward * (fit_depth(points, kind, f, axis, half, radius, margin) + back);
    let back = step * radius;
    let mut axis = axis;
    let mut c = axis + f.forward * (first + back);
    for _ in 0..CENTRING_PASSES {
        let (h, v) = extents(points, kind, f, c);
        // Typical depth of the scene in front of C: the slide that turns the extent's
        // middle angle onto the axis.
        let depth = points.iter().map(|p| -(*p - c).dot(f.forward)).fold(0.0, f64::max).max(1e-9) * 0.5;
        let dx = depth * (0.5 * (h.0 + h.1)).tan();
        let dy = if cylindrical { 0.0 } else { depth * (0.5 * (v.0 + v.1)).tan() };
        if !(dx.is_finite() && dy.is_finite()) {
            break;
        }
        axis += f.right * dx + f.up * dy;
        c = place(axis, back);
    }
    c
}

/// Every candidate at one angle cap, in order of preference, with the fills of the candidates
/// up to the first that reaches `FILL_GOAL` (all of them when none does):
/// `compose` reads no fill after that one, so the later candidates are not probed (each probe
/// is a trace of a tiny image; they were about 40% of framing's time). Measured a few at a
/// time in order, in parallel, so the fills are the same whatever the thread count.
#[allow(clippy::too_many_arguments)]
fn candidates_at(
    points: &[DVec3],
    kind: CameraKind,
    f: &CameraFrame,
    axis: DVec3,
    aspect: f64,
    radius: f64,
    margin: f64,
    cap: f64,
    fill_of: &(dyn Fn(&Composition) -> f64 + Sync),
) -> (Vec<Composition>, Vec<f64>) {
    let first = fit_depth(points, kind, f, axis, (cap, cap), radius, margin);
    let seen: Vec<Seen> = DEPTH_STEPS
        .par_iter()
        .map(|&step| Seen::new(points, kind, f, centre_at(points, kind, f, axis, first, radius, margin, cap, step)))
        .collect();
    // Candidates in order of preference: least distortion first, then the closest C.
    let candidates: Vec<Composition> = ANISOTROPY_STEPS
        .iter()
        .flat_map(|&a| seen.iter().map(move |s| spans_seen(s, kind, f, aspect, margin, a, cap)))
        .collect();
    let batch = rayon::current_num_threads().clamp(2, 8);
    let mut fills: Vec<f64> = Vec::with_capacity(candidates.len());
    for group in candidates.chunks(batch) {
        fills.par_extend(group.par_iter().map(fill_of));
        if fills.iter().any(|&v| v >= FILL_GOAL) {
            break;
        }
    }
    (candidates, fills)
}

/// Mean horizontal distance of `points` from the vertical line through `c` along `f.up`.
fn mean_distance_from_line(points: &[DVec3], f: &CameraFrame, c: DVec3) -> f64 {
    if points.is_empty() {
        return 0.0;
    }
    let sum: f64 = points
        .iter()
        .map(|p| {
            let w = *p - c;
            (w - f.up * w.dot(f.up)).length()
        })
        .sum();
    sum / points.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame() -> CameraFrame {
        CameraFrame::new(DVec3::new(0.0, 0.0, 5.0), DVec3::NEG_Z, DVec3::Y).unwrap().0
    }

    /// Points on an ellipsoid of the given radii around `c`.
    fn ellipsoid(r: DVec3, c: DVec3) -> Vec<DVec3> {
        let mut v = Vec::new();
        for i in 0..=12 {
            for j in 0..24 {
                let (t, p) = (std::f64::consts::PI * i as f64 / 12.0, std::f64::consts::TAU * j as f64 / 24.0);
                v.push(c + DVec3::new(t.sin() * p.cos(), t.cos(), t.sin() * p.sin()) * r);
            }
        }
        v
    }

    /// Every point lies in front of C and within the composition's spans.
    fn in_view(k: &Composition, kind: CameraKind, pts: &[DVec3]) -> bool {
        let f = frame();
        let (h, v) = extents(pts, kind, &f, k.centre);
        let depth_ok = pts.iter().all(|p| (*p - k.centre).dot(f.forward) < 0.0);
        let hx = h.0.abs().max(h.1.abs()) <= k.angle_x / 2.0 + 1e-9;
        let vy = match kind {
            CameraKind::Cylindrical => v.0 >= -k.height / 2.0 - 1e-9 && v.1 <= k.height / 2.0 + 1e-9,
            _ => v.0.abs().max(v.1.abs()) <= k.angle_y / 2.0 + 1e-9,
        };
        depth_ok && hx && vy
    }

    /// `extents` as it was: every point's angles.
    fn extents_every_point(points: &[DVec3], kind: CameraKind, f: &CameraFrame, c: DVec3) -> ((f64, f64), (f64, f64)) {
        let mut h = (f64::INFINITY, f64::NEG_INFINITY);
        let mut v = (f64::INFINITY, f64::NEG_INFINITY);
        for p in points {
            let w = *p - c;
            let (x, y, z) = (w.dot(f.right), w.dot(f.up), -w.dot(f.forward));
            let (a, b) = match kind {
                CameraKind::Cylindrical => (x.atan2(z), y),
                _ => ((x / w.length().max(1e-300)).clamp(-1.0, 1.0).asin(), y.atan2(z)),
            };
            h = (h.0.min(a), h.1.max(a));
            v = (v.0.min(b), v.1.max(b));
        }
        if !h.0.is_finite() {
            return ((0.0, 0.0), (0.0, 0.0));
        }
        (h, v)
    }

    /// perf9: the extents from the points near the keys' extremes are those of every point,
    /// bit for bit: random clouds in front of C, around it, behind it, nearly beside it (slopes
    /// past the cap) and with near-ties at the extremes, for both camera kinds.
    #[test]
    fn extents_match_every_points_angles() {
        let f = frame();
        let mut state = 5u64;
        let mut next = || {
            state = crate::util::rng::splitmix64(state);
            crate::util::rng::unit_f64(state) * 2.0 - 1.0
        };
        let bits = |e: ((f64, f64), (f64, f64))| [e.0.0, e.0.1, e.1.0, e.1.1].map(f64::to_bits);
        for case in 0..60 {
            let c = DVec3::new(0.1, -0.2, [-3.0, 0.0, -0.9, 1.0, -1.5][case % 5]);
            let n = [0, 1, 7, 300, 2000][case % 5];
            let mut pts: Vec<DVec3> = (0..n).map(|_| DVec3::new(next(), next(), next())).collect();
            if case % 3 == 0 {
                // Near-ties: copies of points nudged by a few units in the last place; and
                // points almost beside C (z tiny either side: slopes far past the cap).
                let mut extra = Vec::new();
                for (j, p) in pts.iter().take(20).enumerate() {
                    for k in 1..=3 {
                        extra.push(DVec3::new(f64::from_bits(p.x.to_bits() + k), p.y, p.z));
                        extra.push(DVec3::new(p.x, f64::from_bits(p.y.to_bits() + k), p.z));
                    }
                    let side = if j % 2 == 0 { 1e-9 } else { -1e-9 };
                    extra.push(DVec3::new(p.x, p.y, c.z + side * (j + 1) as f64));
                }
                pts.extend(extra);
            }
            for kind in [CameraKind::Spherical, CameraKind::Cylindrical] {
                assert_eq!(
                    bits(extents(&pts, kind, &f, c)),
                    bits(extents_every_point(&pts, kind, &f, c)),
                    "case {case}, {kind:?}"
                );
            }
        }
    }

    #[test]
    fn the_whole_scene_is_in_view_and_centred() {
        // An off-centre ellipsoid: the centring passes bring its extent onto the axis.
        let pts = ellipsoid(DVec3::new(0.6, 0.4, 0.5), DVec3::new(0.3, -0.2, 0.0));
        let k = compose(&pts, CameraKind::Spherical, &frame(), DVec3::ZERO, 4.0 / 3.0, 1.0, 0.94, &|_| 0.6);
        assert!(in_view(&k, CameraKind::Spherical, &pts), "{k:?}");
        let (h, v) = extents(&pts, CameraKind::Spherical, &frame(), k.centre);
        assert!((h.0 + h.1).abs() < 0.1 * (h.1 - h.0), "horizontal extent {h:?} not centred");
        assert!((v.0 + v.1).abs() < 0.1 * (v.1 - v.0), "vertical extent {v:?} not centred");
        assert!(k.angle_x <= 2.0 * MAX_HALF_ANGLE / 0.94 + 1e-9 && k.angle_y <= 2.0 * MAX_HALF_ANGLE / 0.94 + 1e-9);
        // Within the stretch bound picked (the first, isotropic, with this fill).
        let stretch = (k.angle_x / (4.0 / 3.0)) / k.angle_y;
        assert!((0.99..=1.01).contains(&stretch) || k.angle_x >= 2.0 * MAX_HALF_ANGLE / 0.94 - 1e-9, "{stretch}");
    }

    #[test]
    fn both_axes_keep_the_same_scale_per_pixel() {
        // A tall thin subject: the horizontal span is widened to the vertical one's scale, so
        // the subject keeps its proportions with canvas beside it.
        let pts = ellipsoid(DVec3::new(0.2, 1.0, 0.2), DVec3::ZERO);
        let f = frame();
        for fill in [&(|_: &Composition| 0.6) as &(dyn Fn(&Composition) -> f64 + Sync), &|_| 0.2] {
            let k = compose(&pts, CameraKind::Spherical, &f, DVec3::ZERO, 4.0 / 3.0, 1.0, 0.94, fill);
            let stretch = (k.angle_x / (4.0 / 3.0)) / k.angle_y;
            assert!((0.99..=1.01).contains(&stretch) || k.angle_x >= ISO_WIDEST - 1e-9, "{stretch} {k:?}");
            assert!(in_view(&k, CameraKind::Spherical, &pts));
        }
    }

    #[test]
    fn the_focal_centre_stays_behind_within_the_cap() {
        // Every vertex within the cap (over the margin) of the view axis seen from C: no
        // vertex near C, whose reverse perspective would swell it.
        let pts = ellipsoid(DVec3::new(0.6, 0.4, 0.5), DVec3::ZERO);
        let f = frame();
        let k = compose(&pts, CameraKind::Spherical, &f, DVec3::ZERO, 4.0 / 3.0, 1.0, 0.94, &|_| 0.6);
        assert_eq!(k.rank, 0);
        let ((h0, h1), (v0, v1)) = extents(&pts, CameraKind::Spherical, &f, k.centre);
        let most = h0.abs().max(h1.abs()).max(v0.abs()).max(v1.abs());
        assert!(most <= MAX_HALF_ANGLE + 1e-9, "{most} {k:?}");
        assert!(in_view(&k, CameraKind::Spherical, &pts));
    }

    #[test]
    fn better_compositions_fill_with_less_stretch_or_fill_more() {
        let k = |fill: f64, rank: usize| Composition {
            centre: DVec3::ZERO,
            angle_x: 1.0,
            angle_y: 1.0,
            height: 0.0,
            lift: 0.0,
            fill,
            rank,
            candidate: 0,
        };
        assert!(k(0.5, 3).better_than(&k(0.9, 7)));
        assert!(k(0.5, 3).better_than(&k(0.45, usize::MAX)));
        assert!(!k(0.5, 3).better_than(&k(0.5, 3)), "ties keep the other");
        assert!(k(0.45, usize::MAX).better_than(&k(0.4, usize::MAX)));
        assert!(!k(0.4, usize::MAX).better_than(&k(0.45, usize::MAX)));
    }

    /// `compose_candidate` makes again exactly the candidate `compose` chose, for both camera
    /// kinds, a candidate that reaches the goal, one of the wider wrap, and a fallback.
    #[test]
    fn one_candidate_is_made_as_the_search_makes_it() {
        let pts = ellipsoid(DVec3::new(0.3, 1.0, 0.25), DVec3::new(0.1, 0.2, 0.0));
        let f = frame();
        let fills: [&(dyn Fn(&Composition) -> f64 + Sync); 3] = [
            &|k: &Composition| 0.2 + 0.4 * (k.angle_y / k.angle_x).min(1.0) * (k.angle_x / 3.0).min(1.0),
            &|_: &Composition| 0.6,
            // None reaches the goal, the farthest C fills most: a fallback further back.
            &|k: &Composition| (0.1 + 0.08 * (-k.centre.z).max(0.0)).min(0.45),
        ];
        let mut seen = std::collections::HashSet::new();
        for kind in [CameraKind::Spherical, CameraKind::Cylindrical] {
            for fill in fills {
                let k = compose(&pts, kind, &f, DVec3::ZERO, 4.0 / 3.0, 1.0, 0.94, fill);
                let one = compose_candidate(&pts, kind, &f, DVec3::ZERO, 4.0 / 3.0, 1.0, 0.94, k.candidate, fill);
                assert_eq!(one, k, "{kind:?}");
                seen.insert(k.candidate);
            }
        }
        assert!(seen.len() >= 2, "the cases pick different candidates: {seen:?}");
    }

    #[test]
    fn cylinders_fit_the_height() {
        let pts = ellipsoid(DVec3::new(2.0, 1.0, 0.3), DVec3::new(0.0, 2.0, 0.0));
        let f = frame();
        let k = compose(&pts, CameraKind::Cylindrical, &f, DVec3::ZERO, 4.0 / 3.0, 2.0, 0.9, &|_| 0.6);
        assert!(in_view(&k, CameraKind::Cylindrical, &pts), "{k:?}");
        assert!(k.height >= 2.0 / 0.9 - 1e-6, "{}", k.height);
        assert!((k.centre.y - 2.0).abs() < 1e-6 && k.lift == 0.0);
    }

    /// The band's bottom and top, in height along the focal line.
    fn band(k: &Composition) -> (f64, f64) {
        (k.centre.y - 0.5 * k.height, k.centre.y + 0.5 * k.height)
    }

    /// A subject much taller than the canvas is framed closer, its foot cropped: the band
    /// holds its top with the margin, `TALL_CROP_MAX` of its height less, in proportion.
    #[test]
    fn a_tall_subject_keeps_its_top_and_loses_its_foot() {
        let pts = ellipsoid(DVec3::new(0.3, 1.5, 0.3), DVec3::new(0.0, 2.0, 0.0));
        let f = frame();
        let k = compose(&pts, CameraKind::Cylindrical, &f, DVec3::ZERO, 4.0 / 3.0, 2.0, 0.9, &|_| 0.6);
        assert!((k.height - 3.0 / 0.9 / TALL_CROP_MAX).abs() < 1e-6, "{k:?}");
        let (lo, hi) = band(&k);
        assert!((3.5..=2.0 + 1.5 / 0.9 + 1e-6).contains(&hi) && lo > 1.0, "{lo} {hi}");
        assert!(k.lift > 0.0);
        // Both axes at one scale per pixel still: the width spans what the height does.
        let r = mean_distance_from_line(&pts, &f, k.centre);
        assert!((k.angle_x * r / (4.0 / 3.0) - k.height).abs() < 1e-6 * k.height);
    }

    /// A tall subject whose bulk lies low (a guitar's body under its neck) is framed on it.
    #[test]
    fn a_tall_subject_is_framed_on_its_bulk_when_that_lies_low() {
        let neck = (0..=40).flat_map(|i| {
            let y = 1.0 + 2.0 * i as f64 / 40.0;
            [DVec3::new(-0.05, y, 0.0), DVec3::new(0.05, y, 0.0)]
        });
        let mut pts: Vec<DVec3> = ellipsoid(DVec3::new(0.45, 0.5, 0.15), DVec3::new(0.0, 0.5, 0.0));
        pts.extend(neck);
        let f = frame();
        let k = compose(&pts, CameraKind::Cylindrical, &f, DVec3::ZERO, 4.0 / 3.0, 2.0, 0.9, &|_| 0.6);
        let (lo, hi) = band(&k);
        assert!(k.lift < 0.0 && lo <= 0.0 && hi < 3.0, "{lo} {hi} {k:?}");
    }

    /// A statue on a plinth four times its width, and a figure striding (its feet far apart),
    /// keep their tops: the foot's lowest quarter is not read as its bulk.
    #[test]
    fn a_plinth_or_a_stride_is_not_the_bulk() {
        let f = frame();
        let column = |x: f64| (0..=60).map(move |i| DVec3::new(x, 0.3 + 2.7 * i as f64 / 60.0, 0.0));
        let mut statue: Vec<DVec3> = column(-0.1).chain(column(0.1)).collect();
        statue.extend(ellipsoid(DVec3::new(0.4, 0.15, 0.4), DVec3::new(0.0, 0.15, 0.0)));
        let mut stride: Vec<DVec3> = column(-0.25).chain(column(0.25)).filter(|p| p.y > 1.2).collect();
        stride.extend((0..=30).flat_map(|i| {
            let t = i as f64 / 30.0;
            [DVec3::new(-0.1 - 0.35 * (1.0 - t), 1.2 * t, 0.0), DVec3::new(0.1 + 0.35 * (1.0 - t), 1.2 * t, 0.0)]
        }));
        for (name, pts) in [("statue", statue), ("stride", stride)] {
            let k = compose(&pts, CameraKind::Cylindrical, &f, DVec3::ZERO, 4.0 / 3.0, 2.0, 0.9, &|_| 0.6);
            let (lo, hi) = band(&k);
            assert!(k.lift > 0.0 && hi >= 3.0 && lo > 0.0, "{name}: {lo} {hi} {k:?}");
        }
    }
}
