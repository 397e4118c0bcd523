//! The requests and replies of `cubist serve`, one JSON object per line (docs/serve.md).

use std::path::PathBuf;

use serde::Deserialize;
use serde_json::{Map, Value, json};

use crate::settings::Pass;

/// Longest request line read, bytes: a longer line is refused (bounded memory).
pub const MAX_LINE: usize = 1 << 20;

/// A request as read: its id (any JSON value, echoed in the reply) and what it asks.
#[derive(Debug)]
pub struct Request {
    pub id: Value,
    pub command: Command,
}

#[derive(Debug, PartialEq)]
pub enum Command {
    Render(RenderRequest),
    /// Cancel the render with this id (running or queued); None: the running one and every
    /// queued one.
    Cancel(Option<Value>),
    Stats,
    Shutdown,
}

/// `{"cmd": "render", ...}`.
#[derive(Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RenderRequest {
    /// A .gltf or .glb file; null or absent: the built-in still life.
    #[serde(default)]
    pub scene: Option<PathBuf>,
    /// The settings, as in a `--config` file (missing keys: the preset's values).
    #[serde(default = "empty_object")]
    pub settings: Value,
    /// Where the image goes: `.png`, or `.rgba` for raw 8-bit RGBA rows, top row first.
    pub output: PathBuf,
    /// Passes written beside the output as `<stem>.<pass>.png`; replaces the settings' own
    /// `passes` when given.
    #[serde(default)]
    pub passes: Option<Vec<Pass>>,
    /// Write `PROGRESS <fraction> <stage>` lines on stderr while rendering.
    #[serde(default)]
    pub progress: bool,
    /// Render on threads of a lower CPU priority (a render ahead of the client's user): the
    /// same pixels, the cores left to the client's interface first.
    #[serde(default)]
    pub background: bool,
}

fn empty_object() -> Value {
    Value::Object(Map::new())
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CancelRequest {
    #[serde(default)]
    target: Option<Value>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Empty {}

/// A request line that cannot be served: the reply's id (when the line had one) and the
/// one-line reason.
#[derive(Debug)]
pub struct BadRequest {
    pub id: Value,
    pub message: String,
}

/// Parses one request line.
pub fn parse(line: &str) -> Result<Request, BadRequest> {
    let bad = |id: &Value, message: String| BadRequest { id: id.clone(), message };
    let value: Value =
        serde_json::from_str(line).map_err(|e| bad(&Value::Null, format!("the request is not JSON: {e}")))?;
    let Value::Object(mut obj) = value else {
        return Err(bad(&Value::Null, "a request must be a JSON object".into()));
    };
    let id = obj.remove("id").unwrap_or(Value::Null);
    let cmd = match obj.remove("cmd") {
        Some(Value::String(c)) => c,
        Some(_) => return Err(bad(&id, "`cmd` must be a string".into())),
        None => return Err(bad(&id, "the request has no `cmd` (render, cancel, stats or shutdown)".into())),
    };
    let rest = Value::Object(obj);
    let fields = |e: serde_json::Error| bad(&id, format!("{cmd}: {e}"));
    let command = match cmd.as_str() {
        "render" => Command::Render(serde_json::from_value(rest).map_err(fields)?),
        "cancel" => Command::Cancel(serde_json::from_value::<CancelRequest>(rest).map_err(fields)?.target),
        "stats" => {
            serde_json::from_value::<Empty>(rest).map_err(fields)?;
            Command::Stats
        }
        "shutdown" => {
            serde_json::from_value::<Empty>(rest).map_err(fields)?;
            Command::Shutdown
        }
        other => return Err(bad(&id, format!("unknown cmd `{other}` (render, cancel, stats or shutdown)"))),
    };
    Ok(Request { id, command })
}

/// `{"id": ..., "ok": false, "error": "..."}` (plus `"cancelled": true` for a cancelled render).
pub fn error_reply(id: &Value, message: &str, cancelled: bool) -> Value {
    let mut r = json!({ "id": id, "ok": false, "error": one_line(message) });
    if cancelled {
        r["cancelled"] = Value::Bool(true);
    }
    r
}

/// Messages are one line (a reply is one line of JSON anyway; this keeps them readable).
fn one_line(message: &str) -> String {
    message.lines().map(str::trim).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_command() {
        let r = parse(r#"{"id": 1, "cmd": "render", "output": "/tmp/a.png"}"#).unwrap();
        assert_eq!(r.id, json!(1));
        let Command::Render(render) = r.command else { panic!() };
        assert_eq!(render.scene, None);
        assert_eq!(render.settings, json!({}));
        assert_eq!(render.passes, None);
        let r = parse(r#"{"id": "x", "cmd": "render", "scene": null, "settings": {"width": 8}, "output": "o.rgba", "passes": ["depth", "facet-ids"], "progress": true}"#).unwrap();
        let Command::Render(render) = r.command else { panic!() };
        assert_eq!(render.passes, Some(vec![Pass::Depth, Pass::FacetIds]));
        assert!(render.progress);
        assert_eq!(parse(r#"{"cmd": "cancel"}"#).unwrap().command, Command::Cancel(None));
        assert_eq!(parse(r#"{"cmd": "cancel", "target": 3}"#).unwrap().command, Command::Cancel(Some(json!(3))));
        assert_eq!(parse(r#"{"id": 2, "cmd": "stats"}"#).unwrap().command, Command::Stats);
        assert_eq!(parse(r#"{"cmd": "shutdown"}"#).unwrap().command, Command::Shutdown);
    }

    #[test]
    fn bad_requests_say_why_in_one_line_and_keep_their_id() {
        let msg = |line: &str| parse(line).unwrap_err();
        assert!(msg("not json").message.starts_with("the request is not JSON"));
        assert!(msg("[1]").message.contains("JSON object"));
        let e = msg(r#"{"id": 7}"#);
        assert_eq!((e.id, e.message.contains("no `cmd`")), (json!(7), true));
        assert!(msg(r#"{"id": 7, "cmd": "paint"}"#).message.contains("unknown cmd `paint`"));
        assert!(msg(r#"{"cmd": "render"}"#).message.contains("missing field `output`"));
        assert!(msg(r#"{"cmd": "render", "output": "a.png", "colour": 1}"#).message.contains("unknown field `colour`"));
        assert!(msg(r#"{"cmd": "render", "output": "a.png", "passes": ["nope"]}"#).message.contains("nope"));
        assert!(msg(r#"{"cmd": "stats", "x": 1}"#).message.contains("unknown field `x`"));
        let r = error_reply(&json!(3), "two\nlines", false);
        assert_eq!(r, json!({"id": 3, "ok": false, "error": "two lines"}));
    }
}
