//! Facets that move with the scene (`--facet-motion follow`), the thesis's future work ("a
//! cubist animation system which takes the time dimension into account and animates facets").
//!
//! A facet layout is made at a key frame (the layout frame). Every surface point keeps, in
//! every later frame, the facet it had there: the point a pixel of frame N shows (its triangle
//! and barycentrics, from frame N's pre-pass) is put back where it was at the key frame (the
//! same triangle of the key frame's geometry, at the same barycentrics), projected through
//! the key frame's camera (`Camera::project`, the exact inverse of its rays), and takes the
//! facet of the key picture there. The motion is the scene's own (its animation, the camera's
//! orbit), not an estimate from the pictures (optical flow), and frame N needs only the key
//! frame, never frames between: a render farm's chunks agree.
//!
//! A point may have had no facet at the key frame: it was hidden there (behind another
//! surface, or turned away) or out of the picture. Such pixels take the facet of the nearest
//! pixel that has one (Euclidean, so facets grow over what the motion reveals).
//! Background pixels (no surface) keep the key frame's background facets, grown over what its
//! surfaces covered from the background's own (`background_facets`): the backdrop does not
//! move, and its facets do not change as the surfaces move in front of it. `Carried::revealed` says how much
//! of the picture had to be filled so: when it grows, the view has changed too much for one
//! key frame, and a new one is made (`pipeline::frames`).

pub mod file;

use glam::{DVec2, Vec2, Vec3};

use super::FacetMap;
use crate::camera::Camera;
use crate::distance::nearest_features;
use crate::film::{Film, NO_HIT};

/// How facets move over the frames of an animation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FacetMotion {
    /// Fixed on the image, as the thesis animates (SPEC "Animation").
    Static,
    /// Carried with the surfaces they show.
    Follow,
}

/// Depth agreement, render units (the scene's radius is 1), under which a point counts as the
/// surface the key frame saw at its pixel: 0.5% of the scene, looser than the depth change
/// across a pixel of any but grazing surfaces, tighter than the gap to the surface behind.
pub const DEPTH_TOLERANCE: f32 = 5e-3;

/// What carrying needs of the key frame: its picture's facets and, per pixel of it, the
/// triangle and depth (from the camera surface) its centre ray hit, its geometry and camera.
pub struct Key<'a> {
    pub map: &'a FacetMap,
    /// World triangle id of each pixel's centre ray, `NO_HIT` on the background.
    pub tri: &'a [u32],
    /// Distance along each pixel's centre ray from the camera surface (infinite on background).
    pub depth: &'a [f32],
    /// Triangle corners at the key frame, render space (`World::positions`).
    pub positions: &'a [[Vec3; 3]],
    pub camera: &'a dyn Camera,
}

/// A frame's facets carried from a key frame.
pub struct Carried {
    pub map: FacetMap,
    /// Fraction of the frame's surface pixels whose point the key frame did not see (hidden,
    /// turned away or out of its picture): their facets were grown from their neighbours'.
    pub revealed: f64,
    /// Per facet id: the mean move (pixels, x right, y down) of its pixels from the key frame
    /// to this one, over the pixels whose point the key frame saw; zero for the background's
    /// facets (`background_facets`), which stay where they are.
    pub shift: Vec<Vec2>,
    /// Per pixel: where its surface point was on the key frame's picture (pixels, x right, y
    /// down; NaN where the key frame did not see it, and on the background), so what is laid
    /// on a plane can be read where the point was and move with the surface
    /// (`paint::Sequence::at_key`).
    pub at_key: Vec<Vec2>,
    /// Per pixel, the still ground's facet there (`background_facets`), under the subject too.
    pub ground: Vec<u32>,
}

/// Per-pixel triangle and depth from the camera surface, read off a pre-pass film (one sample
/// per pixel: the pixel's hit is its centre ray's).
pub fn key_buffers(film: &Film, skipped: impl Fn(usize) -> f32) -> (Vec<u32>, Vec<f32>) {
    film.hits
        .iter()
        .enumerate()
        .map(|(i, h)| if h.is_hit() { (h.tri, h.t + skipped(i)) } else { (NO_HIT, f32::INFINITY) })
        .unzip()
}

