//! Tests of the look's paint: per-plane light, passage, brushwork, canvas grain, on synthetic
//! canvases and facet maps (any facet map: Voronoi cells here). The default look's chain and
//! its per-plane light measure on a real render are in `tests.rs`.

use glam::{Vec2, Vec3, Vec4};

use super::border_profile::drawn_line;
use super::borders::Borders;
use super::brushwork::Brushwork;
use super::canvas::CanvasGrain;
use super::measure::{luma, per_plane_light};
use super::passage::Passage;
use super::plane_light::{DARK, GROUND, LIGHT, PlaneLight, Steps};
use super::planes::planes;
use super::tests::voronoi;
use super::*;
use crate::facets::FacetMap;
use crate::film::Film;

/// A flat, fully covered frame of one colour (object 0 everywhere).
fn flat(w: u32, h: u32, c: Vec3) -> Film {
    let mut f = Film::new(w, h, 1);
    for (p, hit) in f.color.iter_mut().zip(f.hits.iter_mut()) {
        *p = c.extend(1.0);
        hit.tri = 0;
        hit.object = 0;
        hit.normal = Vec3::Z;
    }
    f
}

fn run(effect: Box<dyn Effect>, frame: &mut Film, facets: Option<&FacetMap>) {
    Painter::from_effects(vec![effect], [0.62, 0.56, 0.46], false).apply(frame, facets, None).unwrap();
}

pub(super) fn bits(f: &Film) -> Vec<[u32; 4]> {
    f.color.iter().map(|c| c.to_array().map(f32::to_bits)).collect()
}

/// Two facets side by side, split at column `split`.
fn halves(w: u32, h: u32, split: u32) -> FacetMap {
    FacetMap { width: w, height: h, ids: (0..w * h).map(|i| (i % w >= split) as u32).collect(), facet_count: 2 }
}

// ---- per-plane light

