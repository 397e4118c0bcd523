//! Faceting and spatial imprecision through the whole pipeline, on the procedural still life
//! with a synthetic saliency map (a known function of the hit point), so these tests do not
//! depend on the mesh saliency stage: the measurable behaviour of faceting and
//! spatial imprecision.

use std::path::Path;

use cubist::facets::{FacetLayout, FacetPolygon, LabelImage};
use cubist::film::Film;
use cubist::framing::frame_camera;
use cubist::imprecision::AimContext;
use cubist::pipeline::{Prepared, Rendered, render_with};
use cubist::progress::Progress;
use cubist::settings::{CameraKind, FacetProjection, Faceting, Imprecision, Pass, Settings};
use glam::{DVec2, Vec3};

fn still_life() -> Prepared {
    Prepared::load(None).unwrap()
}

fn base_settings() -> Settings {
    Settings {
        width: 160,
        height: 120,
        spp: 1,
        seed: 3,
        faceting: Faceting::Voronoi,
        facet_count: 60,
        ..Settings::preset(cubist::settings::Preset::Plain)
    }
}

/// The hit point of a sample, render space.
fn hit_point(prep: &Prepared, tri: u32, u: f32, v: f32) -> Vec3 {
    let p = prep.world.triangle(tri);
    p[0] * (1.0 - u - v) + p[1] * u + p[2] * v
}

/// Synthetic saliency: a bump of radius 0.35 around the centre of the world's object `object`,
/// zero elsewhere (so facets away from it have no saliency at all).
fn bump(prep: &Prepared, object: usize) -> impl Fn(Vec3) -> f32 + '_ {
    let o = &prep.world.objects[object];
    let tris = o.first_triangle..o.first_triangle + o.triangle_count;
    let n = (tris.len() * 3) as f32;
    let centre = tris.flat_map(|t| prep.world.triangle(t)).fold(Vec3::ZERO, |a, p| a + p) / n;
    move |p: Vec3| (1.0 - (p - centre).length_squared() / (0.35 * 0.35)).max(0.0)
}

/// The per-pixel saliency map of Lee et al. 2005 for a saliency function of the hit point:
/// the average over the pixel's samples, 0 for background.
fn saliency_map(prep: &Prepared, film: &Film, s: &dyn Fn(Vec3) -> f32) -> Vec<f32> {
    (0..film.pixel_count())
        .map(|i| {
            let smp = film.pixel_samples(i);
            smp.iter().filter(|h| h.is_hit()).map(|h| s(hit_point(prep, h.tri, h.u, h.v))).sum::<f32>()
                / smp.len() as f32
        })
        .collect()
}

fn render_sal(prep: &Prepared, settings: &Settings, object: usize) -> Rendered {
    let s = bump(prep, object);
    render_with(prep, settings, &Progress::silent(), &|p, f| f.saliency = Some(saliency_map(p, f, &s))).unwrap()
}

fn render_plain(prep: &Prepared, settings: &Settings) -> Rendered {
    render_with(prep, settings, &Progress::silent(), &|_, _| {}).unwrap()
}

fn stages(r: &Rendered) -> Vec<&'static str> {
    r.timings.0.iter().map(|(n, _)| *n).collect()
}

/// Mean over adjacent pixel pairs in different facets of the L1 colour difference.
fn border_difference(r: &Rendered) -> f64 {
    let m = &r.facets;
    let (w, h) = (m.width as usize, m.height as usize);
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)].into_iter().flatten() {
                if m.ids[i] != m.ids[j] {
                    let d = (r.film.color[i] - r.film.color[j]).truncate().abs();
                    sum += (d.x + d.y + d.z) as f64;
                    n += 1;
                }
            }
        }
    }
    sum / n as f64
}

/// Mean saliency of the final image's hit samples.
fn mean_saliency(prep: &Prepared, r: &Rendered, s: &dyn Fn(Vec3) -> f32) -> f64 {
    let hits: Vec<f64> =
        r.film.samples.iter().filter(|h| h.is_hit()).map(|h| s(hit_point(prep, h.tri, h.u, h.v)) as f64).collect();
    hits.iter().sum::<f64>() / hits.len() as f64
}

