//! The `cubist` binary: the README's first command, flags and config, exit codes, one-line
//! errors and no partial output.

mod common;

use common::run;

#[test]
fn render_without_a_scene_writes_cubist_png() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, err) = run(dir.path(), &["render", "--width", "80", "--height", "60", "--spp", "1"]);
    assert_eq!(code, 0, "{err}");
    let img = image::open(dir.path().join("cubist.png")).unwrap().to_rgba8();
    assert_eq!(img.dimensions(), (80, 60));
    // Not blank: the still life has many colours.
    let mut colours: Vec<[u8; 4]> = img.pixels().map(|p| p.0).collect();
    colours.sort();
    colours.dedup();
    assert!(colours.len() > 50);
}

#[test]
fn help_lists_every_option_with_unit_and_default() {
    let dir = tempfile::tempdir().unwrap();
    let (code, out, _) = run(dir.path(), &["render", "--help"]);
    assert_eq!(code, 0);
    for flag in [
        "--camera",
        "--ambiguity",
        "--width",
        "--height",
        "--spp",
        "--seed",
        "--config",
        "--faceting",
        "--discontinuity",
    ] {
        assert!(out.contains(flag), "--help lacks {flag}");
    }
    assert!(out.contains("degrees") && out.contains("140 under fit"), "{out}");
}

#[test]
fn settings_from_json_and_flags_override_it() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.json"), r#"{"width": 40, "height": 30, "spp": 1, "camera": "cylindrical"}"#)
        .unwrap();
    let (code, _, err) = run(dir.path(), &["render", "--config", "s.json", "--height", "20", "-o", "o.png"]);
    assert_eq!(code, 0, "{err}");
    let img = image::open(dir.path().join("o.png")).unwrap();
    assert_eq!((img.width(), img.height()), (40, 20));
}

#[test]
fn unknown_json_keys_and_bad_values_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.json"), r#"{"widht": 40}"#).unwrap();
    let (code, _, err) = run(dir.path(), &["render", "--config", "s.json"]);
    assert_eq!(code, 2);
    assert!(err.contains("unknown key `widht`") && err.lines().count() == 1, "{err}");
    for args in [
        &["render", "--camera", "planar", "--ambiguity", "180"][..],
        &["render", "--ambiguity", "720"],
        &["render", "--width", "0"],
        &["render", "--width", "100000"],
        &["render", "--camera", "teapot"],
        &["render", "--spp", "-1"],
    ] {
        let (code, _, err) = run(dir.path(), args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(!dir.path().join("cubist.png").exists(), "{args:?} wrote an image");
    }
}

#[test]
fn bad_input_files_fail_with_one_line_and_no_output() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("broken.glb"), b"glTF\x02\x00\x00\x00garbage").unwrap();
    for scene in ["broken.glb", "missing.gltf"] {
        let (code, _, err) = run(dir.path(), &["render", scene, "-o", "out.png"]);
        assert_eq!(code, 1, "{scene}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(scene), "{err}");
        assert!(!dir.path().join("out.png").exists());
    }
    // Only .png outputs; an unwritable directory is an error, not a panic.
    let (code, _, err) = run(dir.path(), &["render", "-o", "out.jpg"]);
    assert_eq!(code, 2, "{err}");
    let (code, _, err) = run(dir.path(), &["render", "-o", "no/such/dir/out.png", "--width", "8", "--height", "8"]);
    assert_eq!(code, 1, "{err}");
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().map(|e| e.file_name()).collect();
    assert_eq!(leftovers.len(), 1, "{leftovers:?}");
}

