//! Facets that move with the scene (`--facet-motion follow`), the thesis's future work ("a
//! cubist animation system which takes the time dimension into account and animates facets").
//!
//! A facet layout is made at a key frame (the layout frame). Every surface point keeps, in
//! every later frame, the facet it had there: the point a pixel of frame N shows (its triangle
//! and barycentrics, from frame N's pre-pass) is put back where it was at the key frame (the
//! same triangle of the key frame's geometry, at the same barycentrics), projected through the
//! key frame's camera (`Camera::project`, the exact inverse of its rays), and takes the facet
//! of the key picture there, its edges read as straight lines rather than as the steps of its
//! pixels (`util::edge_line`), so an edge moves with its surface by less than a pixel too. The
//! motion is the scene's own (its animation, the camera's orbit), not an estimate from the
//! pictures (optical flow), and frame N needs only the key frame, never frames between: a
//! render farm's chunks agree.
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
use crate::util::edge_line;
use crate::util::grid::Grid;

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
    let window = edge_line::Window::new();
    for (i, hit) in film.hits.iter().enumerate() {
        if hit.is_hit() {
            surface += 1;
            match seen_at_key(key, hit.tri, hit.u, hit.v) {
                Some((k, p)) => {
                    let id = across_edge(key.map, key.tri, k, p, &window).unwrap_or(key.map.ids[k]);
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

/// The facet across the key map's edge from key pixel `k` when the point at `p` (key picture
/// pixels) lies beyond the smoothed line of `k`'s facet there: the key map's edges read as
/// straight lines, not as the steps of its pixels, so an edge carried by less than a pixel
/// moves with its surface. None: `k`'s own facet; also where there is no clear edge line (a
/// corner), where `k`'s own centre lies beyond the line (a corner's or a bump's pixel: the key
/// frame's own map is kept), and where the pixel across shows no surface (a subject point
/// never takes a facet of the ground alone).
/// `tri`: the key frame's triangle per pixel (`Key::tri`).
fn across_edge(map: &FacetMap, tri: &[u32], k: usize, p: DVec2, window: &edge_line::Window) -> Option<u32> {
    let (w, h) = (map.width as usize, map.height as usize);
    let own = map.ids[k];
    if !Grid::new(map.width, map.height).on_border(&map.ids, k) {
        return None;
    }
    let line = window.line(w, h, k, |j| map.ids[j] == own)?;
    // The estimate reads `grid_offset` at a centre half a pixel from an edge along the grid.
    let bias = window.grid_offset - 0.5;
    let (kx, ky) = ((k % w) as f64 + 0.5, (k / w) as f64 + 0.5);
    let s = line.at((p.x - kx) as f32, (p.y - ky) as f32) - bias;
    if line.offset - bias < 0.0 || !(s < 0.0) {
        return None;
    }
    // The pixel across the line from k.
    let (x, y) = ((kx - line.normal.x as f64).floor(), (ky - line.normal.y as f64).floor());
    if x < 0.0 || y < 0.0 || x >= w as f64 || y >= h as f64 {
        return None;
    }
    let j = y as usize * w + x as usize;
    (map.ids[j] != own && tri[j] != NO_HIT).then_some(map.ids[j])
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

    /// A key map split by a slanted line: a point takes the facet of the side of the line it
    /// lies on, within a fifth of a pixel, wherever the map's pixel steps put it; pixels off
    /// the edge keep their facet.
    #[test]
    fn a_key_maps_edge_is_read_as_its_straight_line() {
        let (w, h) = (64u32, 48u32);
        let (slope, at) = (0.35f64, 12.0f64);
        let side = |x: f64, y: f64| y > slope * x + at;
        let ids = (0..w * h).map(|i| side((i % w) as f64 + 0.5, (i / w) as f64 + 0.5) as u32).collect();
        let map = FacetMap { width: w, height: h, ids, facet_count: 2 };
        let tri = vec![0u32; (w * h) as usize];
        let window = edge_line::Window::new();
        let norm = (1.0 + slope * slope).sqrt();
        let (mut checked, mut flipped) = (0, 0);
        for k in 0..(w * h) as usize {
            let (kx, ky) = ((k % w as usize) as f64, (k / w as usize) as f64);
            if kx < 8.0 || kx > w as f64 - 8.0 {
                continue;
            }
            for (fx, fy) in [(0.1, 0.1), (0.5, 0.5), (0.9, 0.2), (0.3, 0.9), (0.7, 0.6)] {
                let p = DVec2::new(kx + fx, ky + fy);
                let id = across_edge(&map, &tri, k, p, &window).unwrap_or(map.ids[k]);
                let truth = (p.y - slope * p.x - at) / norm;
                if truth.abs() > 0.2 && (truth.abs() < 2.0) {
                    assert_eq!(id == 1, truth > 0.0, "point {p:?} ({truth} from the line)");
                    checked += 1;
                }
                flipped += (id != map.ids[k]) as usize;
            }
        }
        assert!(checked > 200 && flipped > 20, "{checked} points checked, {flipped} took the facet across");
        // Across onto pixels that show no surface: never.
        let ground: Vec<u32> = map.ids.iter().map(|&id| if id == 1 { NO_HIT } else { 0 }).collect();
        for k in (0..(w * h) as usize).filter(|&k| map.ids[k] == 0) {
            for (fx, fy) in [(0.1, 0.1), (0.9, 0.9), (0.1, 0.9), (0.9, 0.1)] {
                let p = DVec2::new((k % w as usize) as f64 + fx, (k / w as usize) as f64 + fy);
                assert_eq!(across_edge(&map, &ground, k, p, &window), None);
            }
        }
    }

    /// Points at the key pixels' own centres keep their pixels' facets, corners and one-pixel
    /// bumps too: the key frame carried onto itself is its own map.
    #[test]
    fn the_key_frame_carried_onto_itself_keeps_its_map() {
        let (w, h) = (40u32, 30u32);
        // A rectangle with a one-pixel bump and a notch, beside a slanted edge.
        let facet = |x: u32, y: u32| -> u32 {
            let rect = (10..25).contains(&x) && (8..20).contains(&y);
            let bump = x == 17 && y == 7;
            let notch = x == 12 && y == 19;
            if (rect || bump) && !notch {
                1
            } else if 2 * y > x + 30 {
                2
            } else {
                0
            }
        };
        let ids = (0..w * h).map(|i| facet(i % w, i / w)).collect();
        let map = FacetMap { width: w, height: h, ids, facet_count: 3 };
        let tri = vec![0u32; (w * h) as usize];
        let window = edge_line::Window::new();
        for k in 0..(w * h) as usize {
            let p = DVec2::new((k % w as usize) as f64 + 0.5, (k / w as usize) as f64 + 0.5);
            assert_eq!(across_edge(&map, &tri, k, p, &window), None, "pixel {p:?}");
        }
    }

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
