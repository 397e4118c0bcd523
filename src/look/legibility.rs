//! Measures of a legible subject: its proportions against a parallel view of it, the planes'
//! hierarchy from the canvas edges to the salient features, the salient features kept whole
//! in one plane, and the share of the subject's outline crossed by planes or opened.
//!
//! Each is a question about the picture, not a goal: a stretched subject, a uniform lattice,
//! features sliced by plane edges and an unbroken outline are what made pictures hard to read.

use crate::accel::Accel;
use crate::camera::CameraKind;
use crate::error::Result;
use crate::facets::FacetMap;
use crate::framing::subject::{SceneView, Subject};
use crate::framing::{self, FramingParams};
use crate::scene::World;

/// Columns of the probes the stretch is measured on (rows follow the canvas's aspect).
pub const STRETCH_PROBE_COLUMNS: u32 = 320;
/// Points of the subject sampled for its parallel projection (every n-th triangle corner).
const STRETCH_SAMPLES: usize = 30_000;
/// The canvas band whose planes are the edge planes, as a share of the shorter side.
pub const EDGE_BAND: f64 = 0.06;
/// The salient pixels: this top share of the subject's pixels by the saliency map.
pub const SALIENT_SHARE: f64 = 0.03;
/// A salient feature is a connected patch of salient pixels of at least this share of the
/// canvas.
pub const FEATURE_MIN_SHARE: f64 = 0.0003;
/// A feature is whole when this share of its pixels lies in one plane.
pub const WHOLE_SHARE: f64 = 0.9;
/// An outline is opened where the painted luminance across it differs by less than this.
pub const OPEN_STEP: f32 = 0.035;

/// The subject's bounding-box aspect (width / height) under the composed camera against its
/// parallel projection along the same view (a pinhole at infinity), as max(r, 1/r) (1 = the
/// same proportions). Only the subject counts, not a floor or a room filling the canvas; with
/// the scene's own camera, what that camera sees of it, as the framing takes it. None when the
/// composed camera shows none of it.
pub fn stretch(params: &FramingParams, world: &World, accel: &Accel) -> Result<Option<f64>> {
    let framed = framing::frame_camera(params, world, accel)?;
    let aspect = params.width as f64 / params.height.max(1) as f64;
    let ours = framing::probe_subject(framed.camera.as_ref(), accel, world, aspect, STRETCH_PROBE_COLUMNS);
    let own = params.position.is_none() && params.target.is_none();
    let view = world.camera.as_ref().filter(|_| own).and_then(|c| SceneView::of(c, aspect, world, accel));
    let subject = Subject::new(world, STRETCH_SAMPLES, STRETCH_SAMPLES / 10, view.as_ref());
    // A cylindrical camera's rows are heights along its focal line: what its band crops of a
    // tall subject (its foot or its top) is left out of the parallel view too (its height cut
    // at the band, its width that of the sampled points within it).
    let up = framed.frame.up;
    let band = match (framed.kind, framed.focal_centre, framed.view_height) {
        (CameraKind::Cylindrical, Some(c), Some(h)) => (c.dot(up) - 0.5 * h, c.dot(up) + 0.5 * h),
        _ => (f64::NEG_INFINITY, f64::INFINITY),
    };
    let points = subject.points(false);
    let within: Vec<glam::DVec3> = points.iter().copied().filter(|p| (band.0..=band.1).contains(&p.dot(up))).collect();
    let span = |points: &[glam::DVec3], axis: glam::DVec3| {
        points
            .iter()
            .map(|p| p.dot(axis))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x), hi.max(x)))
    };
    let (lo, hi) = span(points, up);
    let (left, right) = span(if within.is_empty() { points } else { &within }, framed.frame.right);
    let theirs = (right - left) / (hi.min(band.1) - lo.max(band.0));
    let Some(a) = bbox_aspect(&ours).filter(|_| theirs.is_finite() && theirs > 0.0) else { return Ok(None) };
    let r = a / theirs;
    Ok(Some(r.max(1.0 / r)))
}

