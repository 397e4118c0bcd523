//! Settings from layers: the preset's values, then a JSON file's keys, then the flags' keys.

use std::path::Path;

use serde_json::{Map, Value};

use super::{Preset, Settings};
use crate::error::{Error, Result};

impl Settings {
    /// Builds settings from layers: the preset named by the outermost layer that names one
    /// (flags, then JSON, else `analytic`), then the JSON object, then the flags' object.
    /// Unknown keys are an error naming the key. The result is validated.
    pub fn from_layers(json: Option<(&Path, Value)>, flags: Map<String, Value>) -> Result<Self> {
        let json_obj = match json {
            None => None,
            Some((path, Value::Object(map))) => Some((path, map)),
            Some((path, _)) => {
                return Err(Error::Config {
                    path: path.to_path_buf(),
                    message: "the top level must be a JSON object of settings".into(),
                });
            }
        };
        let preset_of = |map: &Map<String, Value>| -> Result<Option<Preset>> {
            match map.get("preset") {
                None => Ok(None),
                Some(v) => {
                    serde_json::from_value(v.clone()).map(Some).map_err(|e| Error::setting("preset", e.to_string()))
                }
            }
        };
        let preset = match preset_of(&flags)? {
            Some(p) => p,
            None => match &json_obj {
                Some((_, map)) => preset_of(map)?.unwrap_or(Preset::Analytic),
                None => Preset::Analytic,
            },
        };
        let mut merged = match serde_json::to_value(Settings::preset(preset)) {
            Ok(Value::Object(m)) => m,
            _ => unreachable!("Settings serialises to an object"),
        };
        let known: Vec<String> = merged.keys().cloned().collect();
        if let Some((path, map)) = json_obj {
            for (k, v) in map {
                if !known.contains(&k) {
                    return Err(Error::Config {
                        path: path.to_path_buf(),
                        message: format!("unknown key `{k}` (see `cubist render --help` for every setting)"),
                    });
                }
                merged.insert(k, v);
            }
            // Deserialise once here so a bad value is blamed on the file, not the flags.
            let _: Settings = serde_json::from_value(Value::Object(merged.clone()))
                .map_err(|e| Error::Config { path: path.to_path_buf(), message: e.to_string() })?;
        }
        for (k, v) in flags {
            merged.insert(k, v);
        }
        let settings: Settings =
            serde_json::from_value(Value::Object(merged)).map_err(|e| Error::setting("flags", e.to_string()))?;
        settings.validate()?;
        Ok(settings)
    }

    /// Reads a JSON settings file into the layer `from_layers` takes.
    pub fn read_json(path: &Path) -> Result<Value> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::Config { path: path.to_path_buf(), message: e.to_string() })?;
        serde_json::from_str(&text)
            .map_err(|e| Error::Config { path: path.to_path_buf(), message: format!("not valid JSON: {e}") })
    }
}