/// The key frame's pixel a point of the key geometry falls on, if the key frame saw it there,
/// and where on the key picture it falls (pixels, x right, y down).
fn seen_at_key(key: &Key, tri: u32, u: f32, v: f32) -> Option<(usize, DVec2)> {
    let corners = key.positions.get(tri as usize)?;
    let p = corners[0] * (1.0 - u - v) + corners[1] * u + corners[2] * v;
    let seen = key.camera.project(p.as_dvec3())?;
    if !seen.in_view() {
        return None;
    }
    let (w, h) = (key.map.width as usize, key.map.height as usize);
    let px = DVec2::new((seen.screen.x + 0.5) * w as f64, (0.5 - seen.screen.y) * h as f64);
    let (x, y) = ((px.x.floor() as usize).min(w - 1), (px.y.floor() as usize).min(h - 1));
    let i = y * w + x;
    if key.tri[i] == tri {
        return Some((i, px));
    }
    // A neighbouring triangle, or the pixel's centre ray landing elsewhere on the same surface:
    // the same surface if some pixel around agrees in depth.
    let depth = seen.depth as f32;
    let near = (y.saturating_sub(1)..=(y + 1).min(h - 1))
        .flat_map(|yy| (x.saturating_sub(1)..=(x + 1).min(w - 1)).map(move |xx| yy * w + xx))
        .any(|j| key.tri[j] == tri || (key.depth[j] - depth).abs() <= DEPTH_TOLERANCE);
    near.then_some((i, px))
}

/// Frame N's facets from the key frame: `hits` are frame N's pixel hits (triangle ids of the
/// same geometry as the key's, posed at frame N), at the key map's size.
pub fn carry(key: &Key, film: &Film) -> Carried {
    let (w, h) = (key.map.width, key.map.height);
    debug_assert_eq!((film.width, film.height), (w, h));
    const UNSET: u32 = u32::MAX;
    let n = film.hits.len();
    let mut ids = vec![UNSET; n];
    let (mut surface, mut revealed) = (0usize, 0usize);
    let background = background_facets(key);
    let facets = key.map.facet_count as usize;
    let mut moves = vec![(DVec2::ZERO, 0u64); facets];
    let mut at_key = vec![Vec2::NAN; n];
    let at = |i: usize| DVec2::new((i % w as usize) as f64, (i / w as usize) as f64);
    for (i, hit) in film.hits.iter().enumerate() {
        if hit.is_hit() {
            surface += 1;
            match seen_at_key(key, hit.tri, hit.u, hit.v) {
                Some((k, p)) => {
                    let id = key.map.ids[k];
                    ids[i] = id;
                    at_key[i] = p.as_vec2();
                    if let Some(m) = moves.get_mut(id as usize) {
                        m.0 += at(i) - at(k);
                        m.1 += 1;
                    }
                }
                None => revealed += 1,
            }
        } else {
            ids[i] = background[i];
        }
    }
    grow(&mut ids, w, h, key.map.ids[0]);
    for &id in &background {
        if let Some(m) = moves.get_mut(id as usize) {
            *m = (DVec2::ZERO, 0);
        }
    }
    let shift = moves.iter().map(|&(sum, n)| if n > 0 { (sum / n as f64).as_vec2() } else { Vec2::ZERO }).collect();
    Carried {
        map: FacetMap { width: w, height: h, ids, facet_count: key.map.facet_count },
        revealed: if surface == 0 { 0.0 } else { revealed as f64 / surface as f64 },
        shift,
        at_key,
        ground: background,
    }
}

/// The background's facets of every pixel: the key frame's where it showed background, grown
/// over what its surfaces covered from the background's alone. A frame's background pixels
/// take these, whatever the surfaces do in front of them: a still background keeps its facets
/// from frame to frame (grown from the surfaces' facets, as other unseen pixels are, they
/// would change with every move of the surfaces nearby).
fn background_facets(key: &Key) -> Vec<u32> {
    const UNSET: u32 = u32::MAX;
    let mut ids: Vec<u32> =
        key.tri.iter().zip(&key.map.ids).map(|(&t, &id)| if t == NO_HIT { id } else { UNSET }).collect();
    grow(&mut ids, key.map.width, key.map.height, key.map.ids[0]);
    ids
}

/// Per facet id: whether it is one of the background's facets of `key`
/// (`background_facets`: its background, grown over what its surfaces covered). A key frame
/// carried from this one gives its background pixels these facets, so every later key
/// frame's background facets are among them.
pub fn still_facets(key: &Key) -> Vec<bool> {
    let mut still = vec![false; key.map.facet_count as usize];
    for id in background_facets(key) {
        if let Some(s) = still.get_mut(id as usize) {
            *s = true;
        }
    }
    still
}

