//! The facet flags through the `cubist` binary: layouts saved and reused across runs, passes
//! written beside the output, clear errors and exit codes for bad layouts.

use std::path::Path;
use std::process::{Command, Output};

fn cubist(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cubist")).args(args).current_dir(dir).output().unwrap()
}

const SMALL: [&str; 6] = ["--width", "96", "--height", "72", "--spp", "1"];

fn render(dir: &Path, out: &str, extra: &[&str]) -> Output {
    let mut args = vec!["render", "-o", out];
    args.extend_from_slice(&SMALL);
    args.extend_from_slice(extra);
    cubist(&args, dir)
}

#[test]
fn a_saved_layout_reused_gives_the_identical_image_and_passes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let common = ["--discontinuity", "150", "--imprecision", "random", "--seed", "4"];
    for (method, file) in [("voronoi", "l.json"), ("patch", "l.png")] {
        let mut a = vec!["--faceting", method, "--save-facets", file, "--pass", "facets", "--pass", "facet-ids"];
        a.extend_from_slice(&common);
        let first = render(d, "a.png", &a);
        assert!(first.status.success(), "{}", String::from_utf8_lossy(&first.stderr));
        // The same faceting: it says how the layout's planes are painted (open planes of the
        // planes faceting are one region).
        let mut b = vec!["--faceting", method, "--facets", file, "--verbose"];
        b.extend_from_slice(&common);
        let again = render(d, "b.png", &b);
        assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
        assert_eq!(std::fs::read(d.join("a.png")).unwrap(), std::fs::read(d.join("b.png")).unwrap(), "{method}");
        let stderr = String::from_utf8_lossy(&again.stderr);
        for stage in ["pre-render", "faceting", "imprecision", "re-trace"] {
            assert!(stderr.contains(stage), "--verbose shows {stage}: {stderr}");
        }
        let facets = image::open(d.join("a.facets.png")).unwrap();
        assert_eq!((facets.width(), facets.height()), (96, 72));
        match image::open(d.join("a.facet-ids.png")).unwrap() {
            image::DynamicImage::ImageLuma16(ids) => assert_eq!(ids.dimensions(), (96, 72)),
            other => panic!("facet-ids is {:?}, not 16-bit grey", other.color()),
        }
    }
}

#[test]
fn bad_layouts_and_segment_give_one_line_errors_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("corrupt.json"), "{\"format\": \"cubist-facet-layout\", \"version\": 1, \"facet").unwrap();
    std::fs::write(d.join("other.json"), "{\"width\": 3}").unwrap();
    for (args, code, want) in [
        (vec!["--facets", "missing.json"], 1, "missing.json"),
        (vec!["--facets", "corrupt.json"], 1, "corrupt.json"),
        (vec!["--facets", "other.json"], 1, "not a facet layout"),
        (vec!["--facets", "layout.txt"], 2, ".json or .png"),
        (vec!["--faceting", "segment", "--weight-object", "2"], 2, "weight_object"),
        (vec!["--faceting", "segment", "--segments", "5,30", "--thresholds", "0"], 2, "thresholds"),
        (vec!["--faceting", "constant"], 2, "facet map"),
        (vec!["--faceting", "constant", "--facet-map", "nope.png"], 1, "nope.png"),
        (vec!["--faceting", "voronoi", "--facet-count", "100000"], 2, "facet_count"),
    ] {
        let o = render(d, "out.png", &args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {stderr}");
        assert!(stderr.contains(want), "{args:?}: {stderr}");
        assert_eq!(stderr.trim().lines().count(), 1, "{args:?}: {stderr}");
        assert!(!d.join("out.png").exists(), "{args:?} left an output");
    }
}
