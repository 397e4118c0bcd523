//! Tests of the painterly effects: each SPEC property on synthetic canvases and facet maps
//! (the facet stage is not needed), and the helpers the other paint tests share.

use glam::{Vec3, Vec4};
use proptest::prelude::*;

use super::border_profile::border_factor;
use super::borders::Borders;
use super::chiaroscuro::{Chiaroscuro, MAX_GAIN, ViewAxes};
use super::gradients::Gradients;
use super::palette::{self, ColourTransfer};
use super::quantise::Quantise;
use super::silhouettes::Silhouettes;
use super::*;
use crate::facets::FacetMap;
use crate::film::{Film, NO_HIT};
use crate::pipeline::params::paint;
use crate::settings::{Palette, Preset, Settings};
use crate::util::rng::{splitmix64, unit_f64};

/// Voronoi-like facet ids: nearest of `n` seeded random sites.
pub(super) fn voronoi(w: u32, h: u32, n: u32, seed: u64) -> FacetMap {
    let sites: Vec<(f64, f64)> = (0..n)
        .map(|k| {
            let a = splitmix64(seed ^ splitmix64(k as u64));
            (unit_f64(a) * w as f64, unit_f64(splitmix64(a)) * h as f64)
        })
        .collect();
    let ids = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let d = |s: &(f64, f64)| (s.0 - x).powi(2) + (s.1 - y).powi(2);
            (0..n as usize).min_by(|&a, &b| d(&sites[a]).total_cmp(&d(&sites[b]))).unwrap() as u32
        })
        .collect();
    FacetMap { width: w, height: h, ids, facet_count: n }
}

/// A frame whose colour is `f(x, y)` (linear RGB) fully covered where `fg(x, y)`, background
/// `bg` elsewhere.
pub(super) fn frame_with(
    w: u32,
    h: u32,
    bg: Vec3,
    f: impl Fn(u32, u32) -> Vec3,
    fg: impl Fn(u32, u32) -> bool,
) -> Film {
    let mut film = Film::new(w, h, 1);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            if fg(x, y) {
                film.color[i] = f(x, y).extend(1.0);
                film.hits[i].tri = 0;
                film.hits[i].object = 0;
                film.hits[i].normal = Vec3::Z;
            } else {
                film.color[i] = bg.extend(0.0);
            }
        }
    }
    film
}

pub(super) fn noise(x: u32, y: u32, salt: u64) -> f32 {
    unit_f64(splitmix64(((y as u64) << 32 | x as u64) ^ salt)) as f32
}

/// A render-like image: a shaded blob on a flat background with some texture.
pub(super) fn render_like(w: u32, h: u32) -> Film {
    let bg = Vec3::new(0.62, 0.56, 0.46);
    let (cx, cy, r) = (w as f32 * 0.5, h as f32 * 0.55, w.min(h) as f32 * 0.35);
    frame_with(
        w,
        h,
        bg,
        |x, y| {
            let l = 0.15 + 0.7 * (x as f32 / w as f32) + 0.05 * noise(x, y, 1);
            Vec3::new(l, l * 0.8, l * (0.4 + 0.4 * noise(x, y, 2)))
        },
        |x, y| (x as f32 + 0.5 - cx).powi(2) + (y as f32 + 0.5 - cy).powi(2) < r * r,
    )
}

/// A painting-like reference (not a painting): ochre and umber planes, a blue-grey passage,
/// lead-white lights, brush noise.
pub(super) fn painting_like(w: u32, h: u32) -> image::RgbImage {
    image::RgbImage::from_fn(w, h, |x, y| {
        let plane = ((x / 9) * 7 + (y / 11) * 3) % 5;
        let base: [f32; 3] = match plane {
            0 => [120.0, 90.0, 54.0],
            1 => [60.0, 44.0, 28.0],
            2 => [168.0, 132.0, 79.0],
            3 => [110.0, 125.0, 140.0],
            _ => [225.0, 210.0, 175.0],
        };
        let n = noise(x, y, 7) * 40.0 - 20.0;
        image::Rgb(base.map(|c| (c + n).clamp(0.0, 255.0) as u8))
    })
}

