//! The stage cache (`pipeline::Session`): at every invalidation level, a render that
//! reuses kept outputs gives exactly the pixels (image and passes) and warnings of a fresh
//! `render` of the same scene and settings, and re-runs only the stages the change reaches.

use cubist::pipeline::{Frame, Session};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::{BorderStyle, CameraKind, FacetProjection, Faceting, Imprecision, Palette, Pass};
use cubist::{Prepared, Settings};

fn base() -> Settings {
    Settings { width: 120, height: 90, spp: 2, passes: vec![], ..Settings::default() }
}

/// Renders `s` in the session and fresh (a new `Prepared` of `scene`), and checks they agree
/// bit for bit; returns the session's steps reused.
fn same(session: &mut Session, scene: &Scene, s: &Settings, what: &str) -> Vec<&'static str> {
    let frame = session.render(s, &Progress::silent()).unwrap_or_else(|e| panic!("{what}: {e}"));
    let fresh = cubist::render(&Prepared::new(scene.clone()), s, &Progress::silent()).unwrap();
    check(&frame, &fresh, what);
    frame.reused
}

fn check(frame: &Frame, fresh: &cubist::Rendered, what: &str) {
    assert!(frame.image == fresh.image, "{what}: the image differs from a fresh render's");
    assert_eq!(frame.passes.len(), fresh.passes.len(), "{what}");
    for ((p, a), (q, b)) in frame.passes.iter().zip(&fresh.passes) {
        assert_eq!(p, q, "{what}");
        assert!(a == b, "{what}: pass {p:?} differs");
    }
    for ((p, a), (q, b)) in frame.passes16.iter().zip(&fresh.passes16) {
        assert_eq!(p, q, "{what}");
        assert!(a == b, "{what}: pass {p:?} differs");
    }
    assert_eq!(frame.warnings, fresh.warnings, "{what}");
    assert_eq!(frame.camera, fresh.camera, "{what}");
}

const ALL: [&str; 8] =
    ["pre-render", "saliency", "faceting", "imprecision", "re-trace", "anti-aliasing", "paint", "encode"];

fn reused_up_to(last: &str) -> Vec<&'static str> {
    let n = ALL.iter().position(|s| *s == last).unwrap();
    ALL[..=n].to_vec()
}

#[test]
fn each_change_reruns_only_what_it_invalidates_and_gives_a_fresh_renders_pixels() {
    let scene = Scene::default_scene();
    let mut session = Session::new();
    assert!(session.set_scene(scene.clone()).changed);
    let s = base();
    assert_eq!(same(&mut session, &scene, &s, "first"), Vec::<&str>::new());
    assert_eq!(same(&mut session, &scene, &s, "unchanged"), ALL.to_vec());

    // Painterly: paint only.
    let paint = Settings { border_width: 9.0, palette: Palette::BluePeriod, colors: 6, ..s.clone() };
    assert_eq!(same(&mut session, &scene, &paint, "painterly"), reused_up_to("anti-aliasing"));
    let chiaro = Settings { chiaroscuro: 0.7, gradients: 0.5, ..paint.clone() };
    assert_eq!(same(&mut session, &scene, &chiaro, "chiaroscuro"), reused_up_to("anti-aliasing"));

    // Imprecision: aims onwards.
    let aim = Settings { discontinuity: 80.0, ..chiaro.clone() };
    assert_eq!(same(&mut session, &scene, &aim, "discontinuity"), reused_up_to("faceting"));

    // Facets: faceting onwards (a facet change that changes the facets: the Segment faceting
    // instead of the default Planes).
    let facet =
        Settings { faceting: Faceting::Segment, segments: vec![4, 12], thresholds: vec![0.0, 0.3], ..aim.clone() };
    assert_eq!(same(&mut session, &scene, &facet, "segments"), reused_up_to("saliency"));
    let voronoi = Settings { faceting: Faceting::Voronoi, facet_count: 30, ..facet.clone() };
    assert_eq!(same(&mut session, &scene, &voronoi, "voronoi"), reused_up_to("saliency"));

    // Camera: pre-render onwards, but a layout that does not follow the picture stays.
    let camera = Settings { ambiguity: Some(110.0), ..voronoi.clone() };
    assert_eq!(same(&mut session, &scene, &camera, "camera (voronoi)"), vec!["faceting"]);
    let camera = Settings { ambiguity: Some(120.0), ..s.clone() };
    assert_eq!(same(&mut session, &scene, &camera, "camera (segment)"), Vec::<&str>::new());

    // Passes: encoding only, unless a pass needs the saliency map a render did not compute.
    let passes = Settings { passes: vec![Pass::Depth, Pass::Normals, Pass::FacetIds, Pass::Segments], ..camera };
    assert_eq!(same(&mut session, &scene, &passes, "passes"), reused_up_to("paint"));
    let random = Settings { faceting: Faceting::Patch, imprecision: Imprecision::Random, ..passes.clone() };
    same(&mut session, &scene, &random, "patch, random");
    let with_saliency = Settings { passes: vec![Pass::Saliency, Pass::Facets, Pass::Objects], ..random };
    let reused = same(&mut session, &scene, &with_saliency, "saliency passes");
    assert!(reused.contains(&"faceting") && reused.contains(&"imprecision"), "{reused:?}");
}