/// The still life's objects in order: table, jug, bottle, bowl (right of centre), fruit...
const SALIENT: usize = 3;

#[test]
fn discontinuity_zero_with_converging_facets_is_the_unfaceted_render_and_skips_the_retrace() {
    let prep = still_life();
    let mut s = base_settings();
    s.faceting = Faceting::None;
    let plain = render_plain(&prep, &s);
    for faceting in [Faceting::Voronoi, Faceting::Patch] {
        for imprecision in [Imprecision::Saliency, Imprecision::Random] {
            let mut f = base_settings();
            f.faceting = faceting;
            f.imprecision = imprecision;
            f.discontinuity = 0.0;
            let r = render_sal(&prep, &f, SALIENT);
            assert_eq!(r.film.color, plain.film.color, "{faceting} {imprecision}");
            assert_eq!(r.image, plain.image);
            assert!(!stages(&r).contains(&"re-trace") && !stages(&r).contains(&"imprecision"), "{:?}", stages(&r));
            assert!(stages(&r).contains(&"faceting"));
        }
    }
    assert!(!stages(&plain).contains(&"faceting"), "{:?}", stages(&plain));
}

#[test]
fn only_moved_facets_are_retraced_and_zero_saliency_facets_stay() {
    let prep = still_life();
    let mut s = base_settings();
    s.faceting = Faceting::None;
    let plain = render_plain(&prep, &s);
    let mut f = base_settings();
    f.discontinuity = 150.0;
    let r = render_sal(&prep, &f, SALIENT);
    assert!(stages(&r).contains(&"re-trace"));
    let m = &r.facets;
    let moved = r.aims.iter().filter(|a| a.moved()).count();
    let still = r.aims.iter().filter(|a| a.fc.is_some() && !a.moved()).count();
    assert!(moved >= 3 && still >= 10, "moved {moved}, still {still}");
    let mut changed = 0;
    for (i, &id) in m.ids.iter().enumerate() {
        let a = &r.aims[id as usize];
        if !a.moved() {
            assert_eq!(r.film.color[i], plain.film.color[i], "pixel {i} of unmoved facet {id}");
            // A facet that did not move had no saliency: its saliency centre is its centre.
            assert_eq!(a.sc_raw, a.fc);
        } else if r.film.color[i] != plain.film.color[i] {
            changed += 1;
        }
    }
    assert!(changed > 100, "{changed} pixels of moved facets changed");
}

#[test]
fn saliency_reaiming_shows_more_salient_points_than_random_or_none() {
    let prep = still_life();
    let sal = bump(&prep, SALIENT);
    let mut means = Vec::new();
    for imprecision in [Imprecision::Saliency, Imprecision::Random, Imprecision::None] {
        let mut s = base_settings();
        s.width = 200;
        s.height = 150;
        s.discontinuity = 100.0;
        s.imprecision = imprecision;
        let r = render_sal(&prep, &s, SALIENT);
        means.push(mean_saliency(&prep, &r, &sal));
    }
    eprintln!("mean saliency of hit points: saliency {:.4}, random {:.4}, none {:.4}", means[0], means[1], means[2]);
    assert!(means[0] > 1.2 * means[1] && means[0] > 1.2 * means[2], "{means:?}");
}