/// Runs `light` over `frame` (a flat value of 0.4) on `facets` (`count` of them) and asserts
/// every pixel is lit as `PlaneLight::composed` says, with `ground(facet)` its plane's share of
/// ground.
fn lit_as_composed(
    light: &PlaneLight,
    frame: &mut Film,
    facets: &FacetMap,
    count: usize,
    ground: impl Fn(usize) -> f32,
) {
    let w = frame.width;
    let oval = super::plane_light::Oval::of(w as usize, frame.height as usize, &frame.hits);
    run(Box::new(PlaneLight { amount: light.amount, seed: light.seed, steps: None }), frame, Some(facets));
    let planes = planes(w, &facets.ids, count, light.seed);
    for (i, c) in frame.color.iter().enumerate() {
        let p = Vec2::new((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
        let f = facets.ids[i] as usize;
        let want = 0.4 * light.composed(&planes[f], p, oval.r(p), ground(f));
        assert!((c.x - want).abs() < 1e-6, "pixel {i}: {} against {want}", c.x);
    }
}

#[test]
fn every_plane_gets_a_ramp_from_its_light_end_to_its_dark_end() {
    let (w, h) = (240u32, 180u32);
    let facets = voronoi(w, h, 20, 3);
    let mut frame = flat(w, h, Vec3::splat(0.4));
    let light = PlaneLight { amount: 0.7, seed: 5, steps: None };
    lit_as_composed(&light, &mut frame, &facets, 20, |_| 0.0);
    // The ends: 1 + amount LIGHT and 1 - amount DARK.
    assert!((light.factor(0.0) - (1.0 + 0.7 * LIGHT)).abs() < 1e-6);
    assert!((light.factor(1.0) - (1.0 - 0.7 * DARK)).abs() < 1e-6);
    // Every plane large enough to count varies by a gradient across it: the measure says so.
    let img = crate::output::encode(&frame, [0.0; 3], false);
    let m = per_plane_light(&luma(&img), &facets.ids, w);
    assert!(m.facets >= 15 && m.share == 1.0, "{m:?}");
}

#[test]
fn the_grounds_planes_are_modelled_more_deeply_than_the_subjects() {
    // Two planes, the left one on the subject, the right one on the ground: each pixel is lit
    // as `composed` says with its plane's share of ground, and at the composition's centre
    // a ground plane's ramp is 1 + GROUND times the subject plane's.
    let (w, h) = (120u32, 60u32);
    let facets = halves(w, h, 60);
    let mut frame = flat(w, h, Vec3::splat(0.4));
    for (i, hit) in frame.hits.iter_mut().enumerate() {
        if i as u32 % w >= 60 {
            *hit = crate::film::PixelHit::MISS;
        }
    }
    assert!(!frame.hits[w as usize - 1].is_hit() && frame.hits[0].is_hit());
    let light = PlaneLight { amount: 0.7, seed: 5, steps: None };
    lit_as_composed(&light, &mut frame, &facets, 2, |f| f as f32);
    let planes = planes(w, &facets.ids, 2, 5);
    let centre = 1.0 + 0.7 * super::plane_light::CENTRE_LIGHT;
    for p in [Vec2::new(3.5, 2.5), Vec2::new(30.5, 40.5)] {
        let subject = light.composed(&planes[0], p, 0.0, 0.0) / centre - 1.0;
        let ground = light.composed(&planes[0], p, 0.0, 1.0) / centre - 1.0;
        assert!(subject.abs() > 1e-3 && (ground - (1.0 + GROUND) * subject).abs() < 1e-5, "{subject} {ground}");
    }
}

#[test]
fn stepped_light_lays_straight_bands() {
    // The step of each pixel's own ramp position, as a smooth ramp quantised: a plane's light
    // takes at most `levels` values (at a given distance from the composition's centre), the
    // large planes at least three, in bands whose edges are the ramp's straight iso-lines.
    let (w, h) = (240u32, 180u32);
    let facets = voronoi(w, h, 12, 3);
    let light = || PlaneLight { amount: 0.7, seed: 5, steps: Some(Steps { levels: 5 }) };
    let mut frame = flat(w, h, Vec3::splat(0.4));
    run(Box::new(light()), &mut frame, Some(&facets));
    let planes = planes(w, &facets.ids, 12, 5);
    let oval = super::plane_light::Oval::of(w as usize, h as usize, &frame.hits);
    let (light, steps) = (light(), Steps { levels: 5 });
    let mut seen: Vec<std::collections::BTreeSet<u32>> = vec![Default::default(); 12];
    for (i, c) in frame.color.iter().enumerate() {
        let p = Vec2::new((i as u32 % w) as f32 + 0.5, (i as u32 / w) as f32 + 0.5);
        let f = facets.ids[i] as usize;
        let t = steps.step(planes[f].ramp(p));
        let want = 0.4 * light.composed_at(t, oval.r(p), 0.0);
        assert!((c.x - want).abs() < 1e-6, "pixel {i}: {} against {want}", c.x);
        seen[f].insert((t * 1000.0).round() as u32);
    }
    for (f, s) in seen.iter().enumerate() {
        assert!(s.len() <= 5 && (planes[f].pixels < 2000 || s.len() >= 3), "plane {f}: {s:?}");
    }
    // The steps: the middles of five equal parts of the ramp, the ends included.
    let middles: Vec<f32> = [0.0, 0.19, 0.2, 0.5, 0.99, 1.0].iter().map(|&t| steps.step(t)).collect();
    assert_eq!(middles, [0.1, 0.1, 0.3, 0.5, 0.9, 0.9]);
}

#[test]
fn plane_light_leaves_an_unfaceted_or_transparent_background_alone() {
    let (w, h) = (60u32, 40u32);
    let mut frame = flat(w, h, Vec3::splat(0.4));
    let before = bits(&frame);
    run(Box::new(PlaneLight { amount: 1.0, seed: 1, steps: None }), &mut frame, None);
    assert_eq!(bits(&frame), before, "no facet map: no plane");
    // Transparent: pixels nothing covered stay clear.
    let mut frame = flat(w, h, Vec3::splat(0.4));
    for c in frame.color.iter_mut().take(600) {
        *c = Vec4::new(0.62, 0.56, 0.46, 0.0);
    }
    let facets = voronoi(w, h, 4, 2);
    Painter::from_effects(vec![Box::new(PlaneLight { amount: 1.0, seed: 1, steps: None })], [0.62, 0.56, 0.46], true)
        .apply(&mut frame, Some(&facets), None)
        .unwrap();
    assert!(frame.color.iter().take(600).all(|c| *c == Vec4::new(0.62, 0.56, 0.46, 0.0)));
}

// ---- passage

#[test]
fn passage_darkens_one_side_only_with_a_hard_edge() {
    // A darker facet (left) beside a lighter one (right): the line lies on the darker side,
    // strongest on the border pixel; the lighter side is not darkened (only blended near the
    // border where the line is weak), unlike eq 4.8 which darkens both sides alike.
    let (w, h) = (160u32, 120u32);
    let facets = halves(w, h, 80);
    let base = |x: u32| if x < 80 { 0.25 } else { 0.6 };
    let mut frame = flat(w, h, Vec3::ONE);
    for (i, c) in frame.color.iter_mut().enumerate() {
        *c = Vec3::splat(base(i as u32 % w)).extend(1.0);
    }
    let md = 12.0;
    let mut passage = frame.clone();
    run(Box::new(Passage { width: md, strength: 1.0, seed: 3 }), &mut passage, Some(&facets));
    let mut symmetric = frame.clone();
    run(Box::new(Borders { width: md, strength: 1.0 }), &mut symmetric, Some(&facets));
    for y in 0..h {
        let at = |f: &Film, x: u32| f.color[(y * w + x) as usize].x;
        // The darker side, past the blend band (md / 2) and within the line: darkened by the
        // drawn line's profile times the line's strength, which never drops to nothing; past
        // the line's end, untouched.
        let d = 6.0;
        let dark = at(&passage, 79 - 6) / base(79 - 6);
        assert!(drawn_line(d, md) < 1.0);
        assert!(dark < 1.0 - (1.0 - drawn_line(d, md)) * passage::LOST * passage::FLOOR + 1e-5, "row {y}: {dark}");
        assert!(dark >= drawn_line(d, md) - 1e-6, "row {y}: {dark}");
        assert_eq!(at(&passage, 79 - 8), base(79 - 8), "row {y}: past the line");
        // The lighter side never darkens below the blend of its own and the other side's value.
        for x in 80..w {
            assert!(at(&passage, x) >= base(x) * (1.0 - passage::BLEND) + 0.25 * passage::BLEND - 1e-5);
        }
        // Past the blend band the lighter side is untouched; eq 4.8 darkened it.
        let x = 80 + (md as u32) / 2 + 1;
        assert_eq!(at(&passage, x), base(x), "row {y}");
        assert!(at(&symmetric, x) < base(x));
        // Beyond md nothing changes.
        assert_eq!(at(&passage, 60), base(60));
    }
}

#[test]
fn passage_keeps_a_join_on_its_darker_plane_through_its_dabs() {
    // The left plane hatched in dabs two rows high, alternately 0.1 and 0.4 (its mean 0.25),
    // beside a flat 0.3: the line lies on the left, the darker plane, along the whole join,
    // not on whichever side is darker dab by dab (a seam that turns on and off and changes
    // sides, stitched).
    let (w, h) = (160u32, 120u32);
    let facets = halves(w, h, 80);
    let base = |x: u32, y: u32| {
        if x >= 80 {
            0.3
        } else if (y / 2).is_multiple_of(2) {
            0.1
        } else {
            0.4
        }
    };
    let mut frame = flat(w, h, Vec3::ONE);
    for (i, c) in frame.color.iter_mut().enumerate() {
        *c = Vec3::splat(base(i as u32 % w, i as u32 / w)).extend(1.0);
    }
    let md = 12.0;
    run(Box::new(Passage { width: md, strength: 1.0, seed: 3 }), &mut frame, Some(&facets));
    let at = |x: u32, y: u32| frame.color[(y * w + x) as usize].x;
    for y in (0..h).filter(|y| !(y / 2).is_multiple_of(2)) {
        // A light dab: darkened by the line, past the blend band ...
        let dark = at(79 - 6, y) / base(79 - 6, y);
        assert!(dark < 1.0 - (1.0 - drawn_line(6.0, md)) * passage::LOST * passage::FLOOR + 1e-5, "row {y}: {dark}");
        // ... and the flat plane beside it, darker than the dab, never darkened (only blended
        // towards the lighter dab where the line is weak).
        for x in 80..w {
            assert!(at(x, y) >= 0.3 - 1e-5, "row {y}, x {x}: {}", at(x, y));
        }
    }
}

#[test]
fn passage_lines_come_and_go_along_a_border() {
    // Lost and found: along a long border of two equal planes the line's strength varies.
    let (w, h) = (64u32, 1000u32);
    let facets = halves(w, h, 32);
    let mut frame = flat(w, h, Vec3::splat(0.5));
    run(Box::new(Passage { width: 10.0, strength: 1.0, seed: 9 }), &mut frame, Some(&facets));
    let edge: Vec<f32> = (0..h).map(|y| frame.color[(y * w + 31) as usize].x).collect();
    let (lo, hi) = edge.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    assert!(hi - lo > 0.05, "the line's strength should vary along the border: {lo} .. {hi}");
    // Equal values on both sides: the line goes to one side only (the tie-break), the other
    // side keeps its value (blending equal colours changes nothing).
    for y in 0..h {
        let (l, r) = (frame.color[(y * w + 31) as usize].x, frame.color[(y * w + 32) as usize].x);
        assert!(l < 0.5 && (r - 0.5).abs() < 1e-6, "row {y}: {l} {r}");
    }
}

#[test]
fn passage_draws_object_silhouettes_without_a_facet_map() {
    // One facet (no map), two objects: the silhouette is an edge; background-only images are not.
    let (w, h) = (80u32, 40u32);
    let mut frame = flat(w, h, Vec3::splat(0.5));
    for (i, hit) in frame.hits.iter_mut().enumerate() {
        if i as u32 % w >= 40 {
            hit.object = 1;
        }
    }
    let before = frame.clone();
    run(Box::new(Passage { width: 8.0, strength: 1.0, seed: 1 }), &mut frame, None);
    assert!(frame.color != before.color, "the silhouette gets a line");
    let mut plain = flat(w, h, Vec3::splat(0.5));
    let before = bits(&plain);
    run(Box::new(Passage { width: 8.0, strength: 1.0, seed: 1 }), &mut plain, None);
    assert_eq!(bits(&plain), before, "no edge, no line");
}

// ---- brushwork

/// A picture with texture at every scale, so strokes have something to sample.
pub(super) fn textured(w: u32, h: u32) -> Film {
    let mut f = flat(w, h, Vec3::ZERO);
    for (i, c) in f.color.iter_mut().enumerate() {
        let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
        let v = 0.35 + 0.2 * (x * 0.05).sin() * (y * 0.07).cos() + 0.1 * noise::value2(4, x / 3.0, y / 3.0);
        *c = Vec3::new(v, v * 0.9, v * 0.7).extend(1.0);
    }
    f
}

#[test]
fn brushwork_is_identical_on_any_thread_count() {
    let (w, h) = (300u32, 220u32);
    let facets = voronoi(w, h, 25, 8);
    let frame0 = textured(w, h);
    let out = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut f = frame0.clone();
        let b = Brushwork { opacity: 0.9, length: 14.0, width: 4.0, seed: 11 };
        pool.install(|| run(Box::new(b), &mut f, Some(&facets)));
        bits(&f)
    };
    let one = out(1);
    assert_eq!(one, out(2));
    assert_eq!(one, out(4));
    assert!(one != bits(&frame0), "strokes were painted");
    // Seeded: another seed paints other strokes.
    let mut f = frame0.clone();
    run(Box::new(Brushwork { opacity: 0.9, length: 14.0, width: 4.0, seed: 12 }), &mut f, Some(&facets));
    assert!(bits(&f) != one);
}

#[test]
fn strokes_paint_only_their_own_plane_and_object() {
    // Red facet beside a blue one, and a green object inside the red facet: no pixel takes a
    // colour from across a facet border or a silhouette.
    let (w, h) = (200u32, 120u32);
    let facets = halves(w, h, 100);
    let mut frame = flat(w, h, Vec3::ZERO);
    for (i, (c, hit)) in frame.color.iter_mut().zip(frame.hits.iter_mut()).enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let green = (30..70).contains(&x) && (30..90).contains(&y);
        hit.object = green as u32;
        *c = if green {
            Vec3::new(0.0, 0.5, 0.0)
        } else if x < 100 {
            Vec3::new(0.6, 0.0, 0.0)
        } else {
            Vec3::new(0.0, 0.0, 0.6)
        }
        .extend(1.0);
    }
    let before = frame.clone();
    run(Box::new(Brushwork { opacity: 1.0, length: 30.0, width: 8.0, seed: 2 }), &mut frame, Some(&facets));
    for (a, b) in frame.color.iter().zip(&before.color) {
        // Each channel that was zero stays zero: strokes carry only their region's colour.
        for k in 0..3 {
            if b[k] == 0.0 {
                assert_eq!(a[k], 0.0);
            }
        }
    }
}