pub(super) fn lum(c: Vec4) -> f32 {
    luminance(c.truncate())
}

pub(super) fn run(effect: Box<dyn Effect>, film: &mut Film, facets: Option<&FacetMap>, transparent: bool) {
    let bg = [0.62, 0.56, 0.46];
    Painter::from_effects(vec![effect], bg, transparent).apply(film, facets, None).unwrap();
}

// ---- facet borders (eq 4.8)

#[test]
fn eq_4_8_at_zero_half_and_full_distance() {
    let md = 12.0;
    assert_eq!(border_factor(0.0, md), 0.25);
    assert!((border_factor(md / 2.0, md) - (1.0 + 3.0 * 0.5f32.sqrt()) / 4.0).abs() < 1e-6);
    assert_eq!(border_factor(md, md), 1.0);
    assert_eq!(border_factor(3.0 * md, md), 1.0);
}

#[test]
fn the_drawn_line_is_dark_across_its_core_and_gone_past_its_end() {
    use super::border_profile::{LINE_CORE, LINE_END, drawn_line};
    let md = 12.0;
    assert_eq!(drawn_line(0.0, md), border_factor(0.0, md));
    assert_eq!(drawn_line(LINE_CORE * md, md), 0.25);
    assert_eq!(drawn_line(LINE_END * md, md), 1.0);
    assert_eq!(drawn_line(md, md), 1.0);
    // Rising, and darker than eq 4.8 over the core, lighter past the line.
    let mut last = 0.0;
    for k in 0..=120 {
        let d = k as f32 * 0.1;
        let f = drawn_line(d, md);
        assert!(f >= last && (0.25..=1.0).contains(&f), "{d}: {f}");
        last = f;
    }
    assert!(drawn_line(0.25 * md, md) < border_factor(0.25 * md, md));
    assert!(drawn_line(0.6 * md, md) > border_factor(0.6 * md, md));
    assert_eq!(drawn_line(3.0, 0.0), 1.0);
}

#[test]
fn border_darkening_matches_eq_4_8_on_the_image() {
    // Two facets split at x = 50; md = 20 px given at 1000 px and scaled to this image.
    let (w, h) = (120u32, 30u32);
    let grey = Vec3::splat(0.5);
    let mut film = frame_with(w, h, Vec3::ZERO, |_, _| grey, |_, _| true);
    let facets =
        FacetMap { width: w, height: h, ids: (0..w * h).map(|i| (i % w >= 50) as u32).collect(), facet_count: 2 };
    let mut s = Settings::preset(Preset::Plain);
    s.width = w;
    s.height = h;
    s.border_width = 20.0 / s.pixel_scale();
    s.border_strength = 1.0;
    let painter = Painter::new(&paint(&s)).unwrap();
    assert_eq!(painter.names(), ["borders"]);
    painter.apply(&mut film, Some(&facets), None).unwrap();
    let at = |x: u32| film.color[(15 * w + x) as usize].x;
    let expect = |pd: f32| 0.5 * (20.0 + 3.0 * (pd * 20.0).sqrt()) / 80.0;
    // p_d = 0 on both border pixels, md/2 = 10 and md = 20 px away on either side.
    for (x, pd) in [(50, 0.0), (49, 0.0), (60, 10.0), (39, 10.0), (70, 20.0), (29, 20.0), (100, 50.0)] {
        let want = if pd >= 20.0 { 0.5 } else { expect(pd) };
        assert!((at(x) - want).abs() < 1e-5, "x {x}: {} vs {want}", at(x));
    }
    assert!((at(50) - 0.125).abs() < 1e-6);
}

