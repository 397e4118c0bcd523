//! The default look on scenes built in code, so these run on a fresh clone: the
//! odd scenes (very tall, flat, z-up, several objects, a walker, a pole, a board edge-on, a
//! bench, far, huge, tiny) and the still life; with `--include-ignored`, the tall and thin
//! shared samples (../shared).
//! Planes tile the canvas with straight edges, no facet dominates, the subject keeps its
//! proportions and stays whole, background facets show no ghost, and the picture is the same on
//! any thread count. The thesis preset keeps the paper's method.

use cubist::look::odd::odd_scenes;
use cubist::pipeline::{self, Prepared};
use cubist::progress::Progress;
use cubist::settings::{Faceting, Framing, Preset, Settings};

fn small(preset: Preset, w: u32, h: u32) -> Settings {
    Settings { width: w, height: h, spp: 1, ..Settings::preset(preset) }
}

#[test]
fn the_default_look_on_odd_scenes() {
    let s = small(Preset::Analytic, 320, 240);
    for (name, scene) in odd_scenes() {
        let prep = Prepared::new(scene);
        let look = pipeline::look(&prep, &s, &name).unwrap();
        let r = &look.row;
        eprintln!("{name}: {r:?}");
        assert_eq!(r.planes, 1.0, "{name}: every pixel in a polygonal plane");
        assert!(r.largest <= 0.15, "{name}: largest facet {:.3}", r.largest);
        // At 320 x 240 a run of 1% of the diagonal is 4 px, so short chains weigh more than
        // at the report's 640 x 480; the report holds the 97% target.
        assert!(r.straight >= 0.93, "{name}: straight runs {:.3}", r.straight);
        assert!(r.ghost <= 0.05, "{name}: ghost share {:.3}", r.ghost);
        // By construction (imprecision::cues): no most salient vertex the
        // unfaceted render shows drops out of the final image.
        assert!(r.cues_final >= r.cues_pre, "{name}: cues kept {}/{}", r.cues_final, r.cues_pre);
        // The subject keeps the proportions of a real view of it (its parallel projection along
        // the same view): within 1.25x, a little more for the subjects a few pixels wide at this
        // size (a pole), whose width the probe rounds. It is seen, not lost in the ground.
        if let Some(stretch) = r.stretch {
            let most = if name == "odd-pole" { 2.0 } else { 1.35 };
            assert!(stretch <= most, "{name}: stretch {stretch:.2}");
        }
        // On a floor or in a room, the subject is measured, not the setting around it.
        if name == "odd-floor" || name == "odd-room" {
            assert!(r.stretch.is_some_and(|s| s <= 1.25), "{name}: stretch {:?}", r.stretch);
        }
        assert!(r.fill >= 0.04, "{name}: subject fill {:.3}", r.fill);
        // Planes over the salient parts are smaller than the edges' (a hierarchy).
        if let Some(hierarchy) = r.hierarchy {
            assert!(hierarchy >= 1.3, "{name}: hierarchy {hierarchy:.2}");
        }
    }
}

/// Pixels on the picture's outermost columns, top row and bottom row that show the subject
/// (geometry, not a backdrop or an enclosure, which reach past the edges): a subject cut off.
fn edge_hits(film: &cubist::film::Film, world: &cubist::scene::World) -> Edges {
    let (w, h) = (film.width as usize, film.height as usize);
    let subject = |i: usize| film.hits[i].is_hit() && !world.is_setting(film.hits[i].object as usize);
    let count = |pixels: &mut dyn Iterator<Item = usize>| pixels.filter(|&i| subject(i)).count();
    Edges {
        sides: count(&mut (0..h).flat_map(|y| [y * w, y * w + w - 1])),
        top: count(&mut (0..w)),
        bottom: count(&mut ((h - 1) * w..h * w)),
    }
}

#[derive(Debug)]
struct Edges {
    sides: usize,
    top: usize,
    bottom: usize,
}

impl Edges {
    /// Whole, but for the end of a tall subject the composition says it cropped (the camera's
    /// description): its foot, or its top where its bulk lies low; never its sides.
    fn whole_or_cropped(&self, camera: &str) -> bool {
        let foot = camera.contains("its foot cropped");
        let top = camera.contains("its top cropped");
        self.sides == 0 && (self.top == 0 || top) && (self.bottom == 0 || foot)
    }
}

#[test]
fn composed_subjects_stay_whole() {
    // The pre-render's outermost pixels show no geometry: no part of the subject is cut off,
    // but a tall subject's foot or top (`framing::compose`'s crop).
    let s = Settings { faceting: Faceting::None, ..small(Preset::Analytic, 160, 120) };
    for (name, scene) in odd_scenes() {
        let prep = Prepared::new(scene);
        let r = pipeline::render(&prep, &s, &Progress::silent()).unwrap();
        let on_edge = edge_hits(&r.film, &prep.world);
        assert!(on_edge.whole_or_cropped(&r.camera), "{name}: edge pixels show geometry {on_edge:?} ({})", r.camera);
    }
}

#[test]
fn same_look_on_any_thread_count() {
    let s = small(Preset::Analytic, 96, 72);
    // Three odd scenes and the still life.
    let picked = ["odd-tall", "odd-flat", "odd-walker"];
    let mut scenes: Vec<Prepared> =
        odd_scenes().into_iter().filter(|(n, _)| picked.contains(&n.as_str())).map(|(_, s)| Prepared::new(s)).collect();
    assert_eq!(scenes.len(), picked.len());
    scenes.push(Prepared::load(None).unwrap());
    for prep in &scenes {
        let render = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| pipeline::render(prep, &s, &Progress::silent()).unwrap())
        };
        let (a, b, c) = (render(1), render(2), render(5));
        assert_eq!(a.facets, b.facets);
        assert_eq!(a.facets, c.facets);
        assert_eq!(a.image, b.image);
        assert_eq!(a.image, c.image);
        assert_eq!(a.camera, c.camera);
    }
}

