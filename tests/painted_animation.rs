//! Painted animation (docs/animation.md): the `motion` pass carries each pixel onto the same
//! surface in the next frame, the still background stays byte for byte the same from frame to
//! frame, and the strokes anchored to the surfaces give a frame rendered alone the same bytes
//! as in a sequence, on any thread count.
//!
//! Tests marked `needs ../shared` read the glTF samples of ../shared
//! (`cargo test --release --test painted_animation -- --include-ignored`).

use std::path::{Path, PathBuf};
use std::process::Command;

use cubist::motion::{Rgba16, read_pass};
use cubist::pipeline::{FrameOutput, FramesParams, render_frames};
use cubist::progress::Progress;
use cubist::scene::animation::Choice;
use cubist::settings::Pass;
use cubist::{Prepared, Settings};

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared").join(rel)
}

fn frames(scene: Option<&Path>, settings: &Settings, params: &FramesParams) -> Vec<FrameOutput> {
    let prep = Prepared::load(scene).unwrap();
    let mut out = Vec::new();
    render_frames(&prep, settings, params, &Progress::silent(), &mut |f| {
        out.push(f);
        Ok(())
    })
    .unwrap();
    out
}

fn params(first: u32, last: u32, animation: Option<Choice>, orbit_deg: f64) -> FramesParams {
    FramesParams { animation, orbit_deg, measure: true, ..FramesParams::new(first, last) }
}

fn with_motion(w: u32, h: u32) -> Settings {
    Settings { width: w, height: h, passes: vec![Pass::Motion], ..Settings::default() }
}

/// Share of frame a's surface pixels whose point, moved by `motion` (this -> next, pixels),
/// lands on a pixel of frame b (or one of its 8 neighbours) showing the same triangle, over
/// the pixels whose point frame b shows somewhere.
fn landing_share(a: &FrameOutput, b: &FrameOutput, moved: bool) -> f64 {
    let (sa, sb) = (a.surface.as_ref().unwrap(), b.surface.as_ref().unwrap());
    let (w, h) = (sa.key.width as i64, sa.key.height as i64);
    let motion = read_pass(a.motion.as_ref().unwrap());
    let shown_in_b: std::collections::HashSet<u32> = sb.key.tri.iter().copied().collect();
    let (mut landed, mut n) = (0usize, 0usize);
    for (i, &tri) in sa.key.tri.iter().enumerate() {
        if tri == u32::MAX || !shown_in_b.contains(&tri) {
            continue;
        }
        let m = if moved { motion[i] } else { glam::Vec4::ZERO };
        let x = (i as i64 % w) as f32 + 0.5 + m.z;
        let y = (i as i64 / w) as f32 + 0.5 + m.w;
        let (x, y) = (x.floor() as i64, y.floor() as i64);
        n += 1;
        let near = (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy)));
        if near
            .filter(|&(x, y)| x >= 0 && y >= 0 && x < w && y < h)
            .any(|(x, y)| sb.key.tri[(y * w + x) as usize] == tri)
        {
            landed += 1;
        }
    }
    landed as f64 / n.max(1) as f64
}