#[test]
fn border_strength_scales_the_darkening() {
    let (w, h) = (40u32, 4u32);
    let mut film = frame_with(w, h, Vec3::ZERO, |_, _| Vec3::ONE, |_, _| true);
    let facets =
        FacetMap { width: w, height: h, ids: (0..w * h).map(|i| (i % w >= 20) as u32).collect(), facet_count: 2 };
    run(Box::new(Borders { width: 8.0, strength: 0.5 }), &mut film, Some(&facets), false);
    assert!((film.color[20].x - (1.0 - 0.5 * 0.75)).abs() < 1e-6);
}

#[test]
fn borders_need_a_matching_facet_map() {
    let mut film = render_like(20, 10);
    let facets = voronoi(10, 10, 3, 1);
    let p = Painter::from_effects(vec![Box::new(Borders { width: 4.0, strength: 1.0 })], [0.0; 3], false);
    let e = p.apply(&mut film, Some(&facets), None).unwrap_err().to_string();
    assert!(e.contains("10x10") && e.contains("20x10"), "{e}");
}

// ---- silhouettes

#[test]
fn silhouettes_darken_the_background_by_distance_to_the_foreground() {
    let (w, h) = (80u32, 20u32);
    let bg = Vec3::new(0.62, 0.56, 0.46);
    let mut film = frame_with(w, h, bg, |_, _| Vec3::splat(0.3), |x, _| x < 10);
    let before = film.clone();
    run(Box::new(Silhouettes { width: 30.0, strength: 1.0 }), &mut film, None, false);
    for x in 0..w {
        let i = (10 * w + x) as usize;
        if x < 10 {
            assert_eq!(film.color[i], before.color[i], "foreground untouched");
        } else {
            let d = (x - 9) as f32;
            let want = bg * border_factor(d, 30.0);
            assert!((film.color[i].truncate() - want).length() < 1e-5, "x {x}");
        }
    }
}

#[test]
fn transparent_darkening_composites_to_the_opaque_image() {
    // Borders and silhouettes on a transparent canvas are black with alpha: composited over
    // the background they give the opaque result, partial coverage included.
    let (w, h) = (64u32, 48u32);
    let bg = Vec3::new(0.62, 0.56, 0.46);
    let mut base = render_like(w, h);
    for (i, c) in base.color.iter_mut().enumerate() {
        if i % 7 == 3 && c.w == 1.0 {
            // Partly covered pixels: 60% foreground, 40% background, as the tracer blends.
            let fg = c.truncate();
            *c = (fg * 0.6 + bg * 0.4).extend(0.6);
        }
    }
    let facets = voronoi(w, h, 9, 3);
    let chain = || -> Vec<Box<dyn Effect>> {
        vec![Box::new(Silhouettes { width: 10.0, strength: 0.8 }), Box::new(Borders { width: 5.0, strength: 0.9 })]
    };
    let mut opaque = base.clone();
    Painter::from_effects(chain(), bg.into(), false).apply(&mut opaque, Some(&facets), None).unwrap();
    let mut clear = base.clone();
    Painter::from_effects(chain(), bg.into(), true).apply(&mut clear, Some(&facets), None).unwrap();
    let img = crate::output::encode(&clear, bg.into(), true);
    let mut darkened_background = 0;
    for (i, (o, c)) in opaque.color.iter().zip(&clear.color).enumerate() {
        // The transparent frame's colour is premultiplied + (1 - a) bg: exactly the composite.
        assert!((o.truncate() - c.truncate()).length() < 1e-5, "pixel {i}: {o} vs {c}");
        if base.color[i].w == 0.0 && c.w > 0.0 {
            darkened_background += 1;
            assert!(img.as_raw()[i * 4..i * 4 + 3].iter().all(|&v| v == 0), "halo is black");
        }
    }
    assert!(darkened_background > 100);
}

// ---- colour transfer

pub(super) fn reference_colours(img: &image::RgbImage) -> Vec<Vec3> {
    use crate::scene::texture::srgb_to_linear;
    img.pixels().map(|p| Vec3::from_array(p.0.map(|v| srgb_to_linear(v as f32 / 255.0)))).collect()
}