#[test]
fn a_facet_change_keeps_the_pixels_whose_rays_and_neighbours_did_not_change() {
    // The default faceting (Planes): one plane more or less redraws a few facets, the others
    // keep their pixels and aims, so most pixels keep their re-trace and anti-aliasing;
    // another detail redraws every facet. Each step gives a fresh render's pixels.
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let s = Settings { width: 200, height: 150, spp: 2, passes: vec![], ..Settings::default() };
    same(&mut session, &scene, &s, "first");
    let mut kept = Vec::new();
    for (planes, plane_detail) in [(91, 12.0), (90, 12.0), (90, 12.5), (89, 12.5), (90, 12.0)] {
        let c = Settings { planes, plane_detail, ..s.clone() };
        let what = format!("planes {planes}, detail {plane_detail}");
        let frame = session.render(&c, &Progress::silent()).unwrap();
        let fresh = cubist::render(&Prepared::new(scene.clone()), &c, &Progress::silent()).unwrap();
        check(&frame, &fresh, &what);
        assert_eq!(frame.reused, vec!["pre-render", "saliency"], "{what}");
        let k = frame.pixels_kept;
        assert!(k.retrace_kept + k.retrace_traced > 0 && k.antialiasing_kept + k.antialiasing_traced > 0, "{what}");
        kept.push(k);
    }
    assert!(kept[0].retrace_kept > kept[0].retrace_traced, "{kept:?}");
    assert!(kept[0].antialiasing_kept > kept[0].antialiasing_traced, "{kept:?}");
    assert!(kept.iter().any(|k| k.retrace_traced > 0 && k.antialiasing_traced > 0), "{kept:?}");
    // A setting the faceting method does not read gives the same facets: every later stage
    // is kept.
    let unread = Settings { planes: 90, plane_detail: 12.0, segments: vec![5, 31, 120], ..s.clone() };
    let mut all_but_faceting = ALL.to_vec();
    all_but_faceting.retain(|s| *s != "faceting");
    assert_eq!(same(&mut session, &scene, &unread, "segments under Planes"), all_but_faceting);
}

#[test]
fn the_planes_inputs_kept_per_pre_render_give_a_fresh_renders_facets() {
    // A session makes what the Planes faceting reads of the pre-render (the density's cues
    // and the outlines) once per pre-render and outlines setting: another plane count,
    // detail, seed or outlines setting, and a camera change (a new pre-render), each give a
    // fresh render's pixels, and the facet map is the layout rasterised.
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let s = Settings { width: 160, height: 120, spp: 2, passes: vec![Pass::FacetIds], ..Settings::default() };
    same(&mut session, &scene, &s, "first");
    let lane = |session: &Session| session.stats().lanes[0].outputs.clone();
    assert!(lane(&session).contains(&"faceting inputs"), "{:?}", lane(&session));
    let steps = [
        ("detail 6", Settings { plane_detail: 6.0, ..s.clone() }),
        ("no outlines", Settings { plane_detail: 6.0, plane_outlines: false, ..s.clone() }),
        ("no outlines, 90 planes", Settings { planes: 90, plane_outlines: false, ..s.clone() }),
        ("outlines again, seed 3", Settings { planes: 90, seed: 3, ..s.clone() }),
        ("camera", Settings { planes: 90, seed: 3, ambiguity: Some(120.0), ..s.clone() }),
        ("camera, detail 2", Settings { planes: 90, seed: 3, plane_detail: 2.0, ambiguity: Some(120.0), ..s.clone() }),
    ];
    for (what, c) in steps {
        same(&mut session, &scene, &c, what);
        let (layout, map, _) = session.facets(c.width, c.height).expect("facets kept");
        assert!(*map == layout.rasterize(c.width, c.height), "{what}: the map is the layout rasterised");
        assert!(map.facet_count > 1, "{what}");
    }
}

