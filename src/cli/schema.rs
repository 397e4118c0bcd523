//! `cubist settings --schema`: what every setting is, for front ends that build their own
//! controls (the Blender add-on generates its panel from it). Types, units and ranges come from
//! `settings::schema`, defaults from `Settings::default()` (the analytic preset), help and
//! groups from the flags' own help, stage names from `pipeline::Stage`, the automatic angle
//! from `framing` and the passes' image formats from `output::Pass`: nothing here is a
//! copy. The format is documented in README ("The settings schema").

use clap::{Args, Command, ValueEnum};
use serde_json::{Map, Value, json};

use super::SettingsArgs;
use crate::framing::DEFAULT_FOV;
use crate::pipeline::{Stage, params};
use crate::settings::schema::{FIELDS, Field, Kind, choices};
use crate::settings::{Pass, Preset, Settings};

/// Bumped when the JSON's shape changes (not when a setting is added).
pub const SCHEMA_VERSION: u32 = 1;

/// The whole schema as JSON.
pub fn schema() -> Value {
    let flags = SettingsArgs::augment_args(Command::new("cubist"));
    // Through text, as `cubist settings` prints them: f32 values as typed (0.62), not widened
    // to f64 (0.6200000047683716).
    let text = serde_json::to_string(&Settings::default()).unwrap_or_default();
    let defaults = match serde_json::from_str(&text) {
        Ok(Value::Object(m)) => m,
        _ => Map::new(),
    };
    let settings: Vec<Value> = FIELDS.iter().map(|f| setting(f, &flags, &defaults)).collect();
    let stages: Vec<Value> = Stage::ALL.iter().map(|s| json!({ "name": s.name(), "help": s.help() })).collect();
    let presets: Vec<Value> =
        choices::<Preset>().into_iter().map(|c| json!({ "name": c.value, "help": c.help })).collect();
    json!({ "version": SCHEMA_VERSION, "settings": settings, "stages": stages, "presets": presets })
}

/// Splits a flag's help into its text and the bracket that ends it (`[default: ...]` or
/// `[analytic: ...]`), which says what the default, or a null, means.
fn split_help(help: &str) -> (String, Option<String>) {
    let help = help.trim();
    if let Some(start) = help.rfind(" [")
        && help.ends_with(']')
    {
        let bracket = &help[start + 2..help.len() - 1];
        let said = bracket.split_once(": ").map_or(bracket, |(_, v)| v);
        return (help[..start].trim_end().to_string(), Some(said.to_string()));
    }
    (help.to_string(), None)
}

fn number(kind: Kind, v: f64) -> Value {
    if kind == Kind::Integer { json!(v as i64) } else { json!(v) }
}

fn kind_name(kind: Kind) -> Value {
    serde_json::to_value(kind).unwrap_or(Value::Null)
}

fn setting(f: &Field, flags: &Command, defaults: &Map<String, Value>) -> Value {
    let arg = flags.get_arguments().find(|a| a.get_id().as_str() == f.key);
    let (help, said) = split_help(&arg.and_then(|a| a.get_help()).map(|h| h.to_string()).unwrap_or_default());
    let mut out = Map::new();
    out.insert("key".into(), json!(f.key));
    out.insert("type".into(), kind_name(f.kind));
    if let Some(items) = f.items {
        out.insert("items".into(), kind_name(items));
    }
    if let Some(n) = f.length {
        out.insert("length".into(), json!(n));
    }
    out.insert("nullable".into(), json!(f.nullable));
    out.insert("default".into(), defaults.get(f.key).cloned().unwrap_or(Value::Null));
    if f.nullable {
        out.insert("null_means".into(), json!(said));
    }
    if let Some(r) = f.range {
        let kind = f.items.unwrap_or(f.kind);
        out.insert("min".into(), number(kind, r.min));
        out.insert("min_exclusive".into(), json!(r.min_exclusive));
        out.insert("max".into(), r.max.map_or(Value::Null, |m| number(kind, m)));
        out.insert("max_exclusive".into(), json!(r.max_exclusive));
    }
    if let Some(c) = f.choices {
        out.insert("choices".into(), json!(c()));
    }
    // What null gives where it is one value per case (front ends that show a number): the
    // pinhole's field of view; the cubist cameras' angle is chosen per scene by `compose`
    // (`framing::DEFAULT_ANGLE` under `fit` and `centre`).
    if f.key == "ambiguity" {
        out.insert("automatic".into(), json!({ "perspective": DEFAULT_FOV }));
    }
    if f.key == "passes" {
        let formats: Map<String, Value> =
            Pass::value_variants().iter().map(|&p| (p.as_str().to_string(), json!(params::pass(p).format()))).collect();
        out.insert("formats".into(), Value::Object(formats));
    }
    out.insert("unit".into(), json!(f.unit));
    out.insert("help".into(), json!(help));
    out.insert("group".into(), json!(arg.and_then(|a| a.get_help_heading())));
    out.insert("flag".into(), json!(arg.and_then(|a| a.get_long()).map(|l| format!("--{l}"))));
    Value::Object(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_key_of_the_settings_is_described_in_order_with_its_flag_and_help() {
        let s = schema();
        let keys: Vec<&str> = s["settings"].as_array().unwrap().iter().map(|f| f["key"].as_str().unwrap()).collect();
        let settings = serde_json::to_value(Settings::default()).unwrap();
        let want: Vec<&str> = settings.as_object().unwrap().keys().map(String::as_str).collect();
        let mut sorted = keys.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, want, "schema keys = Settings keys");
        // In the struct's order (serde writes fields in order; a JSON object would sort them).
        let text = serde_json::to_string(&Settings::default()).unwrap();
        let at: Vec<usize> = keys.iter().map(|k| text.find(&format!("\"{k}\":")).unwrap()).collect();
        assert!(at.windows(2).all(|w| w[0] < w[1]), "schema order = Settings order: {keys:?}");
        for f in s["settings"].as_array().unwrap() {
            assert!(f["flag"].as_str().is_some_and(|l| l.starts_with("--")), "{f}");
            assert!(!f["help"].as_str().unwrap().is_empty(), "{f}");
            assert!(f["group"].as_str().is_some(), "{f}");
            assert!(!f["help"].as_str().unwrap().contains("[default"), "{f}");
        }
        assert_eq!(s["stages"][1]["name"], "pre-render");
        assert_eq!(s["presets"][0]["name"], "analytic");
    }

    #[test]
    fn help_brackets_are_split_off() {
        assert_eq!(
            split_help("Image width, pixels [default: 800]"),
            ("Image width, pixels".into(), Some("800".into()))
        );
        assert_eq!(split_help("Border [analytic: 12]"), ("Border".into(), Some("12".into())));
        assert_eq!(split_help("No bracket"), ("No bracket".into(), None));
    }
}