/// A turntable of the built-in still life: each pixel moved by the pass lands on its own
/// triangle in the next frame, where staying put mostly does not. (Unfaceted, so the picture
/// shows what the pre-pass compared against shows: no facet re-aimed.)
#[test]
fn the_motion_pass_carries_each_pixel_onto_its_surface_in_the_next_frame() {
    let settings = Settings { faceting: cubist::settings::Faceting::None, ..with_motion(120, 90) };
    let out = frames(None, &settings, &params(1, 2, None, 6.0));
    let (moved, still) = (landing_share(&out[0], &out[1], true), landing_share(&out[0], &out[1], false));
    println!("turntable 6 deg/frame: {:.1}% land moved, {:.1}% unmoved", moved * 100.0, still * 100.0);
    // (Points hidden in the next frame, by the turn or another surface, count as missed: the
    // pass says where a point goes, not whether it is seen there. Measured: 86.5% against 63.3%.)
    assert!(moved > 0.8, "only {:.1}% of the pixels land on their triangle", moved * 100.0);
    assert!(moved > still + 0.1, "moving does not help: {moved} against {still}");
    // The previous -> this half of frame 2 undoes frame 1's this -> next half on average.
    let (m1, m2) = (read_pass(out[0].motion.as_ref().unwrap()), read_pass(out[1].motion.as_ref().unwrap()));
    let mean = |m: &[glam::Vec4], f: fn(&glam::Vec4) -> f32| m.iter().map(f).sum::<f32>() / m.len() as f32;
    let (next_x, prev_x) = (mean(&m1, |v| v.z), mean(&m2, |v| v.x));
    assert!(next_x.abs() > 0.1, "the turntable barely moves: {next_x}");
    assert!((next_x - prev_x).abs() < 0.25 * next_x.abs(), "{next_x} against {prev_x}");
}

#[test]
fn a_still_refuses_the_motion_pass() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_cubist"))
        .args(["render", "--width", "16", "--height", "16", "--pass", "motion", "-o"])
        .arg(dir.path().join("a.png"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("motion pass needs animation frames"), "{err}");
    assert!(!dir.path().join("a.png").exists());
}

fn cubist(args: &[&str], threads: usize) {
    let out = Command::new(env!("CARGO_BIN_EXE_cubist"))
        .arg("render")
        .args(args)
        .args(["--progress", "none"])
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .unwrap();
    assert!(out.status.success(), "cubist render {args:?}: {}", String::from_utf8_lossy(&out.stderr));
}

/// Frame 3 rendered alone on one thread has the bytes of frame 3 of a 1-3 run on two (its
/// picture and its motion pass), with strokes on the surfaces, static and following facets.
#[test]
#[ignore = "needs ../shared"]
fn a_frame_rendered_alone_equals_the_same_frame_of_a_sequence() {
    for extra in [&[][..], &["--facet-motion", "follow"][..]] {
        let dir = tempfile::tempdir().unwrap();
        let fox = shared("gltf-samples/Fox.glb");
        let common =
            [&[fox.to_str().unwrap(), "--width", "120", "--height", "90", "--pass", "motion"][..], extra].concat();
        let (run, alone) = (dir.path().join("run/f_#.png"), dir.path().join("alone/f_#.png"));
        cubist(&[&common[..], &["--frames", "1-3", "-o", run.to_str().unwrap()]].concat(), 2);
        cubist(&[&common[..], &["--frames", "3", "-o", alone.to_str().unwrap()]].concat(), 1);
        for name in ["f_3.png", "f_3.motion.png"] {
            let read = |d: &str| std::fs::read(dir.path().join(d).join(name)).unwrap();
            assert!(read("run") == read("alone"), "{extra:?}: {name} alone differs from the sequence's");
        }
    }
}

/// Pixels farther than `reach` from any pixel showing geometry, in both frames.
fn far_background(a: &FrameOutput, b: &FrameOutput, reach: i64) -> Vec<usize> {
    let (sa, sb) = (a.surface.as_ref().unwrap(), b.surface.as_ref().unwrap());
    let (w, h) = (sa.key.width as i64, sa.key.height as i64);
    let subject: Vec<bool> =
        sa.key.tri.iter().zip(&sb.key.tri).map(|(&x, &y)| x != u32::MAX || y != u32::MAX).collect();
    (0..(w * h) as usize)
        .filter(|&i| {
            let (x, y) = (i as i64 % w, i as i64 / w);
            !(-reach..=reach).any(|dy| {
                (-reach..=reach).any(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    xx >= 0 && yy >= 0 && xx < w && yy < h && subject[(yy * w + xx) as usize]
                })
            })
        })
        .collect()
}