#[test]
fn each_painterly_setting_of_issue_13_reruns_paint_only() {
    // Per-plane light, passage, brushwork and canvas: each one alone re-runs paint only, and
    // each changes the picture (else a key that missed it would go unnoticed). 720x540: the
    // canvas weave fades out on smaller images.
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let mut last = Settings { width: 720, height: 540, spp: 1, ..base() };
    // The default preset, Analytic, has them all on.
    assert!(last.brushwork > 0.0 && last.canvas_grain > 0.0 && last.border_style == BorderStyle::Passage);
    type Change = (&'static str, fn(&mut Settings));
    let painterly: [Change; 6] = [
        ("plane_light", |s| s.plane_light = 0.3),
        ("border_style", |s| s.border_style = BorderStyle::Symmetric),
        ("brushwork", |s| s.brushwork = 0.4),
        ("stroke_length", |s| s.stroke_length = 40.0),
        ("stroke_width", |s| s.stroke_width = 12.0),
        ("canvas_grain", |s| s.canvas_grain = 0.2),
    ];
    let mut before = session.render(&last, &Progress::silent()).unwrap().image;
    for (what, change) in painterly {
        let mut next = last.clone();
        change(&mut next);
        // spp 1: no anti-aliasing stage.
        assert_eq!(same(&mut session, &scene, &next, what), reused_up_to("re-trace"), "{what}");
        let after = session.render(&next, &Progress::silent()).unwrap().image;
        assert!(before != after, "{what}: the picture did not change");
        (before, last) = (after, next);
    }
}

#[test]
fn sizes_keep_their_own_outputs() {
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let full = base();
    let quarter = Settings { width: 30, height: 22, ..full.clone() };
    let half = Settings { width: 60, height: 45, ..full.clone() };
    for s in [&quarter, &half, &full] {
        assert!(same(&mut session, &scene, s, "first pass").is_empty());
    }
    // The viewport's next change: each size re-runs paint only.
    for s in [&quarter, &half, &full] {
        let paint = Settings { border_width: 5.0, ..(*s).clone() };
        assert_eq!(same(&mut session, &scene, &paint, "paint pass"), reused_up_to("anti-aliasing"));
    }
    let stats = session.stats();
    assert_eq!(stats.lanes.iter().map(|l| (l.width, l.height)).collect::<Vec<_>>(), [(120, 90), (60, 45), (30, 22)]);
    assert!(stats.bytes > 0 && stats.lanes.iter().all(|l| l.outputs.contains(&"pre-render")));
    // A budget of one byte keeps only the size in use.
    let mut small = Session::new().with_budget(1);
    small.set_scene(scene.clone());
    for s in [&quarter, &full] {
        small.render(s, &Progress::silent()).unwrap();
    }
    assert_eq!(small.stats().lanes.len(), 1);
}

#[test]
fn other_projections_and_a_transparent_background_agree_with_fresh_renders() {
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let linear = Settings { facet_projection: FacetProjection::Linear, facet_fov: 20.0, ..base() };
    same(&mut session, &scene, &linear, "linear facets");
    let transparent = Settings { transparent: true, silhouette_width: 6.0, ..linear.clone() };
    same(&mut session, &scene, &transparent, "transparent");
    let plain = Settings { faceting: Faceting::None, camera: CameraKind::Perspective, ..transparent };
    same(&mut session, &scene, &plain, "unfaceted perspective");
}

#[test]
fn a_new_scene_keeps_what_its_content_allows() {
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let s = base();
    same(&mut session, &scene, &s, "first");

    // The same content again: nothing changes, every output is kept.
    let again = session.set_scene(scene.clone());
    assert!(!again.changed);
    assert_eq!(same(&mut session, &scene, &s, "same scene"), ALL.to_vec());

    // A material changed: the BVH stays, the pre-render runs again.
    let mut lit = scene.clone();
    lit.materials[0].base_color *= 0.5;
    let u = session.set_scene(lit.clone());
    assert!(u.changed && !u.bvh_rebuilt && u.meshes_changed == 0, "{u:?}");
    assert!(same(&mut session, &lit, &s, "material").is_empty());

    // An object moved: the BVH is rebuilt, no mesh changed (their saliency is kept).
    let mut moved = lit.clone();
    moved.objects[2].transform.w_axis.y += 0.1;
    let u = session.set_scene(moved.clone());
    assert!(u.changed && u.bvh_rebuilt && u.meshes_changed == 0, "{u:?}");
    let kept = session.stats().saliency_meshes;
    assert!(kept > 0);
    same(&mut session, &moved, &s, "moved object");

    // A mesh edited: that mesh alone is new.
    let mut edited = moved.clone();
    let m = edited.objects[2].mesh;
    for p in &mut edited.meshes[m].positions {
        p.x *= 1.2;
    }
    let u = session.set_scene(edited.clone());
    assert!(u.bvh_rebuilt && u.meshes_changed == 1, "{u:?}");
    same(&mut session, &edited, &s, "edited mesh");
    assert!(session.stats().saliency_meshes <= kept + 1);
}

#[test]
fn a_cancelled_render_keeps_nothing_half_done() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let s = base();
    same(&mut session, &scene, &s, "first");
    // Cancelled as each stage starts: the render fails with `cancelled`, and the next render
    // (which re-runs what the cancel stopped) still matches a fresh one.
    let changed = Settings { ambiguity: Some(100.0), ..s.clone() };
    for stage in ["pre-render", "saliency", "faceting", "imprecision", "re-trace", "anti-aliasing", "paint"] {
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        let progress = Progress::new(Box::new(move |name, _| {
            if name == stage {
                f.store(true, Ordering::Relaxed);
            }
        }))
        .with_cancel(flag);
        let err = session.render(&changed, &progress).err().map(|e| e.to_string());
        assert_eq!(err.as_deref(), Some("cancelled"), "cancelled at {stage}");
        same(&mut session, &scene, &changed, &format!("after a cancel at {stage}"));
        same(&mut session, &scene, &s, &format!("back, after a cancel at {stage}"));
    }
}

