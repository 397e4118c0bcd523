//! Tests of the painterly chain: its contracts (an effect off leaves the image bit-identical,
//! deterministic on any thread count, alpha handling), its golden image, the pipeline's
//! paint, and kept inputs.

use crate::error::Error;
use crate::paint::palette::ColourTransfer;
use crate::paint::tests::*;
use crate::paint::*;
use crate::pipeline::params::paint;
use crate::settings::{Palette, Preset, Settings};
use proptest::prelude::*;

fn all_off() -> Settings {
    let mut s = Settings::preset(Preset::Plain);
    s.width = 64;
    s.height = 48;
    s
}

#[test]
fn each_effect_off_leaves_the_image_bit_identical() {
    let facets = voronoi(64, 48, 8, 1);
    let frame0 = render_like(64, 48);
    type Toggle = (&'static str, fn(&mut Settings, bool));
    let toggles: Vec<Toggle> = vec![
        ("borders", |s, on| s.border_width = if on { 10.0 } else { 0.0 }),
        ("borders", |s, on| s.border_strength = if on { 1.0 } else { 0.0 }),
        ("silhouettes", |s, on| s.silhouette_width = if on { 200.0 } else { 0.0 }),
        ("silhouettes", |s, on| s.silhouette_strength = if on { 1.0 } else { 0.0 }),
        ("palette", |s, on| s.palette = if on { Palette::BluePeriod } else { Palette::None }),
        ("quantise", |s, on| s.colors = if on { 5 } else { 0 }),
        ("gradients", |s, on| s.gradients = if on { 1.0 } else { 0.0 }),
    ];
    for transparent in [false, true] {
        let mut s = all_off();
        s.transparent = transparent;
        s.border_width = 10.0;
        s.silhouette_width = 10.0;
        let mut film = frame0.clone();
        // Width without strength and strength without width are both off.
        s.border_strength = 0.0;
        s.silhouette_strength = 0.0;
        let p = Painter::new(&paint(&s)).unwrap();
        assert!(p.is_empty(), "{:?}", p.names());
        p.apply(&mut film, Some(&facets), None).unwrap();
        assert!(
            film.color
                .iter()
                .zip(&frame0.color)
                .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
        );
        for (name, toggle) in &toggles {
            let mut s = all_off();
            s.transparent = transparent;
            s.border_strength = 1.0;
            s.silhouette_strength = 1.0;
            s.border_width = 10.0;
            s.silhouette_width = 200.0;
            // Only the toggled one's pair is on: switch the other pair off.
            if !name.starts_with("borders") {
                s.border_width = 0.0;
            }
            if !name.starts_with("silhouettes") {
                s.silhouette_width = 0.0;
            }
            toggle(&mut s, true);
            assert_eq!(Painter::new(&paint(&s)).unwrap().names(), [*name]);
            let mut on = frame0.clone();
            Painter::new(&paint(&s)).unwrap().apply(&mut on, Some(&facets), None).unwrap();
            assert!(on.color != frame0.color, "{name} on changes the image");
            toggle(&mut s, false);
            let p = Painter::new(&paint(&s)).unwrap();
            assert!(p.is_empty(), "{name} off");
            let mut off = frame0.clone();
            p.apply(&mut off, Some(&facets), None).unwrap();
            assert!(
                off.color
                    .iter()
                    .zip(&frame0.color)
                    .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
            );
        }
    }
}

#[test]
fn the_chain_is_deterministic_on_any_thread_count() {
    let facets = voronoi(200, 150, 30, 5);
    let frame0 = render_like(200, 150);
    let mut s = all_off();
    s.width = 200;
    s.height = 150;
    s.border_width = 12.0;
    s.silhouette_width = 30.0;
    s.palette = Palette::Ochre;
    s.gradients = 0.4;
    s.colors = 7;
    let out = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut f = frame0.clone();
        pool.install(|| apply_chain(&mut f, Some(&facets), &paint(&s), None)).unwrap();
        f.color
    };
    let one = out(1);
    assert_eq!(
        Painter::new(&paint(&s)).unwrap().names(),
        ["silhouettes", "borders", "gradients", "palette", "quantise"],
        "fixed chain order"
    );
    assert!(one.iter().zip(out(3)).all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)));
}

