//! Tiny traces of a candidate camera: the share of the canvas its subject fills.

use glam::DVec3;

use crate::accel::Accel;
use crate::camera::{Camera, CameraRay, screen_point};

/// Columns of `probe_fill`'s tiny image (rows follow the aspect).
pub(super) const PROBE_COLUMNS: u32 = 48;
/// Columns of the probe when ranking views on the coarse sample.
pub(super) const COARSE_PROBE_COLUMNS: u32 = 24;

/// The part of the subject nearest the focal centre a converging camera magnifies most (scale
/// about 1 / distance from C, or from the focal line): with C right behind a small part (an arm
/// behind the body, the nearest of several objects), the fullest candidate is that part blown up
/// over the canvas and the rest shrunk beside it, a "magnified ghost" that no longer reads
/// (cues stay legible). A guarded probe refuses such a candidate: when more than
/// `NEAR_C_SHARE` of the pixels showing geometry show a point within `within` of C (of the focal
/// line: `line`, its direction), it counts as filling nothing.
pub(super) struct NearGuard {
    pub(super) centre: DVec3,
    pub(super) line: Option<DVec3>,
    pub(super) within: f64,
}

/// `NearGuard`'s distance from C, in scene radii: a part this close is magnified at least 4x
/// against a subject about one radius away.
pub(super) const NEAR_C_RADII: f64 = 0.25;
/// `NearGuard`'s share of the subject's pixels the magnified part may take.
const NEAR_C_SHARE: f64 = 0.5;

/// The size of a probe image `columns` wide with this aspect (width / height).
fn probe_size(aspect: f64, columns: u32) -> (u32, u32) {
    (columns, ((columns as f64 / aspect).round() as u32).clamp(8, 4 * columns))
}

/// `per_pixel` of every pixel of a tiny `w x h` image (one ray per pixel centre, row 0 on
/// top) and what its ray hits first, in pixel order; deterministic on any thread count.
fn probe<T: Send>(
    camera: &dyn Camera,
    accel: &Accel,
    (w, h): (u32, u32),
    per_pixel: impl Fn(&CameraRay, Option<crate::accel::Hit>) -> T + Sync,
) -> Vec<T> {
    use rayon::prelude::*;
    // The pixel centres' rays, tabulated where the camera can (`ray` bit for bit).
    let rays = camera.centre_rays(w, h);
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let r = rays(i as usize, screen_point(x, y, glam::DVec2::splat(0.5), w, h));
            per_pixel(&r, accel.closest(r.origin, r.dir, 0.0, f32::INFINITY))
        })
        .collect()
}

/// A `columns`-wide probe of `camera` at the canvas's `aspect`: 1 where a pixel centre's ray
/// first hits the subject of `world` (not its setting: a floor filling the canvas is not the
/// subject's extent), else 0, with its width and height (the look report's stretch measure).
pub fn probe_subject(
    camera: &dyn Camera,
    accel: &Accel,
    world: &crate::scene::World,
    aspect: f64,
    columns: u32,
) -> (Vec<f64>, u32, u32) {
    let (w, h) = probe_size(aspect, columns);
    let subject = |hit: Option<crate::accel::Hit>| hit.is_some_and(|h| !world.is_setting(h.object as usize));
    (probe(camera, accel, (w, h), |_, hit| if subject(hit) { 1.0 } else { 0.0 }), w, h)
}

/// The share of a tiny image (`columns` wide, one ray per pixel centre) whose rays hit
/// geometry: `compose`'s estimate of a candidate's subject fill. Deterministic (a hit count).
/// With `guard`, 0 when the guard refuses the candidate.
pub(super) fn probe_fill(
    camera: &dyn Camera,
    accel: &Accel,
    aspect: f64,
    columns: u32,
    guard: Option<&NearGuard>,
) -> f64 {
    let (w, h) = probe_size(aspect, columns);
    let pixels = probe(camera, accel, (w, h), |r, hit| {
        let Some(hit) = hit else { return (0u32, 0u32) };
        let near = guard.is_some_and(|g| {
            let d = (r.origin + r.dir * hit.t).as_dvec3() - g.centre;
            let d = match g.line {
                Some(u) => d - u * d.dot(u),
                None => d,
            };
            d.length() < g.within
        });
        (1, near as u32)
    });
    let (hits, near) = pixels.iter().fold((0u32, 0u32), |a, b| (a.0 + b.0, a.1 + b.1));
    if hits > 0 && near as f64 > NEAR_C_SHARE * hits as f64 {
        return 0.0;
    }
    hits as f64 / (w * h) as f64
}