#[test]
fn colour_transfer_uses_only_reference_colours_and_keeps_luminance_order() {
    let painting = painting_like(97, 61);
    let reference = reference_colours(&painting);
    for (w, h) in [(64u32, 48u32), (300, 200), (7, 3)] {
        let mut film = render_like(w, h);
        let before = film.clone();
        run(Box::new(ColourTransfer::from_colours(&reference).unwrap()), &mut film, None, false);
        for c in &film.color {
            assert!(reference.contains(&c.truncate()), "{c} is not a colour of the reference");
        }
        let mut order: Vec<usize> = (0..film.color.len()).collect();
        order.sort_by(|&a, &b| lum(before.color[a]).total_cmp(&lum(before.color[b])));
        for pair in order.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            if lum(before.color[a]) < lum(before.color[b]) {
                assert!(lum(film.color[a]) <= lum(film.color[b]), "order broken at {a}, {b}");
            } else {
                assert_eq!(film.color[a], film.color[b], "ties share a colour");
            }
        }
    }
}

#[test]
fn colour_transfer_from_a_png_writes_only_its_colours() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("painting.png");
    let painting = painting_like(50, 40);
    painting.save(&path).unwrap();
    let mut film = render_like(90, 70);
    let mut s = Settings::preset(Preset::Plain);
    s.palette_image = Some(path.clone());
    s.palette = Palette::Ochre; // overridden by the image
    Painter::new(&paint(&s)).unwrap().apply(&mut film, None, None).unwrap();
    let img = crate::output::encode(&film, s.background, false);
    let colours: std::collections::HashSet<[u8; 3]> = painting.pixels().map(|p| p.0).collect();
    for p in img.pixels() {
        assert!(colours.contains(&[p.0[0], p.0[1], p.0[2]]), "{:?} not in the painting", p.0);
    }
}

#[test]
fn plain_ranks_without_contrast_limit() {
    // The SPEC's literal rule: the pixel of rank k among N takes quantile (k + 1/2) / N.
    let reference: Vec<Vec3> = (0..10).map(|k| Vec3::splat(k as f32 / 10.0)).collect();
    let mut t = ColourTransfer::from_colours(&reference).unwrap();
    t.contrast_limit = f64::INFINITY;
    let n = 5u32;
    let mut film = frame_with(n, 1, Vec3::ZERO, |x, _| Vec3::splat(0.01 + 0.2 * x as f32), |_, _| true);
    run(Box::new(t), &mut film, None, false);
    for k in 0..n as usize {
        let q = (k as f32 + 0.5) / n as f32;
        assert_eq!(film.color[k].x, reference[(q * 10.0) as usize].x, "rank {k}");
    }
}

/// A grey reference ramp of 100 levels, and an `n` x 2 picture: a subject (row 0, hit pixels)
/// of value 0.3 over a ground (row 1) whose values run from 0.2 to 0.5, below it to above it.
fn subject_over_a_ground_ramp(n: u32) -> (Vec<Vec3>, Film) {
    let reference: Vec<Vec3> = (0..100).map(|k| Vec3::splat(k as f32 / 100.0)).collect();
    let mut film = frame_with(n, 2, Vec3::ZERO, |_, _| Vec3::splat(0.3), |_, y| y == 0);
    for x in 0..n {
        film.color[(n + x) as usize] = Vec3::splat(0.2 + 0.3 * x as f32 / n as f32).extend(1.0);
    }
    (reference, film)
}