#[test]
fn border_colour_difference_rises_with_discontinuity() {
    let prep = still_life();
    let measure = |imprecision, d| {
        let mut s = base_settings();
        s.discontinuity = d;
        s.imprecision = imprecision;
        border_difference(&render_sal(&prep, &s, SALIENT))
    };
    // Random: the aim point's distance scales with the discontinuity, so the difference rises
    // strictly. Saliency: it rises while the limit binds, then stays once every saliency
    // centre is within reach (at 160x120 a facet's saliency centre is at most ~10 px = 70 px
    // at 1000 px from its centre).
    let random: Vec<f64> = [0.0, 50.0, 100.0, 200.0].iter().map(|&d| measure(Imprecision::Random, d)).collect();
    let saliency: Vec<f64> =
        [0.0, 12.5, 25.0, 50.0, 200.0].iter().map(|&d| measure(Imprecision::Saliency, d)).collect();
    eprintln!("border difference, random at 0/50/100/200: {random:.4?}; saliency at 0/12.5/25/50/200: {saliency:.4?}");
    assert!(random.windows(2).all(|w| w[1] > w[0]), "{random:?}");
    assert!(saliency[..4].windows(2).all(|w| w[1] > w[0]), "{saliency:?}");
    assert!(saliency[4] >= saliency[3], "{saliency:?}");
}

/// A procedural single object (an ellipsoid of 1536 triangles), like the meshes of Table 4.1.
fn ellipsoid_scene() -> Prepared {
    use cubist::scene::{Object, Scene, default::ellipsoid};
    let mut scene = Scene { source: "<ellipsoid>".into(), ..Scene::default() };
    scene.materials.push(Default::default());
    scene.meshes.push(ellipsoid("blob", Vec3::new(1.0, 0.8, 0.7), 24, 32, 0));
    scene.objects.push(Object { name: "blob".into(), mesh: 0, transform: glam::DMat4::IDENTITY });
    Prepared::new(scene)
}

#[test]
fn visible_faces_rise_with_ambiguity() {
    let prep = ellipsoid_scene();
    let counts: Vec<usize> = [60.0, 140.0, 240.0, 360.0]
        .iter()
        .map(|&a| {
            let mut s = base_settings();
            s.width = 200;
            s.height = 150;
            s.camera = CameraKind::Spherical;
            s.ambiguity = Some(a);
            s.discontinuity = 100.0;
            s.imprecision = Imprecision::Random;
            let r = render_plain(&prep, &s);
            assert!(stages(&r).contains(&"re-trace"));
            cubist::eval::count_visible(&r.film, prep.world.triangle_count()).visible
        })
        .collect();
    eprintln!("visible faces of 1536 at ambiguity 60/140/240/360 (faceted, re-aimed): {counts:?}");
    assert!(counts.windows(2).all(|w| w[1] > w[0]), "{counts:?}");
}

#[test]
fn same_seed_same_image_on_any_thread_count() {
    let prep = still_life();
    for faceting in [Faceting::Voronoi, Faceting::Patch] {
        let mut s = base_settings();
        s.faceting = faceting;
        s.discontinuity = 120.0;
        s.facet_projection = FacetProjection::Linear;
        s.facet_fov = 20.0;
        let a = render_sal(&prep, &s, SALIENT);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let b = pool.install(|| render_sal(&prep, &s, SALIENT));
        assert_eq!(a.film.color, b.film.color, "{faceting}");
        assert_eq!(a.facets, b.facets);
        s.seed += 1;
        let c = render_sal(&prep, &s, SALIENT);
        assert_ne!(a.facets, c.facets, "another seed, other facets");
    }
}

#[test]
fn saved_then_loaded_layouts_give_the_identical_image() {
    let prep = still_life();
    let dir = tempfile::tempdir().unwrap();
    for faceting in [Faceting::Voronoi, Faceting::Patch] {
        for ext in ["json", "png"] {
            for imprecision in [Imprecision::Saliency, Imprecision::Random] {
                let path = dir.path().join(format!("layout-{faceting}.{ext}"));
                let mut s = base_settings();
                s.faceting = faceting;
                s.discontinuity = 100.0;
                s.imprecision = imprecision;
                s.save_facets = Some(path.clone());
                let first = render_sal(&prep, &s, SALIENT);
                assert!(path.exists());
                let mut t = s.clone();
                t.save_facets = None;
                t.facets = Some(path.clone());
                // The layout replaces the method: another seed or method changes nothing.
                t.faceting = Faceting::None;
                t.facet_count = 7;
                let again = render_sal(&prep, &t, SALIENT);
                assert_eq!(first.facets, again.facets, "{faceting} {ext}");
                assert_eq!(first.film.color, again.film.color, "{faceting} {ext} {imprecision}");
            }
        }
    }
}