/// Width / height of the bounding box of the set pixels of a probe image.
fn bbox_aspect(img: &(Vec<f64>, u32, u32)) -> Option<f64> {
    let (px, w, h) = img;
    let (mut x0, mut x1, mut y0, mut y1) = (u32::MAX, 0, u32::MAX, 0);
    for y in 0..*h {
        for x in 0..*w {
            if px[(y * w + x) as usize] > 0.0 {
                (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
            }
        }
    }
    (x0 <= x1).then(|| (x1 - x0 + 1) as f64 / (y1 - y0 + 1) as f64)
}

/// The salient pixels: the top `SALIENT_SHARE` of the subject's pixels (`subject[i]`) by
/// `saliency`, when any pixel has a positive saliency.
pub fn salient_pixels(saliency: &[f32], subject: &[bool]) -> Vec<bool> {
    let mut values: Vec<f32> =
        saliency.iter().zip(subject).filter(|(s, on)| **on && **s > 0.0).map(|(s, _)| *s).collect();
    if values.is_empty() {
        return vec![false; saliency.len()];
    }
    let k = ((values.len() as f64 * (1.0 - SALIENT_SHARE)) as usize).min(values.len() - 1);
    let (_, cut, _) = values.select_nth_unstable_by(k, f32::total_cmp);
    let cut = *cut;
    saliency.iter().zip(subject).map(|(s, on)| *on && *s >= cut && *s > 0.0).collect()
}

/// The salient features: 8-connected patches of salient pixels of at least
/// `FEATURE_MIN_SHARE` of the canvas, each as its pixel indices.
pub fn features(salient: &[bool], width: u32, height: u32) -> Vec<Vec<usize>> {
    let (w, h) = (width as usize, height as usize);
    let min = ((FEATURE_MIN_SHARE * (w * h) as f64) as usize).max(4);
    let mut seen = vec![false; salient.len()];
    let mut out = Vec::new();
    for start in 0..salient.len() {
        if !salient[start] || seen[start] {
            continue;
        }
        let mut patch = vec![start];
        seen[start] = true;
        let mut k = 0;
        while k < patch.len() {
            let i = patch[k];
            k += 1;
            let (x, y) = ((i % w) as i64, (i / w) as i64);
            for dy in -1..=1 {
                for dx in -1..=1 {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as i64 || ny >= h as i64 {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if salient[j] && !seen[j] {
                        seen[j] = true;
                        patch.push(j);
                    }
                }
            }
        }
        if patch.len() >= min {
            out.push(patch);
        }
    }
    out
}

/// The share of `features` with at least `WHOLE_SHARE` of their pixels in one plane (1 when
/// there is none).
pub fn features_whole(map: &FacetMap, features: &[Vec<usize>]) -> f64 {
    if features.is_empty() {
        return 1.0;
    }
    let whole = features
        .iter()
        .filter(|f| {
            let mut counts = std::collections::HashMap::new();
            for &i in f.iter() {
                *counts.entry(map.ids[i]).or_insert(0usize) += 1;
            }
            let most = counts.values().copied().max().unwrap_or(0);
            most as f64 >= WHOLE_SHARE * f.len() as f64
        })
        .count();
    whole as f64 / features.len() as f64
}

/// The median area of the planes touching the canvas's edge band against the median area of
/// the planes the salient pixels lie in (each plane once), or None without salient pixels.
pub fn hierarchy(map: &FacetMap, salient: &[bool]) -> Option<f64> {
    let (w, h) = (map.width as usize, map.height as usize);
    let mut area = vec![0usize; map.facet_count as usize];
    for &id in &map.ids {
        if let Some(a) = area.get_mut(id as usize) {
            *a += 1;
        }
    }
    let band = ((EDGE_BAND * w.min(h) as f64).round() as usize).max(1);
    let mut edge = vec![false; area.len()];
    let mut cue = vec![false; area.len()];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let id = map.ids[i] as usize;
            if id >= area.len() {
                continue;
            }
            if x < band || y < band || x + band >= w || y + band >= h {
                edge[id] = true;
            }
            if salient[i] {
                cue[id] = true;
            }
        }
    }
    let median = |flags: &[bool]| {
        let mut v: Vec<usize> = area.iter().zip(flags).filter(|(a, f)| **f && **a > 0).map(|(a, _)| *a).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_unstable();
        Some(v[v.len() / 2] as f64)
    };
    Some(median(&edge)? / median(&cue)?)
}