#[test]
fn ground_value_lifts_the_subject_above_a_ground_of_its_value() {
    // Ranked as rendered the subject takes a middle level; with the ground ranked at 0.6 of
    // its value, a level above the whole ground's, the ground keeping its own order.
    let n = 40u32;
    let paint = |ground: f32| {
        let (reference, mut film) = subject_over_a_ground_ramp(n);
        let mut t = ColourTransfer::from_colours(&reference).unwrap();
        t.contrast_limit = f64::INFINITY;
        t.ground_value = ground;
        run(Box::new(t), &mut film, None, false);
        let (subject, ground) = film.color.split_at(n as usize);
        (subject[0].x, ground.iter().map(|c| c.x).collect::<Vec<f32>>())
    };
    let (subject, ground) = paint(1.0);
    assert!(ground.iter().any(|&g| g > subject) && ground.iter().any(|&g| g < subject));
    let (subject, ground) = paint(0.6);
    assert!(ground.iter().all(|&g| g < subject), "{subject} over {ground:?}");
    assert!(ground.windows(2).all(|w| w[0] <= w[1]), "the ground's order: {ground:?}");
}

#[test]
fn ground_value_holds_for_a_sequence_as_for_a_still() {
    // An animation decides the palette's mapping on one picture and looks every frame up in
    // it: that picture painted as a frame paints as the still does, ground lowered and all.
    let n = 40u32;
    let (reference, film) = subject_over_a_ground_ramp(n);
    let mut t = ColourTransfer::from_colours(&reference).unwrap();
    t.ground_value = 0.6;
    let painter = Painter::from_effects(vec![Box::new(t)], [0.0; 3], false);
    let mut still = film.clone();
    painter.apply(&mut still, None, None).unwrap();
    let held = painter.hold(&film, None, None, &sequence::Sequence::default()).unwrap();
    let mut frame = film.clone();
    painter
        .apply_sequence(&mut frame, None, None, &sequence::Sequence { held: Some(&held), ..Default::default() })
        .unwrap();
    for (i, (a, b)) in still.color.iter().zip(&frame.color).enumerate() {
        assert!((a.x - b.x).abs() <= 0.02, "pixel {i}: still {a}, frame {b}");
    }
    let (subject, ground) = frame.color.split_at(n as usize);
    assert!(ground.iter().all(|g| g.x < subject[0].x));
}

#[test]
fn bad_palette_images_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.jpg");
    let e = ColourTransfer::from_image(&missing).err().unwrap().to_string();
    assert!(e.contains("missing.jpg"), "{e}");
    let junk = dir.path().join("junk.png");
    std::fs::write(&junk, b"not an image").unwrap();
    let e = ColourTransfer::from_image(&junk).err().unwrap().to_string();
    assert!(e.contains("junk.png") && e.contains("palette image"), "{e}");
    let clear = dir.path().join("clear.png");
    image::RgbaImage::new(4, 4).save(&clear).unwrap();
    let e = ColourTransfer::from_image(&clear).err().unwrap().to_string();
    assert!(e.contains("no opaque pixel"), "{e}");
}

#[test]
fn built_in_ramps_are_luminance_ordered() {
    use palette::Palette as P;
    for (p, name) in [(P::Ochre, "ochre"), (P::Grey, "grey"), (P::BluePeriod, "blue-period"), (P::Olive, "olive")] {
        let r = palette::ramp(p).unwrap();
        assert_eq!(r.name, name);
        assert_eq!(r.stops.first().unwrap().0, 0.0);
        assert_eq!(r.stops.last().unwrap().0, 1.0);
        for pair in r.stops.windows(2) {
            assert!(pair[0].0 < pair[1].0, "{}: positions", r.name);
        }
        let t = ColourTransfer::from_ramp(r);
        for pair in t.levels().windows(2) {
            assert!(luminance(pair[0]) < luminance(pair[1]), "{}: luminance must increase", r.name);
        }
    }
    assert!(palette::ramp(P::None).is_none());
}

// ---- quantisation