#[test]
fn json_layouts_rasterise_at_any_resolution() {
    // A layout saved at one size renders a bigger frame with the same facets, scaled.
    let prep = still_life();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("v.json");
    let mut s = base_settings();
    s.save_facets = Some(path.clone());
    let small = render_plain(&prep, &s);
    let mut t = base_settings();
    t.width *= 2;
    t.height *= 2;
    t.facets = Some(path);
    let big = render_plain(&prep, &t);
    let (ms, mb) = (small.facets, big.facets);
    let mut same = 0;
    for y in 0..ms.height {
        for x in 0..ms.width {
            same += (ms.ids[(y * ms.width + x) as usize] == mb.ids[(2 * y * mb.width + 2 * x + 1) as usize]) as u32;
        }
    }
    assert!(same as f64 > 0.97 * ms.ids.len() as f64, "{same} of {}", ms.ids.len());
}

fn write_map(path: &Path, w: u32, h: u32, f: impl Fn(u32, u32) -> [u8; 3]) {
    image::RgbImage::from_fn(w, h, |x, y| image::Rgb(f(x, y))).save(path).unwrap();
}

#[test]
fn constant_facet_maps_with_one_pixel_facets_and_background_facets() {
    let prep = still_life();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("map.png");
    // At the render's size: the top-left 20x12 block is one facet of background only; the
    // 8x8 block at (76, 60) is 64 one-pixel facets; the rest splits into 4 quarters.
    write_map(&path, 160, 120, |x, y| {
        if x < 20 && y < 12 {
            [1, 2, 3]
        } else if (76..84).contains(&x) && (60..68).contains(&y) {
            [200, (x - 76) as u8 * 8, (y - 60) as u8 * 8]
        } else {
            [(x >= 80) as u8 * 100, (y >= 60) as u8 * 100, 50]
        }
    });
    let mut s = base_settings();
    s.faceting = Faceting::Constant;
    s.facet_map = Some(path);
    s.discontinuity = 200.0;
    s.imprecision = Imprecision::Random;
    s.facet_projection = FacetProjection::Linear;
    let r = render_sal(&prep, &s, SALIENT);
    let m = &r.facets;
    assert_eq!(m.facet_count, 1 + 4 + 64);
    assert!(r.film.color.iter().all(|c| c.is_finite()));
    // Facet 0 (the background block) is hit by none of its rays: its linear facet is left
    // as it is, but the random re-aim still turns it.
    assert!(r.aims[0].linear.is_none());
    // Every one-pixel facet has its pixel centre as facet centre, and is re-aimed.
    let ones: Vec<_> =
        (0..m.facet_count as usize).filter(|&f| m.ids.iter().filter(|&&i| i as usize == f).count() == 1).collect();
    assert_eq!(ones.len(), 64);
    for f in ones {
        let i = m.ids.iter().position(|&id| id as usize == f).unwrap() as u32;
        let centre = DVec2::new((i % 160) as f64 + 0.5, (i / 160) as f64 + 0.5);
        assert_eq!(r.aims[f].fc, Some(centre));
        assert!(r.aims[f].moved());
    }
}