/// Checks that every pixel of the background farther than a stroke's length (and a pixel) from
/// the subject, in both frames of each pair, keeps its bytes.
fn assert_still_background(label: &str, out: &[FrameOutput], settings: &Settings) {
    let reach = (settings.stroke_length * settings.width as f64 / 1000.0).ceil() as i64 + 1;
    for pair in out.windows(2) {
        let far = far_background(&pair[0], &pair[1], reach);
        assert!(far.len() > 1000, "{label}: too little background to compare: {}", far.len());
        let (a, b) = (pair[0].image.as_raw(), pair[1].image.as_raw());
        let changed = far.iter().filter(|&&i| a[4 * i..4 * i + 4] != b[4 * i..4 * i + 4]).count();
        let most = far.iter().flat_map(|&i| (4 * i..4 * i + 4).map(|k| a[k].abs_diff(b[k]))).max().unwrap_or(0);
        assert!(
            changed == 0,
            "{label}, frames {}-{}: {changed} of {} still background pixels changed, by up to {most}",
            pair[0].frame,
            pair[1].frame,
            far.len()
        );
    }
}

/// The fox walks over a still background: away from it (farther than a stroke's length), the
/// background keeps its bytes from frame to frame, with static facets and with facets that
/// follow: what a frame's own picture would decide for a background plane the fox walks into
/// (which planes open across the outline, a plane's mean colour the strokes go towards, its
/// hue) is held from the layout frame (`paint::Held`).
#[test]
#[ignore = "needs ../shared"]
fn the_still_background_keeps_its_bytes_from_frame_to_frame() {
    let fox = shared("gltf-samples/Fox.glb");
    for follow in [false, true] {
        let mut s = Settings { width: 160, height: 120, ..Settings::default() };
        if follow {
            s.facet_motion = cubist::settings::FacetMotion::Follow;
        }
        let out = frames(Some(&fox), &s, &params(1, 4, Some(Choice::Index(0)), 0.0));
        assert_still_background(&format!("fox, follow {follow}"), &out, &s);
    }
}

/// A turntable with facets that follow and a new key frame every second frame: the key
/// frames' planes of the still background are the layout's, so the background keeps its bytes
/// across a new key frame too (its planes made again from the new key frame's facets would
/// turn their ramps and strokes).
#[test]
fn the_still_background_keeps_its_bytes_across_new_key_frames() {
    let s = Settings {
        width: 160,
        height: 120,
        facet_motion: cubist::settings::FacetMotion::Follow,
        ..Settings::default()
    };
    let out = frames(None, &s, &FramesParams { rekey: 2, ..params(1, 4, None, 6.0) });
    assert_still_background("still life turntable, a key frame every 2", &out, &s);
}

/// The same on a cow turning under the camera: a new key frame re-plans the subject's planes,
/// and the still background's strokes keep their size (sized against the layout frame's median
/// plane, `paint::Held::plane_median`, not the new key frame's).
#[test]
#[ignore = "needs ../shared"]
fn the_still_background_keeps_its_stroke_sizes_across_new_key_frames() {
    let spot = shared("models/spot.glb");
    let s = Settings {
        width: 240,
        height: 180,
        facet_motion: cubist::settings::FacetMotion::Follow,
        ..Settings::default()
    };
    let out = frames(Some(&spot), &s, &FramesParams { rekey: 2, ..params(1, 5, None, 8.0) });
    assert_still_background("spot turntable, a key frame every 2", &out, &s);
}

/// The pass reads back as written (`Rgba16`, 16 bits a channel).
#[test]
fn the_motion_pass_is_sixteen_bit_rgba() {
    let out = frames(None, &with_motion(40, 30), &params(1, 1, None, 3.0));
    let m: &Rgba16 = out[0].motion.as_ref().unwrap();
    assert_eq!(m.dimensions(), (40, 30));
    assert!(read_pass(m).iter().any(|v| v.z != 0.0), "a turntable frame with no motion");
}