#[test]
fn quantisation_yields_at_most_k_colours_and_keeps_luminance() {
    let frame0 = render_like(120, 90);
    for k in [2u32, 3, 5, 16, 200] {
        let mut film = frame0.clone();
        run(Box::new(Quantise { colors: k }), &mut film, None, false);
        let mut colours: Vec<[u32; 3]> = film.color.iter().map(|c| c.truncate().to_array().map(f32::to_bits)).collect();
        colours.sort();
        colours.dedup();
        assert!(colours.len() <= k as usize, "k {k}: {} colours", colours.len());
        assert!(colours.len() >= 2.min(k as usize));
        // Brighter never turns darker, and each colour's luminance is its pixels' mean.
        let mut groups: std::collections::HashMap<[u32; 3], (f64, f64, usize)> = Default::default();
        for (a, b) in frame0.color.iter().zip(&film.color) {
            let g = groups.entry(b.truncate().to_array().map(f32::to_bits)).or_default();
            g.0 += lum(*a) as f64;
            g.1 = lum(*b) as f64;
            g.2 += 1;
        }
        for (sum, l, n) in groups.values() {
            assert!((sum / *n as f64 - l).abs() < 1e-4, "k {k}: mean luminance kept");
        }
    }
    // Brighter never turns darker.
    let mut film = frame0.clone();
    run(Box::new(Quantise { colors: 6 }), &mut film, None, false);
    let mut order: Vec<usize> = (0..film.color.len()).collect();
    order.sort_by(|&a, &b| lum(frame0.color[a]).total_cmp(&lum(frame0.color[b])));
    for pair in order.windows(2) {
        assert!(lum(film.color[pair[0]]) <= lum(film.color[pair[1]]) + 1e-6);
    }
}

#[test]
fn quantising_a_transparent_image_leaves_the_background_clear() {
    let mut film = render_like(60, 40);
    let before = film.clone();
    run(Box::new(Quantise { colors: 4 }), &mut film, None, true);
    let img = crate::output::encode(&film, [0.62, 0.56, 0.46], true);
    let mut colours = std::collections::HashSet::new();
    for (i, p) in img.pixels().enumerate() {
        if before.color[i].w == 0.0 {
            assert_eq!(p.0[3], 0);
            assert_eq!(film.color[i], before.color[i]);
        } else {
            colours.insert([p.0[0], p.0[1], p.0[2]]);
        }
    }
    assert!(colours.len() <= 4, "{colours:?}");
}

// ---- gradients

#[test]
fn gradients_touch_only_chosen_facets_and_peak_at_a_corner() {
    let (w, h) = (160u32, 120u32);
    let facets = voronoi(w, h, 24, 9);
    let g = Gradients { fraction: 0.5, seed: 4 };
    let overlays = g.overlays(w, &facets.ids, 24);
    let chosen = overlays.iter().filter(|o| o.is_some()).count();
    assert!((4..=20).contains(&chosen), "{chosen} of 24 chosen at fraction 0.5");
    let mut film = frame_with(w, h, Vec3::ZERO, |_, _| Vec3::splat(0.5), |_, _| true);
    run(Box::new(Gradients { fraction: 0.5, seed: 4 }), &mut film, Some(&facets), false);
    for (i, c) in film.color.iter().enumerate() {
        if overlays[facets.ids[i] as usize].is_none() {
            assert_eq!(c.x, 0.5, "unchosen facet changed");
        }
    }
    for o in overlays.iter().flatten() {
        assert_eq!(o.weight(o.corner), 1.0);
        let centre = o.corner + o.axis / o.axis.length_squared();
        assert!(o.weight(centre) < 1e-6);
        let at_corner = o.apply(Vec3::splat(0.5), o.corner);
        let want = if o.dark { 0.5 * (1.0 - o.strength) } else { 0.5 + 0.5 * 0.6 * o.strength };
        assert!((at_corner.x - want).abs() < 1e-6);
    }
    // Every facet at fraction 1; seeded: another seed chooses differently.
    let all = Gradients { fraction: 1.0, seed: 4 }.overlays(w, &facets.ids, 24);
    assert!(all.iter().all(Option::is_some));
    let other = Gradients { fraction: 0.5, seed: 5 }.overlays(w, &facets.ids, 24);
    assert!(other != overlays);
}

