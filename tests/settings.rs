//! The settings: presets, validation, layers, and the schema front ends read
//! (`cubist settings --schema`) against what validation accepts.

use cubist::paint::Painter;
use cubist::pipeline::params;
use cubist::settings::schema::{FIELDS, Field, Kind};
use cubist::settings::{CameraKind, Faceting, Palette, Preset, Settings};
use serde_json::{Map, Value, json};

#[test]
fn presets_bundle_the_papers_settings() {
    let a = Settings::default();
    assert_eq!(a.preset, Preset::Analytic);
    assert_eq!(a.faceting, Faceting::Planes);
    assert_eq!(a.discontinuity, 110.0);
    let angle = |s: &Settings| params::framing(s).angle_deg(params::camera_kind(CameraKind::Spherical), None);
    assert_eq!(angle(&a), 140.0);
    assert!(a.border_width > 0.0 && a.border_strength > 0.0 && a.palette != Palette::None);
    for p in [Preset::Analytic, Preset::Braque, Preset::BluePeriod, Preset::Grisaille] {
        let s = Settings::preset(p);
        s.validate().unwrap();
        assert!((120.0..=150.0).contains(&angle(&s)), "{p}: ambiguity {}", angle(&s));
        assert!((50.0..=200.0).contains(&s.discontinuity), "{p}");
        assert_eq!(s.faceting, Faceting::Planes);
        assert!(!Painter::new(&params::paint(&s)).unwrap().is_empty());
        // Named in JSON and flags alike.
        let from_json: Preset = serde_json::from_value(json!(p.as_str())).unwrap();
        assert_eq!(from_json, p);
    }
    assert!(Painter::new(&params::paint(&Settings::preset(Preset::Plain))).unwrap().is_empty());
    // The paper's method stays reachable as it has it.
    let t = Settings::preset(Preset::Thesis);
    t.validate().unwrap();
    assert_eq!((t.faceting, angle(&t), t.discontinuity), (Faceting::Segment, 140.0, 200.0));
}

#[test]
fn weight_settings_are_validated() {
    let ok = Settings::default();
    assert!(ok.validate().is_ok());
    let bad = |f: &dyn Fn(&mut Settings), key: &str| {
        let mut s = Settings::default();
        f(&mut s);
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains(key), "{e}");
    };
    bad(&|s| s.weight_object = 1.5, "weight_object");
    bad(&|s| s.weight_colour = -1.0, "weight_colour");
    bad(&|s| s.weight_normal = f64::NAN, "weight_normal");
    bad(&|s| s.weight_depth = f64::INFINITY, "weight_depth");
    bad(&|s| s.weight_saliency = -0.1, "weight_saliency");
    bad(&|s| s.superpixels = 2_000_000, "superpixels");
    // JSON keys and flags reach the same fields.
    let json = json!({ "weight_object": 1.0, "superpixels": 900 });
    let s = Settings::from_layers(Some((std::path::Path::new("x.json"), json)), Default::default()).unwrap();
    assert_eq!((s.weight_object, s.superpixels), (1.0, 900));
}

#[test]
fn the_image_side_at_fault_is_named() {
    let e = |w: u32, h: u32| Settings { width: w, height: h, ..Settings::default() }.validate().unwrap_err();
    assert!(e(0, 10).to_string().contains("`width`"), "{}", e(0, 10));
    assert!(e(10, 0).to_string().contains("`height`"), "{}", e(10, 0));
    assert!(e(20000, 10).to_string().contains("`width`"));
    assert!(e(10, 20000).to_string().contains("`height`"));
}

/// Settings with `key` set to `value` (every other key at its default), through the layers a
/// flag takes: Ok when accepted.
fn with(key: &str, value: Value) -> Result<Settings, String> {
    let mut flags = Map::new();
    flags.insert(key.into(), value);
    Settings::from_layers(None, flags).map_err(|e| e.to_string())
}

/// A value of `f`'s type: `v` itself, or `v` in every item of an array.
fn value_of(f: &Field, v: f64) -> Value {
    let kind = f.items.unwrap_or(f.kind);
    let one = if kind == Kind::Integer { json!(v as i64) } else { json!(v) };
    if f.kind == Kind::Array { json!(vec![one; f.length.unwrap_or(3)]) } else { one }
}

/// Every range the schema states is what validation accepts, at both ends: the bound itself
/// (accepted unless open) and just past it (refused).
#[test]
fn schema_ranges_are_what_validation_accepts() {
    let mut checked = 0;
    for f in FIELDS {
        let Some(r) = f.range else { continue };
        let integer = f.items.unwrap_or(f.kind) == Kind::Integer;
        // A step past a bound that the field's precision resolves (f32 for some keys).
        let step = |b: f64| if integer { 1.0 } else { 1e-4 * b.abs().max(1.0) };
        let at_min = with(f.key, value_of(f, r.min));
        assert_eq!(at_min.is_ok(), !r.min_exclusive, "{} = {} (min): {at_min:?}", f.key, r.min);
        let below = with(f.key, value_of(f, r.min - step(r.min)));
        assert!(below.is_err(), "{} below its minimum {} is accepted", f.key, r.min);
        if let Some(max) = r.max {
            let at_max = with(f.key, value_of(f, max));
            assert_eq!(at_max.is_ok(), !r.max_exclusive, "{} = {max} (max): {at_max:?}", f.key);
            let above = with(f.key, value_of(f, max + step(max)));
            assert!(above.is_err(), "{} above its maximum {max} is accepted", f.key);
            if r.max_exclusive {
                assert!(with(f.key, value_of(f, max - step(max))).is_ok(), "{} just below {max}", f.key);
            }
        }
        if r.min_exclusive {
            assert!(with(f.key, value_of(f, r.min + step(r.min))).is_ok(), "{} just above {}", f.key, r.min);
        }
        checked += 1;
    }
    assert!(checked > 25, "{checked} ranges checked");
}