#[test]
fn a_bad_palette_image_fails_before_tracing() {
    let prep = crate::pipeline::Prepared::new(crate::scene::Scene::default_scene());
    let mut s = all_off();
    s.palette_image = Some("/nonexistent/painting.jpg".into());
    let e = crate::pipeline::render(&prep, &s, &crate::progress::Progress::silent()).err().unwrap();
    assert!(matches!(e, Error::Input { .. }), "{e}");
}

#[test]
fn colour_transfer_levels_keep_hues_in_runs() {
    // The test painting's blue-grey and light ochre planes share a luminance range, each in
    // discrete 8-bit steps: picked bin by bin the levels flip hue every few bins (stripes on
    // every smooth gradient). Chosen together they switch hue only a few times.
    let painting = painting_like(400, 300);
    let t = ColourTransfer::from_colours(&reference_colours(&painting)).unwrap();
    let blue: Vec<bool> = t.levels().iter().map(|c| c.z > c.x).collect();
    let switches = blue.windows(2).filter(|w| w[0] != w[1]).count();
    assert!(blue.iter().any(|b| *b), "the blue-grey plane is used");
    assert!(switches <= 4, "{switches} hue switches");
    for pair in t.levels().windows(2) {
        assert!(luminance(pair[0]) <= luminance(pair[1]));
    }
}

// ---- golden image and pipeline

/// The whole chain on a synthetic render with Voronoi facets, against a stored picture
/// (`CUBIST_UPDATE_GOLDEN=1 cargo test --release --lib paint_chain_golden` rewrites it after
/// an intended change; look at it before committing).
#[test]
fn paint_chain_golden() {
    let (w, h) = (96u32, 72u32);
    let mut film = render_like(w, h);
    let facets = voronoi(w, h, 14, 11);
    let mut s = Settings::preset(Preset::Braque);
    s.width = w;
    s.height = h;
    s.chiaroscuro = 0.0; // needs a scene; covered by its own test
    s.contour_width = 0.0; // the same
    apply_chain(&mut film, Some(&facets), &paint(&s), None).unwrap();
    let img = crate::output::encode(&film, s.background, false);
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/paint-chain.png");
    if std::env::var_os("CUBIST_UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        img.save(&path).unwrap();
    }
    let golden =
        image::open(&path).expect("tests/golden/paint-chain.png (rewrite with CUBIST_UPDATE_GOLDEN=1)").to_rgba8();
    assert_eq!(golden.dimensions(), img.dimensions());
    let diffs: Vec<i32> =
        golden.as_raw().iter().zip(img.as_raw()).map(|(a, b)| (*a as i32 - *b as i32).abs()).collect();
    let max = diffs.iter().copied().max().unwrap();
    let mean = diffs.iter().sum::<i32>() as f64 / diffs.len() as f64;
    assert!(max <= 3 && mean < 0.05, "differs from the golden image: max {max}, mean {mean}");
}