/// The share of the subject's outline (pairs of 4-neighbour pixels, one on the subject and one
/// not) that a plane crosses (both pixels in one plane) or that the painting opens (their
/// painted luminance differs by less than `OPEN_STEP`).
pub fn outline_broken(map: &FacetMap, subject: &[bool], lum: &[f32]) -> f64 {
    let (w, h) = (map.width as usize, map.height as usize);
    let (mut total, mut broken) = (0usize, 0usize);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)].into_iter().flatten() {
                if subject[i] == subject[j] {
                    continue;
                }
                total += 1;
                if map.ids[i] == map.ids[j] || (lum[i] - lum[j]).abs() < OPEN_STEP {
                    broken += 1;
                }
            }
        }
    }
    if total == 0 { 0.0 } else { broken as f64 / total as f64 }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(w: u32, h: u32, id: impl Fn(u32, u32) -> u32, count: u32) -> FacetMap {
        let ids = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| id(x, y)).collect();
        FacetMap { width: w, height: h, ids, facet_count: count }
    }

    #[test]
    fn features_are_connected_salient_patches() {
        let (w, h) = (20u32, 10u32);
        let salient: Vec<bool> =
            (0..w * h).map(|i| ((i % w) < 3 && (i / w) < 3) || ((i % w) >= 15 && (i / w) >= 7)).collect();
        let f = features(&salient, w, h);
        assert_eq!(f.len(), 2);
        assert_eq!(f[0].len(), 9);
        assert_eq!(f[1].len(), 15);
    }

    #[test]
    fn a_feature_cut_by_a_plane_edge_is_not_whole() {
        let m = map(10, 10, |x, _| (x >= 5) as u32, 2);
        let inside: Vec<usize> = (0..10).flat_map(|y| (1..4).map(move |x| y * 10 + x)).collect();
        let across: Vec<usize> = (0..10).flat_map(|y| (3..7).map(move |x| y * 10 + x)).collect();
        assert_eq!(features_whole(&m, std::slice::from_ref(&inside)), 1.0);
        assert_eq!(features_whole(&m, &[inside, across]), 0.5);
    }

    #[test]
    fn hierarchy_compares_edge_planes_with_salient_planes() {
        // A 4 x 4 block of small planes in the middle, one big plane around it.
        let m = map(
            40,
            40,
            |x, y| if (16..24).contains(&x) && (16..24).contains(&y) { 1 + (x / 2 % 4) + 4 * (y / 2 % 4) } else { 0 },
            17,
        );
        let salient: Vec<bool> =
            (0..1600).map(|i| (18..22).contains(&(i % 40)) && (18..22).contains(&(i / 40))).collect();
        let r = hierarchy(&m, &salient).unwrap();
        assert!((r - (1600.0 - 64.0) / 4.0).abs() < 1e-9, "{r}");
    }

    #[test]
    fn an_outline_inside_one_plane_or_without_a_step_is_broken() {
        let subject: Vec<bool> = (0..100).map(|i| i % 10 < 5).collect();
        let split = map(10, 10, |x, _| (x >= 5) as u32, 2);
        let one = map(10, 10, |_, _| 0, 1);
        let step: Vec<f32> = (0..100).map(|i| if i % 10 < 5 { 0.2 } else { 0.8 }).collect();
        let flat = vec![0.5f32; 100];
        assert_eq!(outline_broken(&split, &subject, &step), 0.0);
        assert_eq!(outline_broken(&one, &subject, &step), 1.0);
        assert_eq!(outline_broken(&split, &subject, &flat), 1.0);
    }
}