/// Every key is in the schema with the JSON type its default has, nullable exactly when its
/// default may be null, and every enum lists the values serde accepts.
#[test]
fn schema_types_are_the_settings_types() {
    let defaults = serde_json::to_value(Settings::default()).unwrap();
    let defaults = defaults.as_object().unwrap();
    assert_eq!(FIELDS.len(), defaults.len());
    let json_type = |k: Kind, v: &Value| match k {
        Kind::Boolean => v.is_boolean(),
        Kind::Integer => v.is_u64() || v.is_i64(),
        Kind::Number => v.is_number(),
        Kind::Enum | Kind::Path | Kind::Text => v.is_string(),
        Kind::Array => v.is_array(),
    };
    for f in FIELDS {
        let v = &defaults[f.key];
        if v.is_null() {
            assert!(f.nullable, "{} defaults to null", f.key);
        } else {
            assert!(json_type(f.kind, v), "{}: {v} is not of type {:?}", f.key, f.kind);
        }
        if let (Some(items), Some(list)) = (f.items, v.as_array()) {
            assert!(list.iter().all(|x| json_type(items, x)), "{}: items of {v}", f.key);
        }
        if let Some(n) = f.length {
            assert!(v.is_null() || v.as_array().is_some_and(|a| a.len() == n), "{}", f.key);
        }
        if let Some(choices) = f.choices {
            let choices = choices();
            assert!(!choices.is_empty());
            for c in &choices {
                let value = if f.kind == Kind::Array { json!([c.value]) } else { json!(c.value) };
                // Constant faceting needs its map; every other value stands alone.
                let r = with(f.key, value);
                assert!(r.is_ok() || c.value == "constant", "{} = {}: {r:?}", f.key, c.value);
            }
            assert!(with(f.key, json!("no-such-value")).is_err());
        }
    }
}

/// A value of key `f` as a flag writes it: its default, else one of its type's.
fn flag_value(f: &Field, default: &Value) -> String {
    match default {
        Value::Null => match (f.kind, f.length) {
            (Kind::Array, Some(n)) => vec!["0.5"; n].join(","),
            (Kind::Number, _) => "0.5".into(),
            (Kind::Text, _) => "1-2".into(),
            _ => "x".into(),
        },
        Value::String(s) => s.clone(),
        Value::Array(a) if a.is_empty() => f.choices.map(|c| c()[0].value.clone()).unwrap_or_default(),
        Value::Array(a) => a.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(","),
        v => v.to_string(),
    }
}

/// Every key of `Settings` (as serde writes it) has a schema entry and a flag, in every command
/// that takes settings, and the flag sets that key and nothing else: a setting cannot be
/// declared without reaching the schema and the command line.
#[test]
fn every_setting_reaches_the_schema_and_a_flag() {
    use clap::{CommandFactory, Parser};
    use cubist::cli::{Cli, Command};
    let defaults = serde_json::to_value(Settings::default()).unwrap();
    let defaults = defaults.as_object().unwrap();
    let mut schema_keys: Vec<&str> = FIELDS.iter().map(|f| f.key).collect();
    schema_keys.sort_unstable();
    assert_eq!(schema_keys, defaults.keys().map(String::as_str).collect::<Vec<_>>(), "schema keys = Settings keys");
    let cli = Cli::command();
    for command in ["render", "faces", "saliency", "facets", "settings", "look"] {
        let sub = cli.find_subcommand(command).unwrap();
        for f in FIELDS {
            let arg = sub.get_arguments().find(|a| a.get_id().as_str() == f.key);
            let arg = arg.unwrap_or_else(|| panic!("`{command}` has no flag for {}", f.key));
            let long = if f.key == "passes" { "pass".to_string() } else { f.key.replace('_', "-") };
            assert_eq!(arg.get_long(), Some(long.as_str()), "{command}: the flag of {}", f.key);
            assert!(arg.get_help().is_some_and(|h| !h.to_string().is_empty()), "--{long} has no help");
            assert!(arg.get_help_heading().is_some(), "--{long} has no heading");
        }
    }
    for f in FIELDS {
        let long = if f.key == "passes" { "pass".to_string() } else { f.key.replace('_', "-") };
        let flag = format!("--{long}={}", flag_value(f, &defaults[f.key]));
        let cli = Cli::try_parse_from(["cubist", "settings", &flag]).unwrap_or_else(|e| panic!("{flag}: {e}"));
        let Command::Settings(args) = cli.command else { panic!("not settings") };
        let layer = args.settings.flags.to_layer();
        assert_eq!(layer.keys().collect::<Vec<_>>(), [f.key], "{flag} sets {:?}", layer);
    }
}