#[test]
fn the_pipeline_paints_the_analytic_preset() {
    use crate::pipeline::{Prepared, render};
    let prep = Prepared::new(crate::scene::Scene::default_scene());
    let progress = crate::progress::Progress::silent();
    let mut plain = Settings::preset(Preset::Plain);
    plain.width = 64;
    plain.height = 48;
    plain.spp = 1;
    let mut analytic = Settings::preset(Preset::Analytic);
    analytic.width = 64;
    analytic.height = 48;
    analytic.spp = 1;
    // Until the facets stage is wired the pipeline renders unfaceted; the painting still runs.
    analytic.faceting = crate::settings::Faceting::None;
    let a = render(&prep, &plain, &progress).unwrap();
    let b = render(&prep, &analytic, &progress).unwrap();
    assert!(b.timings.0.iter().any(|(stage, _)| *stage == "paint"));
    assert!(!a.timings.0.iter().any(|(stage, _)| *stage == "paint"), "no paint stage when every effect is off");
    assert!(a.image != b.image);
    // The ochre ramp: every painted pixel is warm (red >= green >= blue).
    assert!(b.image.pixels().all(|p| p.0[0] >= p.0[1] && p.0[1] >= p.0[2]));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Any size (down to 1x1), any facet split, opaque or transparent: finite colours, alpha in
    /// [0, 1], and a transparent image's background never gains colour, only black.
    #[test]
    fn the_chain_is_stable_on_any_image(
        w in 1u32..24,
        h in 1u32..24,
        sites in 1u32..12,
        seed in any::<u64>(),
        transparent in any::<bool>(),
        colors in prop_oneof![Just(0u32), 2u32..12],
    ) {
        let frame0 = render_like(w, h);
        let facets = voronoi(w, h, sites, seed);
        let mut s = all_off();
        s.width = w;
        s.height = h;
        s.seed = seed;
        s.transparent = transparent;
        s.border_width = 300.0;
        s.silhouette_width = 300.0;
        s.gradients = 0.7;
        s.palette = Palette::Grey;
        s.colors = colors;
        let mut f = frame0.clone();
        apply_chain(&mut f, Some(&facets), &paint(&s), None).unwrap();
        for (a, b) in f.color.iter().zip(&frame0.color) {
            prop_assert!(a.is_finite() && (0.0..=1.0).contains(&a.w));
            prop_assert!(a.w >= b.w - 1e-6, "alpha never drops");
        }
        let img = crate::output::encode(&f, s.background, transparent);
        if transparent {
            for (p, b) in img.pixels().zip(&frame0.color) {
                if b.w == 0.0 {
                    prop_assert!(p.0[..3].iter().all(|&v| v == 0), "background halo must be black: {:?}", p.0);
                }
            }
        }
    }
}

// ---- the default look (the effects themselves: tests_plane.rs)

#[test]
fn the_default_chain_is_identical_on_any_thread_count() {
    let (w, h) = (240u32, 180u32);
    let facets = voronoi(w, h, 30, 5);
    let frame0 = crate::paint::tests_plane::textured(w, h);
    let mut s = Settings::default();
    (s.width, s.height) = (w, h);
    s.chiaroscuro = 0.0; // needs a scene: covered by the pipeline test below
    s.contour_width = 0.0; // the same
    let out = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut f = frame0.clone();
        pool.install(|| apply_chain(&mut f, Some(&facets), &paint(&s), None)).unwrap();
        crate::paint::tests_plane::bits(&f)
    };
    assert_eq!(
        Painter::new(&paint(&s)).unwrap().names(),
        ["palette", "brushwork", "plane light", "passage", "values", "canvas grain"],
        "fixed chain order"
    );
    assert_eq!(out(1), out(3));
}

#[test]
fn the_thesis_borders_stay_reachable() {
    let mut s = Settings::default();
    assert_eq!(s.border_style, crate::settings::BorderStyle::Passage);
    s.border_style = crate::settings::BorderStyle::Symmetric;
    assert!(Painter::new(&paint(&s)).unwrap().names().contains(&"borders"));
    // A preset without the look's paint has none of it; the paper's method none either.
    for p in [Preset::Plain, Preset::Thesis] {
        let s = Settings::preset(p);
        assert_eq!((s.plane_light, s.brushwork, s.value_contrast, s.canvas_grain), (0.0, 0.0, 0.0, 0.0));
        assert_eq!((s.ground_value, s.value_lift), (1.0, 1.0));
        assert_eq!(s.border_style, crate::settings::BorderStyle::Symmetric);
    }
}