#[test]
fn faces_prints_a_table_row_in_one_call() {
    let dir = tempfile::tempdir().unwrap();
    let sphere = common::icosphere_gltf(dir.path(), 3);
    let s = sphere.to_str().unwrap();
    let (code, out, err) = run(
        dir.path(),
        &[
            "faces",
            s,
            "--view",
            "spherical:120",
            "--view",
            "spherical:360",
            "--view",
            "orthographic",
            "--json",
            "--width",
            "256",
            "--height",
            "256",
            "--spp",
            "1",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let rows = v["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 3);
    assert!(rows[1]["visible"].as_u64().unwrap() > 1260, "{out}");
    assert_eq!(rows[1]["total"], 1280);
    let (code, out, _) = run(
        dir.path(),
        &["faces", s, "--camera", "planar", "--angles", "90,120,150", "--width", "128", "--height", "128"],
    );
    assert_eq!(code, 0);
    assert_eq!(out.lines().filter(|l| l.contains("planar")).count(), 3, "{out}");
}

#[test]
fn progress_lines_for_the_addon() {
    let dir = tempfile::tempdir().unwrap();
    let (code, _, err) =
        run(dir.path(), &["render", "--progress", "lines", "--width", "64", "--height", "48", "--spp", "1"]);
    assert_eq!(code, 0);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("PROGRESS ")).collect();
    assert!(lines.len() >= 3, "{err}");
    for l in lines {
        let f: f64 = l.split_whitespace().nth(1).unwrap().parse().unwrap();
        assert!((0.0..=1.0).contains(&f));
    }
}

/// `cubist settings` prints the resolved settings: every key (null where chosen per scene),
/// the preset's values, then the config file, then the flags; bad values are usage errors.
#[test]
fn settings_prints_every_resolved_key_as_json() {
    use cubist::settings::{Preset, Settings};
    let dir = tempfile::tempdir().unwrap();
    let parse = |out: &str| -> serde_json::Value { serde_json::from_str(out).expect("stdout is JSON") };

    let (code, out, err) = run(dir.path(), &["settings"]);
    assert_eq!(code, 0, "{err}");
    let json = parse(&out);
    // Every key of `Settings`, and back into Settings the defaults (the output is a valid
    // config file; f32 values print as typed, 0.34 rather than 0.3400000035762787).
    let keys = json.as_object().unwrap();
    let all = serde_json::to_value(Settings::default()).unwrap();
    assert!(keys.keys().eq(all.as_object().unwrap().keys()), "{out}");
    let back: Settings = serde_json::from_value(json.clone()).unwrap();
    assert_eq!(back, Settings::default());
    assert_eq!(json["background"], serde_json::json!([0.21, 0.18, 0.14]));
    for key in ["preset", "fill", "superpixels", "weight_object", "saliency_method", "saliency_cache", "passes"] {
        assert!(keys.contains_key(key), "no `{key}` in {out}");
    }
    assert_eq!(json["preset"], "analytic");
    assert_eq!(json["ambiguity"], serde_json::Value::Null);
    assert_eq!(json["discontinuity"], 110.0);

    for (name, preset) in [
        ("analytic", Preset::Analytic),
        ("braque", Preset::Braque),
        ("blue-period", Preset::BluePeriod),
        ("grisaille", Preset::Grisaille),
        ("plain", Preset::Plain),
    ] {
        let (code, out, err) = run(dir.path(), &["settings", "--preset", name]);
        assert_eq!(code, 0, "{name}: {err}");
        let back: Settings = serde_json::from_value(parse(&out)).unwrap();
        assert_eq!(back, Settings::preset(preset), "{name}");
    }

    // Layers: preset named in the file, file values, then flags.
    std::fs::write(dir.path().join("s.json"), r#"{"preset": "braque", "width": 40, "colors": 3}"#).unwrap();
    let (code, out, err) = run(dir.path(), &["settings", "--config", "s.json", "--colors", "5", "--pass", "depth"]);
    assert_eq!(code, 0, "{err}");
    let json = parse(&out);
    assert_eq!((json["preset"].as_str(), json["width"].as_u64()), (Some("braque"), Some(40)));
    assert_eq!((json["colors"].as_u64(), json["palette"].as_str()), (Some(5), Some("olive")));
    assert_eq!(json["passes"], serde_json::json!(["depth"]));

    // Validated like a render: one-line usage errors, nothing on stdout.
    std::fs::write(dir.path().join("bad.json"), r#"{"widht": 40}"#).unwrap();
    for args in [
        &["settings", "--config", "bad.json"][..],
        &["settings", "--fill", "1.5"],
        &["settings", "--segments", "5,30", "--thresholds", "0"],
    ] {
        let (code, out, err) = run(dir.path(), args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(out.is_empty() && err.trim().lines().count() == 1, "{args:?}: {out} {err}");
    }
}

/// `cubist settings --schema`: every key with its type, default, range or choices, unit, help
/// and group; the stages in the order the progress output names them; the presets.
#[test]
fn settings_schema_describes_every_key_the_stages_and_the_presets() {
    let dir = tempfile::tempdir().unwrap();
    let (code, out, err) = run(dir.path(), &["settings", "--schema"]);
    assert_eq!(code, 0, "{err}");
    let schema: serde_json::Value = serde_json::from_str(&out).expect("stdout is JSON");
    assert_eq!(schema["version"], 1);
    let settings = schema["settings"].as_array().unwrap();
    let field = |key: &str| settings.iter().find(|f| f["key"] == key).unwrap_or_else(|| panic!("no {key}"));
    // The defaults are what `cubist settings` prints (f32 values as typed: 0.34).
    let (_, out, _) = run(dir.path(), &["settings"]);
    let defaults: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(settings.len(), defaults.as_object().unwrap().len());
    assert_eq!(field("background")["default"], serde_json::json!([0.21, 0.18, 0.14]));
    for f in settings {
        assert_eq!(f["default"], defaults[f["key"].as_str().unwrap()], "{f}");
    }
    let w = field("weight_saliency");
    assert_eq!(
        (w["type"].as_str(), w["min"].as_f64(), w["group"].as_str()),
        (Some("number"), Some(0.0), Some("Facets"))
    );
    assert!(w["help"].as_str().unwrap().contains("saliency"), "{w}");
    let fill = field("fill");
    assert_eq!((fill["nullable"].as_bool(), fill["min_exclusive"].as_bool()), (Some(true), Some(true)));
    assert!(fill["null_means"].as_str().unwrap().contains("0.8"), "{fill}");
    let d = field("discontinuity");
    assert_eq!((d["unit"].as_str(), d["flag"].as_str()), (Some("px at 1000 px"), Some("--discontinuity")));
    let camera = field("camera");
    let choices: Vec<&str> =
        camera["choices"].as_array().unwrap().iter().map(|c| c["value"].as_str().unwrap()).collect();
    assert_eq!(choices, ["auto", "spherical", "cylindrical", "planar", "perspective", "orthographic"]);
    let passes = field("passes");
    assert_eq!((passes["type"].as_str(), passes["items"].as_str()), (Some("array"), Some("enum")));
    assert_eq!(
        (passes["formats"]["facet-ids"].as_str(), passes["formats"]["depth"].as_str()),
        (Some("grey16"), Some("grey"))
    );
    let ambiguity = field("ambiguity");
    // The cubist cameras' angle is chosen per scene (`compose`): only the pinhole's is one value.
    assert_eq!(
        (ambiguity["automatic"].get("other"), ambiguity["automatic"]["perspective"].as_f64()),
        (None, Some(60.0))
    );
    let stages: Vec<&str> = schema["stages"].as_array().unwrap().iter().map(|s| s["name"].as_str().unwrap()).collect();
    assert_eq!(
        stages,
        [
            "loading",
            "pre-render",
            "saliency",
            "faceting",
            "imprecision",
            "re-trace",
            "anti-aliasing",
            "paint",
            "writing",
            "done"
        ]
    );
    let presets: Vec<&str> =
        schema["presets"].as_array().unwrap().iter().map(|p| p["name"].as_str().unwrap()).collect();
    assert_eq!(presets, ["analytic", "braque", "blue-period", "grisaille", "plain", "thesis"]);
}

/// `cubist settings --stages` names the stages a render of those settings runs, and a render
/// reports exactly those (re-trace: when some facet moved).
#[test]
fn settings_stages_are_the_stages_a_render_reports() {
    let dir = tempfile::tempdir().unwrap();
    let stages = |args: &[&str]| -> Vec<String> {
        let (code, out, err) = run(dir.path(), &[&["settings", "--stages"][..], args].concat());
        assert_eq!(code, 0, "{err}");
        serde_json::from_str(&out).unwrap()
    };
    assert_eq!(stages(&["--preset", "plain"]), ["loading", "pre-render", "anti-aliasing", "writing", "done"]);
    // One sample per pixel: the pre-render is the image, no anti-aliasing.
    assert!(!stages(&["--spp", "1"]).contains(&"anti-aliasing".to_string()));
    let analytic = stages(&[]);
    assert_eq!(
        analytic,
        [
            "loading",
            "pre-render",
            "saliency",
            "faceting",
            "imprecision",
            "re-trace",
            "anti-aliasing",
            "paint",
            "writing",
            "done"
        ]
    );
    assert!(!stages(&["--faceting", "voronoi", "--imprecision", "random"]).contains(&"saliency".to_string()));
    assert!(stages(&["--preset", "plain", "--pass", "saliency"]).contains(&"saliency".to_string()));
    // A render reports exactly those stages, in that order.
    let (code, _, err) =
        run(dir.path(), &["render", "--width", "48", "--height", "36", "--spp", "2", "--progress", "lines"]);
    assert_eq!(code, 0, "{err}");
    let mut reported: Vec<String> = Vec::new();
    for l in err.lines().filter_map(|l| l.strip_prefix("PROGRESS ")) {
        let stage = l.split_once(' ').unwrap().1.to_string();
        if reported.last() != Some(&stage) {
            reported.push(stage);
        }
    }
    assert_eq!(reported, analytic);
}

/// Every `[default: X]` / `[analytic: X]` written in a flag's help is the value the settings
/// really take (the help is hand-written; this keeps it honest when a preset changes).
#[test]
fn help_defaults_match_the_settings() {
    use clap::CommandFactory;
    let defaults = serde_json::to_value(cubist::Settings::default()).unwrap();
    let cli = cubist::cli::Cli::command();
    let render = cli.find_subcommand("render").unwrap();
    let mut checked = 0;
    for arg in render.get_arguments() {
        let key = arg.get_id().as_str();
        let key = if key == "pass" { "passes" } else { key };
        let Some(value) = defaults.get(key) else { continue };
        let help = arg.get_help().map(|h| h.to_string()).unwrap_or_default();
        let Some(start) = help.find("[default: ").map(|i| i + 10).or_else(|| help.find("[analytic: ").map(|i| i + 11))
        else {
            continue;
        };
        let stated = help[start..].split(']').next().unwrap();
        let stated = stated.split([' ', ';']).next().unwrap();
        let actual = match value {
            serde_json::Value::Null => continue, // chosen per scene: the help describes how
            serde_json::Value::String(s) => s.clone(),
            serde_json::Value::Array(a) => a.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(","),
            v => v.to_string(),
        };
        let same = stated == actual
            || matches!((stated.parse::<f64>(), actual.parse::<f64>()), (Ok(a), Ok(b)) if (a - b).abs() < 1e-9)
            || (actual.contains(',')
                && stated.split(',').zip(actual.split(',')).all(
                    |(a, b)| matches!((a.parse::<f64>(), b.parse::<f64>()), (Ok(x), Ok(y)) if (x - y).abs() < 1e-6),
                ));
        assert!(same, "--{}: the help says {stated}, the default is {actual}", key.replace('_', "-"));
        checked += 1;
    }
    assert!(checked > 25, "only {checked} defaults checked");
}