#[test]
fn a_facet_whose_centre_lies_outside_it_is_re_aimed_as_a_whole() {
    let prep = still_life();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ring.json");
    let ring = FacetPolygon {
        facet: 1,
        points: vec![
            [0.2, 0.2],
            [0.8, 0.2],
            [0.8, 0.8],
            [0.2, 0.8],
            [0.2, 0.2],
            [0.35, 0.35],
            [0.35, 0.65],
            [0.65, 0.65],
            [0.65, 0.35],
            [0.35, 0.35],
        ],
    };
    let layout = FacetLayout {
        facet_count: 2,
        base: Some(LabelImage { width: 1, height: 1, labels: vec![0] }),
        sites: vec![],
        polygons: vec![ring],
    };
    std::fs::write(&path, cubist::facets::io::to_json(&layout)).unwrap();
    let mut s = base_settings();
    s.faceting = Faceting::None;
    let plain = render_plain(&prep, &s);
    s.facets = Some(path);
    s.discontinuity = 200.0;
    s.imprecision = Imprecision::Saliency;
    let r = render_sal(&prep, &s, SALIENT);
    let m = &r.facets;
    let fc = r.aims[1].fc.unwrap();
    assert_eq!(m.ids[fc.y as usize * 160 + fc.x as usize], 0, "the ring's centre lies in its hole");
    assert!(r.aims[1].moved() && r.aims[1].target.is_some());
    // The whole ring turned (its pixels changed on both sides of the hole); facet 0 moved too
    // or not, but nothing is NaN.
    let changed = |x0: u32, x1: u32| {
        (0..120u32)
            .flat_map(|y| (x0..x1).map(move |x| (y * 160 + x) as usize))
            .filter(|&i| m.ids[i] == 1 && r.film.color[i] != plain.film.color[i])
            .count()
    };
    assert!(changed(32, 56) > 50 && changed(104, 128) > 50, "{} {}", changed(32, 56), changed(104, 128));
    assert!(r.film.color.iter().all(|c| c.is_finite()));
}

#[test]
fn a_saliency_centre_on_the_background_aims_at_the_focal_point_of_its_ray() {
    let prep = still_life();
    let s = base_settings();
    let framed = frame_camera(&cubist::pipeline::params::framing(&s), &prep.world, &prep.accel).unwrap();
    let ctx = AimContext {
        camera: framed.camera.as_ref(),
        accel: &prep.accel,
        width: s.width,
        height: s.height,
        clip_radius: prep.world.radius as f64 * 1.001,
        up: framed.frame.up,
    };
    // The top-left corner of the still life is background.
    let (fc, sc) = (DVec2::new(80.5, 60.5), DVec2::new(2.5, 2.5));
    let ray = ctx.ray_at(sc);
    assert!(prep.accel.closest(ray.origin, ray.dir, 0.0, f32::INFINITY).is_none());
    let (reaim, target) = ctx.reaim(fc, sc).unwrap();
    let focal = ray.surface_origin() + ray.dir.as_dvec3() * ray.surface_focus();
    assert!((target.unwrap() - focal).length() < 1e-4);
    // The facet-centre ray now passes through that point.
    let c = reaim.apply(&ctx.ray_at(fc), ctx.clip_radius);
    let o = c.surface_origin();
    let along = (focal - o).dot(c.dir.as_dvec3());
    assert!((o + c.dir.as_dvec3() * along - focal).length() < 1e-4);
}

