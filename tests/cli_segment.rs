//! Segment faceting through the `cubist` binary: `cubist facets --pass segments` writes the
//! pre-render, each level and the layout (the thesis's Fig. 4.5); a render with
//! `--faceting segment` saves a layout that a later frame reuses; bad values are one-line
//! usage errors.

use std::path::Path;
use std::process::{Command, Output};

fn cubist(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cubist")).args(args).current_dir(dir).output().unwrap()
}

const SMALL: [&str; 6] = ["--width", "160", "--height", "120", "--spp", "1"];

#[test]
fn facets_command_writes_every_level_and_the_layout() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut args = vec!["facets", "-o", "f.png", "--pass", "segments", "--segments", "4,12", "--thresholds", "0,0"];
    args.extend_from_slice(&SMALL);
    args.extend_from_slice(&["--save-facets", "f.json", "--verbose"]);
    let o = cubist(&args, d);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    for name in ["f.png", "f.superpixels.png", "f.level1.png", "f.level2.png", "f.layout.png", "f.json"] {
        assert!(d.join(name).is_file(), "{name} missing: {stderr}");
    }
    assert!(!d.join("f.level3.png").exists());
    for name in ["f.png", "f.level1.png", "f.layout.png"] {
        let img = image::open(d.join(name)).unwrap();
        assert_eq!((img.width(), img.height()), (160, 120), "{name}");
    }
    // Thresholds 0: every segment is selected; the verbose report says so.
    assert!(stderr.contains("level N=4: 4 segments, 4 selected"), "{stderr}");
    assert!(stderr.contains("level N=12: 12 segments, 12 selected"), "{stderr}");
    // The saved layout is what a render reuses.
    let layout = cubist::facets::io::load(&d.join("f.json")).unwrap();
    assert_eq!(layout.facet_count, 16);
    assert_eq!(layout.polygons.len(), 16);
}

#[test]
fn a_segment_layout_saved_by_a_render_is_reused_identically() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut a = vec!["render", "-o", "a.png", "--faceting", "segment", "--save-facets", "l.json", "--pass", "segments"];
    a.extend_from_slice(&SMALL);
    let first = cubist(&a, d);
    assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
    assert!(d.join("a.segments.png").is_file());
    let mut b = vec!["render", "-o", "b.png", "--faceting", "segment", "--facets", "l.json"];
    b.extend_from_slice(&SMALL);
    let second = cubist(&b, d);
    assert!(second.status.success(), "{}", String::from_utf8_lossy(&second.stderr));
    let (x, y) = (image::open(d.join("a.png")).unwrap().to_rgba8(), image::open(d.join("b.png")).unwrap().to_rgba8());
    assert!(x == y, "the reused layout gives another image");
}

#[test]
fn bad_segment_settings_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (extra, want) in [
        (vec!["--weight-object", "1.5"], "weight_object"),
        (vec!["--weight-colour", "-1"], "weight_colour"),
        (vec!["--segments", "5,0", "--thresholds", "0,0"], "segments"),
        (vec!["--segments", "5,30", "--thresholds", "0"], "thresholds"),
        (vec!["-o", "out.jpg"], "png"),
    ] {
        let mut args = vec!["facets"];
        args.extend_from_slice(&SMALL);
        args.extend_from_slice(&extra);
        let o = cubist(&args, d);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(stderr.contains(want), "{extra:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{extra:?}: {stderr}");
        assert!(std::fs::read_dir(d).unwrap().next().is_none(), "{extra:?} left an output");
    }
}

#[test]
#[ignore = "needs ../shared"]
fn venus_segments() {
    let venus = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models/venus_11k.glb");
    assert!(venus.is_file(), "{} is absent: this test needs the shared test data", venus.display());
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec!["facets", venus.to_str().unwrap(), "-o", "v.png", "--verbose"];
    args.extend_from_slice(&SMALL);
    let o = cubist(&args, dir.path());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("level N=5: 5 segments"), "{stderr}");
    assert!(stderr.contains("level N=120: 120 segments"), "{stderr}");
    assert!(dir.path().join("v.layout.png").is_file());
}