#[test]
fn a_session_without_a_scene_says_so() {
    let err = Session::new().render(&base(), &Progress::silent()).err().unwrap().to_string();
    assert!(err.contains("no scene"), "{err}");
}

#[test]
fn a_paint_only_change_resumes_the_chain_before_the_first_effect_it_changes() {
    // The session keeps the canvas before the first effect whose parameters changed (the
    // analytic chain: chiaroscuro, passage, palette, plane light, brushwork, canvas grain)
    // and paints the next change of that effect from there: the pixels stay a fresh render's
    // through changes of later, earlier and first effects, a transparent background, and a
    // facet change (another film under the kept canvas).
    let scene = Scene::default_scene();
    let mut session = Session::new();
    session.set_scene(scene.clone());
    let s = Settings { width: 200, height: 150, spp: 1, ..base() };
    let prefix = |session: &Session| session.stats().lanes[0].outputs.contains(&"paint prefix");
    same(&mut session, &scene, &s, "first");
    assert!(!prefix(&session), "nothing changed yet: nothing kept part-way");
    let steps: Vec<(&str, Settings)> = vec![
        ("brushwork 0.5", Settings { brushwork: 0.5, ..s.clone() }),
        ("brushwork 0.6", Settings { brushwork: 0.6, ..s.clone() }),
        ("brushwork 0.5 again", Settings { brushwork: 0.5, ..s.clone() }),
        ("canvas grain", Settings { brushwork: 0.5, canvas_grain: 0.9, ..s.clone() }),
        ("border width", Settings { border_width: 9.0, ..s.clone() }),
        ("border width again", Settings { border_width: 10.0, ..s.clone() }),
        ("brushwork after a border change", Settings { border_width: 10.0, brushwork: 0.3, ..s.clone() }),
        ("chiaroscuro (the first effect)", Settings { chiaroscuro: 0.6, ..s.clone() }),
        ("chiaroscuro again", Settings { chiaroscuro: 0.5, ..s.clone() }),
        ("plane light (passage reads it too)", Settings { plane_light: 0.4, ..s.clone() }),
        ("seed (every effect)", Settings { seed: 7, ..s.clone() }),
        ("transparent", Settings { transparent: true, ..s.clone() }),
        ("transparent, brushwork", Settings { transparent: true, brushwork: 0.4, ..s.clone() }),
        ("transparent, brushwork again", Settings { transparent: true, brushwork: 0.2, ..s.clone() }),
        ("opaque, brushwork", Settings { brushwork: 0.2, ..s.clone() }),
        ("facet change", Settings { brushwork: 0.3, segments: vec![5, 20, 80], ..s.clone() }),
        ("facet change, brushwork", Settings { brushwork: 0.4, segments: vec![5, 20, 80], ..s.clone() }),
    ];
    let mut held = 0;
    for (what, next) in &steps {
        let reused = same(&mut session, &scene, next, what);
        // spp 1: no anti-aliasing stage; paint-only changes re-run paint alone.
        if !["seed", "transparent", "opaque", "facet"].iter().any(|w| what.starts_with(w)) {
            assert_eq!(reused, reused_up_to("re-trace"), "{what}");
        }
        held += prefix(&session) as usize;
    }
    // Once an effect changed, the canvas before it is kept (not after a change of the first
    // effect, whose canvas is the film's own, nor after a new film).
    assert!(held >= 10, "the canvas part-way was kept after {held} of {} changes", steps.len());
}