#[test]
fn a_facet_aimed_at_its_own_focal_point_is_not_re_traced() {
    // Regression: with a spherical camera every ray converges on one focal point, so a
    // saliency centre on the background aims a facet at the point its centre ray already passes
    // through (no turn); f32 rounding left a turn of ~3e-8 and the facet was re-traced into the
    // same pixels (80% of a 1000 px bunny_2k render at discontinuity 50).
    let prep = still_life();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("corner.json");
    // Facet 1: the top-left quarter, whose corner is background.
    let corner = FacetPolygon { facet: 1, points: vec![[0.0, 0.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]] };
    let layout = FacetLayout {
        facet_count: 2,
        base: Some(LabelImage { width: 1, height: 1, labels: vec![0] }),
        sites: vec![],
        polygons: vec![corner],
    };
    std::fs::write(&path, cubist::facets::io::to_json(&layout)).unwrap();
    let mut s = base_settings();
    s.camera = CameraKind::Spherical;
    s.faceting = Faceting::None;
    let plain = render_plain(&prep, &s);
    assert!(!plain.film.hits[2 * 160 + 2].is_hit(), "pixel (2, 2) must be background");
    s.facets = Some(path);
    s.discontinuity = 200.0;
    s.imprecision = Imprecision::Saliency;
    // All the saliency on one background pixel of facet 1: its saliency centre is that pixel.
    let r = render_with(&prep, &s, &Progress::silent(), &|_, f| {
        let mut m = vec![0.0; f.pixel_count()];
        m[2 * 160 + 2] = 1.0;
        f.saliency = Some(m);
    })
    .unwrap();
    let a = r.aims[1];
    assert_eq!(a.sc_raw, Some(DVec2::new(2.5, 2.5)));
    // The discontinuity limit (27.7 px here) keeps the aim point on the background.
    let sc = a.sc.unwrap();
    assert!(!plain.film.hits[sc.y as usize * 160 + sc.x as usize].is_hit(), "{sc:?} is not background");
    assert!(a.sc != a.fc && a.target.is_some(), "{a:?}");
    assert!(!a.moved(), "a turn of {:?} re-aims nothing", a.reaim.map(|r| r.turn.length()));
    assert!(!stages(&r).contains(&"re-trace"), "{:?}", stages(&r));
    assert_eq!(r.film.color, plain.film.color);
    // The cylindrical camera's rays meet on a line, not a point: there the same aim turns the facet.
    s.camera = CameraKind::Cylindrical;
    let r = render_with(&prep, &s, &Progress::silent(), &|_, f| {
        let mut m = vec![0.0; f.pixel_count()];
        m[2 * 160 + 2] = 1.0;
        f.saliency = Some(m);
    })
    .unwrap();
    assert!(r.aims[1].moved() && stages(&r).contains(&"re-trace"));
}

#[test]
fn every_camera_reaims_without_nan_and_is_exact_at_discontinuity_zero() {
    let prep = still_life();
    for (camera, ambiguity) in [
        (CameraKind::Spherical, Some(140.0)),
        (CameraKind::Cylindrical, Some(140.0)),
        (CameraKind::Planar, Some(90.0)),
        (CameraKind::Planar, Some(0.0)),
        (CameraKind::Perspective, Some(50.0)),
        (CameraKind::Orthographic, None),
    ] {
        for projection in [FacetProjection::Converging, FacetProjection::Linear] {
            let mut s = base_settings();
            s.camera = camera;
            s.ambiguity = ambiguity;
            s.facet_projection = projection;
            s.discontinuity = 150.0;
            s.imprecision = Imprecision::Random;
            let r = render_plain(&prep, &s);
            assert!(r.film.color.iter().all(|c| c.is_finite()), "{camera} {ambiguity:?} {projection}");
            assert!(r.film.hits.iter().filter(|h| h.is_hit()).count() > 500, "{camera} {ambiguity:?} {projection}");
        }
        let mut s = base_settings();
        s.camera = camera;
        s.ambiguity = ambiguity;
        s.discontinuity = 0.0;
        let mut plain = s.clone();
        plain.faceting = Faceting::None;
        assert_eq!(render_plain(&prep, &s).film.color, render_plain(&prep, &plain).film.color, "{camera}");
    }
}

#[test]
fn facet_passes() {
    let prep = still_life();
    let mut s = base_settings();
    s.discontinuity = 100.0;
    s.passes = vec![Pass::Facets, Pass::FacetIds];
    let r = render_sal(&prep, &s, SALIENT);
    let facets = &r.passes.iter().find(|(p, _)| p.as_str() == "facets").unwrap().1;
    assert_eq!(facets.dimensions(), (160, 120));
    // Facet centres are marked yellow, saliency centres red.
    assert!(facets.pixels().any(|p| p.0 == [255, 215, 0, 255]));
    assert!(facets.pixels().any(|p| p.0 == [230, 30, 30, 255]));
    let ids = &r.passes16.iter().find(|(p, _)| p.as_str() == "facet-ids").unwrap().1;
    let m = &r.facets;
    assert!(ids.pixels().zip(&m.ids).all(|(p, &id)| p.0[0] as u32 == id));
}