#[test]
fn the_default_render_lights_most_planes_on_their_own() {
    // the per-plane light measure on the built-in still life: most facets carry a
    // gradient of at least 15% of the image's range; without the per-plane light fewer do.
    use crate::pipeline::{Prepared, render};
    let prep = Prepared::new(crate::scene::Scene::default_scene());
    let progress = crate::progress::Progress::silent();
    let mut s = Settings::default();
    (s.width, s.height, s.spp) = (320, 240, 1);
    let on = render(&prep, &s, &progress).unwrap();
    let facets = &on.facets;
    let with = crate::paint::measure::per_plane_light(&crate::paint::measure::luma(&on.image), &facets.ids, s.width);
    s.plane_light = 0.0;
    let off = render(&prep, &s, &progress).unwrap();
    let without =
        crate::paint::measure::per_plane_light(&crate::paint::measure::luma(&off.image), &off.facets.ids, s.width);
    assert!(with.facets >= 10, "{with:?}");
    assert!(with.share >= 0.7, "per-plane light {:.2} of {} facets", with.share, with.facets);
    assert!(with.share > without.share, "{} vs {}", with.share, without.share);
    assert_eq!(crate::paint::measure::PLANE_LIGHT_SHARE, 0.15);
}

#[test]
fn kept_paint_inputs_give_the_one_off_chains_pixels_after_a_change_upstream() {
    // A session keeps the brushwork's strokes and fragments (`PaintInputs::kept`): after a
    // border width change (passage, before the brushwork, paints other colours) the chain on
    // the kept inputs must give the bits a one-off chain gives, on any thread count.
    let (w, h) = (240u32, 180u32);
    let facets = voronoi(w, h, 30, 5);
    let frame0 = crate::paint::tests_plane::textured(w, h);
    let mut s = Settings::default();
    (s.width, s.height) = (w, h);
    (s.chiaroscuro, s.contour_width) = (0.0, 0.0); // they need a scene
    let inputs = PaintInputs::kept_for_changes();
    for (threads, border) in [(1, 12.0), (3, 11.0), (1, 16.0), (3, 12.0)] {
        s.border_width = border;
        let painter = Painter::new(&paint(&s)).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let (mut kept, mut fresh) = (frame0.clone(), frame0.clone());
        pool.install(|| painter.apply_with(&mut kept, Some(&facets), None, &inputs)).unwrap();
        painter.apply(&mut fresh, Some(&facets), None).unwrap();
        assert!(inputs.bytes() > 0);
        assert_eq!(crate::paint::tests_plane::bits(&kept), crate::paint::tests_plane::bits(&fresh), "border {border}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// `PaintContext::edges` serves a limit from edges computed at a larger one: below the
    /// smaller limit the nearest feature (ties included: sparse features on a grid tie often)
    /// and its distance must be the same bits.
    #[test]
    fn edges_below_a_limit_do_not_depend_on_it(
        w in 1usize..40,
        h in 1usize..40,
        bits in proptest::collection::vec(0u8..24, 1600),
        limit in 0.5f32..20.0,
        more in 0.0f32..30.0,
    ) {
        let feat: Vec<bool> = (0..w * h).map(|i| bits[i] == 0).collect();
        let (d, near) = crate::distance::nearest_features(w as u32, h as u32, limit, |i| feat[i]);
        let (d2, near2) = crate::distance::nearest_features(w as u32, h as u32, limit + more, |i| feat[i]);
        for i in 0..w * h {
            if d[i] < limit {
                prop_assert_eq!(near[i], near2[i], "pixel {}", i);
                prop_assert_eq!(d[i].to_bits(), d2[i].to_bits(), "pixel {}", i);
            } else {
                prop_assert!(d2[i] >= limit, "pixel {}: {} at the larger limit", i, d2[i]);
            }
        }
    }
}