// ---- chiaroscuro

/// A camera looking down -Z with +Y up.
pub(super) fn view_down_z() -> ViewAxes {
    ViewAxes { right: Vec3::X, up: Vec3::Y, forward: -Vec3::Z }
}

proptest! {
    #[test]
    fn chiaroscuro_turns_the_lights_towards_the_planes_light_side(
        amount in 0.0f32..=1.0,
        seed in any::<u64>(),
        facet in 0u32..1000,
        angle in 0.0f32..std::f32::consts::TAU,
    ) {
        use super::planes::{KEY, Plane};
        let dark = glam::Vec2::from_angle(angle);
        let plane = Plane { pixels: 10, centre: glam::Vec2::ZERO, long_axis: glam::Vec2::X, elongation: 0.0, dark, span: (0.0, 1.0) };
        let view = view_down_z();
        let (q, gain) = Chiaroscuro::new(amount, seed).facet_light(&plane, facet, &view);
        prop_assert!((gain - 1.0).abs() <= amount * MAX_GAIN + 1e-6);
        // A rotation about the view axis, by `amount` of the turn from the key's side to the
        // plane's light side.
        let (axis, turn) = q.to_axis_angle();
        if turn > 1e-4 {
            prop_assert!(axis.cross(view.forward).length() < 1e-3, "axis {axis}");
        }
        let full = KEY.angle_to(plane.light_side()).abs();
        prop_assert!((turn - amount * full).abs() < 2e-3, "turn {turn} vs {amount} x {full}");
        if amount == 1.0 {
            let key = view.world(KEY);
            let turned = q * key;
            prop_assert!((turned - view.world(plane.light_side())).length() < 1e-3);
        }
    }
}

#[test]
fn chiaroscuro_relights_facets_and_leaves_the_background() {
    use crate::pipeline::{Prepared, render};
    let prep = Prepared::new(crate::scene::Scene::default_scene());
    let mut s = Settings::preset(Preset::Plain);
    s.width = 96;
    s.height = 72;
    s.spp = 1;
    let rendered = render(&prep, &s, &crate::progress::Progress::silent()).unwrap();
    let framed = crate::framing::frame_camera(&crate::pipeline::params::framing(&s), &prep.world, &prep.accel).unwrap();
    let rig = crate::shading::LightRig::new(&prep.world, &framed.frame, s.shadows, s.exposure);
    let f = &framed.frame;
    let view = ViewAxes { right: f.right.as_vec3(), up: f.up.as_vec3(), forward: f.forward.as_vec3() };
    let lighting = Lighting { world: &prep.world, rig: &rig, view };
    let facets = voronoi(96, 72, 12, 2);
    let before = rendered.film;
    let relight = |amount: f32| {
        let mut f = before.clone();
        Painter::from_effects(vec![Box::new(Chiaroscuro::new(amount, 3))], s.background, false)
            .apply(&mut f, Some(&facets), Some(&lighting))
            .unwrap();
        f
    };
    let a = relight(0.8);
    assert_eq!(a.color, relight(0.8).color, "deterministic");
    let mut changed = vec![false; 12];
    for i in 0..before.color.len() {
        if before.hits[i].tri == NO_HIT {
            assert_eq!(a.color[i], before.color[i], "background untouched");
        } else if (a.color[i] - before.color[i]).truncate().length() > 1e-3 {
            changed[facets.ids[i] as usize] = true;
        }
        assert!(a.color[i].truncate().max_element() <= before.color[i].truncate().max_element() * 4.0 + 1e-4);
    }
    assert!(changed.iter().filter(|c| **c).count() >= 8, "{changed:?}");
    // Without the lights it is an error, not a silent no-op.
    let mut f = before.clone();
    let e = Painter::from_effects(vec![Box::new(Chiaroscuro::new(0.5, 3))], s.background, false)
        .apply(&mut f, None, None)
        .unwrap_err();
    assert!(e.to_string().contains("chiaroscuro"));
}