/// The dominant direction of the luminance texture over the pixels where `inside` holds:
/// the structure tensor's minor eigenvector (along the strokes), and its coherence in [0, 1].
fn texture_direction(f: &Film, inside: impl Fn(u32, u32) -> bool) -> (Vec2, f32) {
    let (w, h) = (f.width, f.height);
    let l = |x: u32, y: u32| luminance(f.color[(y * w + x) as usize].truncate()) as f64;
    let (mut jxx, mut jxy, mut jyy) = (0f64, 0f64, 0f64);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            if !(inside(x, y) && inside(x - 1, y) && inside(x + 1, y) && inside(x, y - 1) && inside(x, y + 1)) {
                continue;
            }
            let gx = (l(x + 1, y) - l(x - 1, y)) / 2.0;
            let gy = (l(x, y + 1) - l(x, y - 1)) / 2.0;
            jxx += gx * gx;
            jxy += gx * gy;
            jyy += gy * gy;
        }
    }
    let tr = jxx + jyy;
    let disc = (((jxx - jyy) / 2.0).powi(2) + jxy * jxy).sqrt();
    // The gradient's main direction; strokes run across it.
    let angle = 0.5 * (2.0 * jxy).atan2(jxx - jyy);
    let along = Vec2::from_angle(angle as f32).perp();
    (along, if tr > 0.0 { (2.0 * disc / tr) as f32 } else { 0.0 })
}