/// Gives every unset pixel the facet of the nearest set one, in Euclidean distance between
/// pixel centres (`distance::nearest_features`: ties go the same way on any thread count), so
/// a grown region splits between its neighbours along straight bisectors, not the steps and
/// boxes of a breadth-first growth over 4-neighbours; all unset: `fallback`.
fn grow(ids: &mut [u32], width: u32, height: u32, fallback: u32) {
    const UNSET: u32 = u32::MAX;
    if ids.iter().all(|&id| id == UNSET) {
        ids.fill(fallback);
        return;
    }
    if !ids.contains(&UNSET) {
        return;
    }
    let (_, nearest) = nearest_features(width, height, f32::INFINITY, |i| ids[i] != UNSET);
    let grown: Vec<u32> = nearest.iter().map(|&j| ids.get(j as usize).copied().unwrap_or(fallback)).collect();
    ids.copy_from_slice(&grown);
}

/// What a frame's picture shows, for measuring coherence between frames: its key data (per
/// pixel triangle and depth, the frame's geometry and camera) and each pixel's barycentrics.
pub struct FrameSurface {
    pub key: file::KeyData,
    /// Barycentrics (u, v) of each pixel's centre-ray hit (meaningless where `key.tri` is `NO_HIT`).
    pub uv: Vec<(f32, f32)>,
}

impl FrameSurface {
    /// From a pre-pass film and its key data.
    pub fn new(key: file::KeyData, film: &Film) -> FrameSurface {
        FrameSurface { key, uv: film.hits.iter().map(|h| (h.u, h.v)).collect() }
    }
}

/// How coherent two consecutive frames are, over the surface points both show.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coherence {
    /// Surface points seen in both frames (pixels of the later frame whose point the earlier
    /// frame saw).
    pub points: usize,
    /// Share of those points whose facet id is the same in both frames.
    pub stickiness: f64,
    /// Mean absolute colour change of those points, RGB in [0, 1] averaged over channels.
    pub flicker: f64,
}

/// Stickiness and flicker from frame `a` to frame `b`: each pixel of `b`
/// showing a surface point is matched, through the scene's exact motion, to the pixel of `a`
/// showing the same point (as facets follow: `a`'s geometry and camera, `Camera::project`).
/// `image_*` are RGBA8 pictures at the frames' size.
pub fn coherence(
    a: &FrameSurface,
    map_a: &FacetMap,
    image_a: &[u8],
    b: &FrameSurface,
    map_b: &FacetMap,
    image_b: &[u8],
) -> Coherence {
    let key = a.key.key(map_a);
    let (mut points, mut same, mut change) = (0usize, 0usize, 0.0f64);
    for (i, &tri) in b.key.tri.iter().enumerate() {
        if tri == NO_HIT {
            continue;
        }
        let (u, v) = b.uv[i];
        let Some((k, _)) = seen_at_key(&key, tri, u, v) else { continue };
        points += 1;
        same += (map_a.ids[k] == map_b.ids[i]) as usize;
        change +=
            (0..3).map(|c| (image_a[4 * k + c] as f64 - image_b[4 * i + c] as f64).abs()).sum::<f64>() / (3.0 * 255.0);
    }
    let n = points.max(1) as f64;
    Coherence { points, stickiness: same as f64 / n, flicker: change / n }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every grown pixel takes a facet of a set pixel at the least Euclidean distance (brute
    /// force), set pixels keep theirs, and nothing stays unset.
    #[test]
    fn grown_pixels_take_the_facet_of_the_nearest_set_pixel() {
        const UNSET: u32 = u32::MAX;
        let (w, h) = (23usize, 17usize);
        // A few seeds of four facets, placed where a 4-neighbour growth and the nearest
        // differ (breadth-first counts steps: a diagonal neighbour is two away).
        let seeds = [(1usize, 1usize, 0u32), (20, 3, 1), (6, 15, 2), (14, 9, 3), (15, 9, 3), (2, 12, 1)];
        let mut ids = vec![UNSET; w * h];
        for &(x, y, id) in &seeds {
            ids[y * w + x] = id;
        }
        let before = ids.clone();
        grow(&mut ids, w as u32, h as u32, 7);
        for i in 0..w * h {
            if before[i] != UNSET {
                assert_eq!(ids[i], before[i]);
                continue;
            }
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            let d2 = |&(sx, sy, _): &(usize, usize, u32)| (sx as i64 - x).pow(2) + (sy as i64 - y).pow(2);
            let best = seeds.iter().map(d2).min().unwrap();
            assert!(
                seeds.iter().any(|s| d2(s) == best && s.2 == ids[i]),
                "pixel ({x}, {y}) took facet {} not among the nearest seeds'",
                ids[i]
            );
        }
        let mut none = vec![UNSET; 6];
        grow(&mut none, 3, 2, 7);
        assert_eq!(none, vec![7; 6]);
    }
}
