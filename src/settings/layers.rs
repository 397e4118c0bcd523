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
        let base = merged.clone();
        if let Some((path, map)) = json_obj {
            for (k, v) in map {
                if !known.contains(&k) {
                    return Err(Error::config(
                        path,
                        format!(
                            "unknown key `{}` (see `cubist render --help` for every setting)",
                            crate::error::shorten(&k)
                        ),
                    ));
                }
                merged.insert(k, v);
            }
            // Deserialise once here so a bad value is blamed on the file (and its key), not
            // on the flags.
            if let Err(e) = serde_json::from_value::<Settings>(Value::Object(merged.clone())) {
                let (key, e) = blame(&base, &merged, e);
                return Err(Error::config(path, format!("`{key}`: {e}")));
            }
        }
        let before_flags = merged.clone();
        for (k, v) in flags {
            if !known.contains(&k) {
                return Err(Error::setting("flags", format!("unknown setting `{}`", crate::error::shorten(&k))));
            }
            merged.insert(k, v);
        }
        let settings: Settings = match serde_json::from_value(Value::Object(merged.clone())) {
            Ok(s) => s,
            Err(e) => {
                let (key, e) = blame(&before_flags, &merged, e);
                return Err(Error::setting(static_key(&key), e.to_string()));
            }
        };
        settings.validate()?;
        Ok(settings)
    }

    /// Reads a JSON settings file into the layer `from_layers` takes.
    /// At most `MAX_CONFIG_FILE` bytes of a regular file.
    pub fn read_json(path: &Path) -> Result<Value> {
        let text = read_config(path)?;
        serde_json::from_str(&text).map_err(|e| Error::config(path, format!("not valid JSON: {e}")))
    }
}

/// Largest settings file (`--config`), bytes: a settings object is a few kilobytes.
pub const MAX_CONFIG_FILE: u64 = 16 << 20;

/// A settings file's text: a regular file (symlinks followed) of at most `MAX_CONFIG_FILE`
/// bytes, read without blocking on a FIFO or a device. Written here rather than with
/// `util::files::read_bounded` because settings depend on nothing but `error`.
fn read_config(path: &Path) -> Result<String> {
    use std::io::Read;
    let err = |m: String| Error::config(path, m);
    let meta = std::fs::metadata(path).map_err(|e| err(format!("cannot open: {e}")))?;
    if !meta.is_file() {
        return Err(err("cannot open: not a regular file".into()));
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(|e| err(format!("cannot open: {e}")))?;
    let meta = file.metadata().map_err(|e| err(format!("cannot open: {e}")))?;
    if !meta.is_file() {
        return Err(err("cannot open: not a regular file".into()));
    }
    if meta.len() > MAX_CONFIG_FILE {
        return Err(err(format!("{} bytes is larger than the limit of {MAX_CONFIG_FILE} bytes", meta.len())));
    }
    let mut bytes = Vec::new();
    file.take(MAX_CONFIG_FILE + 1).read_to_end(&mut bytes).map_err(|e| err(format!("cannot read: {e}")))?;
    if bytes.len() as u64 > MAX_CONFIG_FILE {
        return Err(err(format!("larger than the limit of {MAX_CONFIG_FILE} bytes")));
    }
    String::from_utf8(bytes).map_err(|_| err("not UTF-8 text".into()))
}

/// The key whose value makes `merged` fail to deserialise: each key that differs from `base`
/// (a valid layer) is tried alone on it, so the error names the key at fault (serde's own
/// message does not). Falls back to serde's error when no single key fails.
fn blame(base: &Map<String, Value>, merged: &Map<String, Value>, e: serde_json::Error) -> (String, String) {
    for (k, v) in merged {
        if base.get(k) == Some(v) {
            continue;
        }
        let mut one = base.clone();
        one.insert(k.clone(), v.clone());
        if let Err(e) = serde_json::from_value::<Settings>(Value::Object(one)) {
            return (k.clone(), crate::error::shorten(&e.to_string()));
        }
    }
    ("settings".into(), crate::error::shorten(&e.to_string()))
}

/// The `&'static str` of a settings key (`Error::Setting` keeps static keys).
fn static_key(key: &str) -> &'static str {
    super::schema::FIELDS.iter().find(|f| f.key == key).map_or("settings", |f| f.key)
}