#[test]
fn strokes_are_parallel_within_a_plane_and_turn_from_plane_to_plane() {
    // Flat planes (no texture of their own): what texture there is comes from the strokes.
    let (w, h) = (400u32, 200u32);
    let facets = halves(w, h, 200);
    let mut frame = flat(w, h, Vec3::splat(0.45));
    let b = Brushwork { opacity: 1.0, length: 24.0, width: 6.0, seed: 21 };
    let want = b.directions(&planes(w, &facets.ids, 2, 21));
    run(Box::new(Brushwork { opacity: 1.0, length: 24.0, width: 6.0, seed: 21 }), &mut frame, Some(&facets));
    let mut found = Vec::new();
    for f in 0..2u32 {
        let (dir, coherence) = texture_direction(&frame, |x, y| {
            facets.ids[(y * w + x) as usize] == f && (10..190).contains(&(x % 200)) && (10..190).contains(&y)
        });
        let off = dir.dot(want[f as usize]).abs().min(1.0).acos().to_degrees();
        assert!(off < 12.0, "facet {f}: strokes {dir} vs planned {}: {off} deg", want[f as usize]);
        assert!(coherence > 0.3, "facet {f}: mostly parallel strokes, coherence {coherence}");
        found.push(dir);
    }
    let between = found[0].dot(found[1]).abs().min(1.0).acos().to_degrees();
    let planned = want[0].dot(want[1]).abs().min(1.0).acos().to_degrees();
    assert!((between - planned).abs() < 15.0, "{between} vs {planned}");
}