#[test]
fn the_thesis_preset_is_the_papers_method() {
    let t = Settings::preset(Preset::Thesis);
    assert_eq!(t.faceting, Faceting::Segment);
    assert_eq!((t.segments.clone(), t.thresholds.clone()), (vec![5, 30, 120], vec![0.0, 0.05, 0.08]));
    assert_eq!(t.framing, Framing::Fit);
    assert_eq!((t.aim_min_coverage, t.aim_width_share), (0.0, 0.0), "every facet re-aimed, as the thesis");
    assert_eq!((t.discontinuity, t.border_width), (200.0, 12.0));
    assert_eq!(t.ambiguity, None, "140 deg");
    // The still life through it has Segment's level-1 leftovers and re-aimed background facets.
    let prep = Prepared::load(None).unwrap();
    let look = pipeline::look(&prep, &small(Preset::Thesis, 160, 120), "still-life").unwrap();
    assert!(look.row.planes < 1.0, "{:?}", look.row);
    // The default is ours: planes, composed, the backdrop kept.
    let d = Settings::default();
    assert_eq!((d.preset, d.faceting, d.framing), (Preset::Analytic, Faceting::Planes, Framing::Compose));
    assert!(d.aim_min_coverage > 0.0);
}

#[test]
fn the_still_life_keeps_its_cues() {
    // The top 5% salient vertices are seen at least as often as in the unfaceted render, at
    // the report's size and a smaller one, with the default look and the other presets that
    // re-aim.
    let prep = Prepared::load(None).unwrap();
    for (preset, w, h) in [(Preset::Analytic, 320, 240), (Preset::Analytic, 640, 480), (Preset::Braque, 320, 240)] {
        let look = pipeline::look(&prep, &small(preset, w, h), "still-life").unwrap();
        assert!(look.row.cues_pre > 10, "{:?}", look.row);
        assert!(look.row.cues_final >= look.row.cues_pre, "{preset:?} {w}x{h}: {:?}", look.row);
    }
}

/// Compares `img` with the golden image `name` (tests/golden), rewriting it when
/// CUBIST_UPDATE_GOLDEN is set. `max_big` channels may differ by more than 24 levels (a facet
/// edge or an outline one pixel off on another CPU's floating point).
fn check_golden(img: &image::RgbaImage, name: &str, max_mean: f64, max_big: usize) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden").join(name);
    if std::env::var_os("CUBIST_UPDATE_GOLDEN").is_some() {
        img.save(&path).unwrap();
    }
    let want =
        image::open(&path).unwrap_or_else(|e| panic!("{name}: {e} (CUBIST_UPDATE_GOLDEN=1 writes it)")).to_rgba8();
    assert_eq!(want.dimensions(), img.dimensions(), "{name}");
    let (mut total, mut big) = (0u64, 0usize);
    for (a, b) in want.pixels().zip(img.pixels()) {
        for k in 0..3 {
            let d = (a.0[k] as i32 - b.0[k] as i32).unsigned_abs() as u64;
            total += d;
            big += (d > 24) as usize;
        }
    }
    let mean = total as f64 / (img.width() * img.height() * 3) as f64;
    assert!(mean < max_mean && big < max_big, "{name}: mean abs diff {mean:.3}, {big} channels off by > 24");
}

/// The default look and the thesis preset on the still life, against committed pictures: the
/// thesis's must not change while its method does not; the default's changes only deliberately.
#[test]
fn golden_default_and_thesis_still_life() {
    let prep = Prepared::load(None).unwrap();
    for (preset, name) in [(Preset::Analytic, "still_life_default.png"), (Preset::Thesis, "still_life_thesis.png")] {
        let s = Settings { spp: 2, ..small(preset, 160, 120) };
        let r = pipeline::render(&prep, &s, &Progress::silent()).unwrap();
        check_golden(&r.image, name, 1.5, 400);
    }
}

/// The tall thin shared samples keep their proportions and stay whole (a tall one cropped
/// at its foot at most): CesiumMan (a figure
/// walking across the default view, an arm out) and the Fox. Needs ../shared.
#[test]
#[ignore = "needs ../shared/gltf-samples"]
fn tall_thin_samples_keep_their_proportions() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples");
    for name in ["CesiumMan.glb", "Fox.glb"] {
        let path = dir.join(name);
        let prep = Prepared::load(Some(path.as_path())).unwrap();
        let look = pipeline::look(&prep, &small(Preset::Analytic, 320, 240), name).unwrap();
        let stretch = look.row.stretch.expect("both views see the subject");
        assert!(stretch <= 1.25, "{name}: stretch {stretch:.2} ({})", look.row.camera);
        let s = Settings { faceting: Faceting::None, ..small(Preset::Analytic, 160, 120) };
        let r = pipeline::render(&prep, &s, &Progress::silent()).unwrap();
        let on_edge = edge_hits(&r.film, &prep.world);
        assert!(on_edge.whole_or_cropped(&r.camera), "{name}: edge pixels show geometry {on_edge:?} ({})", r.camera);
    }
}