#[test]
fn the_hatching_quietens_where_the_composition_is_calm() {
    // A flat picture, all subject (the composition centred on the canvas), in many planes:
    // what varies comes from the strokes, whose value changes are smaller towards the corners
    // (`brushwork::CORNER_CALM`) than about the centre.
    let (w, h) = (480u32, 360u32);
    let facets = voronoi(w, h, 60, 3);
    let mut frame = flat(w, h, Vec3::splat(0.45));
    run(Box::new(Brushwork { opacity: 1.0, length: 20.0, width: 6.0, seed: 9 }), &mut frame, Some(&facets));
    let oval = super::plane_light::Oval::of(w as usize, h as usize, &frame.hits);
    let spread = |inside: &dyn Fn(f32) -> bool| {
        let v: Vec<f64> = (0..(w * h) as usize)
            .filter(|&i| inside(oval.r(Vec2::new((i % w as usize) as f32 + 0.5, (i / w as usize) as f32 + 0.5))))
            .map(|i| luminance(frame.color[i].truncate()) as f64)
            .collect();
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / v.len() as f64).sqrt() / mean
    };
    let (centre, corners) = (spread(&|r| r < 0.3), spread(&|r| r > 0.95));
    assert!(corners < 0.7 * centre, "corners {corners} vs centre {centre}");
    assert!(corners > 0.1 * centre, "the corners lost their strokes: {corners} vs {centre}");
}

#[test]
fn brushwork_keeps_dark_accents_and_skips_what_is_not_painted() {
    // A one-pixel dark line inside a light plane stays dark under the strokes.
    let (w, h) = (120u32, 80u32);
    let mut frame = flat(w, h, Vec3::splat(0.6));
    for y in 0..h {
        frame.color[(y * w + 60) as usize] = Vec3::splat(0.1).extend(1.0);
    }
    run(Box::new(Brushwork { opacity: 1.0, length: 20.0, width: 6.0, seed: 4 }), &mut frame, None);
    for y in 0..h {
        assert!(frame.color[(y * w + 60) as usize].x < 0.2, "row {y}");
    }
    // Transparent background pixels stay clear.
    let mut frame = flat(w, h, Vec3::splat(0.6));
    for c in frame.color.iter_mut().take(2000) {
        *c = Vec4::new(0.62, 0.56, 0.46, 0.0);
    }
    Painter::from_effects(
        vec![Box::new(Brushwork { opacity: 1.0, length: 20.0, width: 6.0, seed: 4 })],
        [0.62, 0.56, 0.46],
        true,
    )
    .apply(&mut frame, None, None)
    .unwrap();
    assert!(frame.color.iter().take(2000).all(|c| *c == Vec4::new(0.62, 0.56, 0.46, 0.0)));
}

// ---- canvas grain

#[test]
fn canvas_grain_keeps_the_value_and_fades_when_too_fine() {
    let (w, h) = (200u32, 150u32);
    let mut frame = flat(w, h, Vec3::splat(0.5));
    run(Box::new(CanvasGrain { amount: 1.0, period: 4.0, seed: 1 }), &mut frame, None);
    let mean = frame.color.iter().map(|c| c.x as f64).sum::<f64>() / frame.color.len() as f64;
    assert!((mean - 0.5).abs() < 0.5 * 0.03, "mean {mean}");
    let (lo, hi) = frame.color.iter().fold((f32::MAX, f32::MIN), |(a, b), c| (a.min(c.x), b.max(c.x)));
    assert!(hi - lo > 0.05, "the weave shows: {lo} .. {hi}");
    // Periods under a couple of pixels would alias: no grain at all.
    let mut small = flat(w, h, Vec3::splat(0.5));
    let before = bits(&small);
    run(Box::new(CanvasGrain { amount: 1.0, period: 1.5, seed: 1 }), &mut small, None);
    assert_eq!(bits(&small), before);
}

// ---- the default look
