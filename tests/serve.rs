//! `cubist serve` end to end: the binary driven through its stdin and stdout as the
//! Blender add-on drives it. Request sequences; at each invalidation level the same pixels as a
//! fresh `cubist render` with the same settings; bad requests answered and survived; cancel;
//! the end of stdin; the parent's death; no file left but the outputs asked for.

mod common;

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::gltf_builder::Gltf;
use serde_json::{Value, json};

/// A running `cubist serve` and a thread reading its replies.
struct Server {
    child: Child,
    stdin: Option<ChildStdin>,
    replies: mpsc::Receiver<Value>,
    /// Lines the server wrote on stderr (`PROGRESS` lines of renders that ask for them).
    stderr: mpsc::Receiver<String>,
}

impl Server {
    fn start() -> Server {
        let mut child = Command::new(common::binary())
            .arg("serve")
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start cubist serve");
        let stdout: ChildStdout = child.stdout.take().unwrap();
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                let v: Value =
                    serde_json::from_str(&line).unwrap_or_else(|e| panic!("reply is not JSON ({e}): {line}"));
                if tx.send(v).is_err() {
                    break;
                }
            }
        });
        let stderr = child.stderr.take().unwrap();
        let (etx, erx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines() {
                let Ok(line) = line else { break };
                if etx.send(line).is_err() {
                    break;
                }
            }
        });
        let stdin = child.stdin.take();
        Server { child, stdin, replies: rx, stderr: erx }
    }

    fn send(&mut self, request: &Value) {
        self.send_line(&request.to_string());
    }

    fn send_line(&mut self, line: &str) {
        let stdin = self.stdin.as_mut().expect("stdin open");
        writeln!(stdin, "{line}").unwrap();
        stdin.flush().unwrap();
    }

    fn reply(&self) -> Value {
        self.replies.recv_timeout(Duration::from_secs(300)).expect("a reply within 5 minutes")
    }

    /// Sends a request and waits for its reply.
    fn ask(&mut self, request: Value) -> Value {
        self.send(&request);
        let r = self.reply();
        assert_eq!(r["id"], request["id"], "{r}");
        r
    }

    /// Closes stdin and waits for the exit status.
    fn close(mut self) -> std::process::ExitStatus {
        self.stdin = None;
        wait(&mut self.child, Duration::from_secs(60)).expect("the server ends at the end of its stdin")
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn wait(child: &mut Child, limit: Duration) -> Option<std::process::ExitStatus> {
    let t = Instant::now();
    while t.elapsed() < limit {
        if let Some(s) = child.try_wait().unwrap() {
            return Some(s);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    None
}

fn render(id: u64, scene: Option<&Path>, settings: Value, output: &Path) -> Value {
    json!({"id": id, "cmd": "render", "scene": scene, "settings": settings, "output": output})
}

/// `cubist render` of the same scene and settings, fresh, as RGBA pixels.
fn fresh(dir: &Path, scene: Option<&Path>, settings: &Value, name: &str) -> image::RgbaImage {
    let config = dir.join(format!("{name}.json"));
    std::fs::write(&config, settings.to_string()).unwrap();
    let out = dir.join(format!("{name}.fresh.png"));
    let mut args: Vec<String> = vec!["render".into()];
    if let Some(s) = scene {
        args.push(s.display().to_string());
    }
    args.extend(["-o".into(), out.display().to_string(), "--config".into(), config.display().to_string()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let (code, _, err) = common::run(dir, &args);
    assert_eq!(code, 0, "{err}");
    let img = image::open(&out).unwrap().to_rgba8();
    std::fs::remove_file(&out).unwrap();
    std::fs::remove_file(&config).unwrap();
    img
}

fn png(path: &Path) -> image::RgbaImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgba8()
}

fn reused(r: &Value) -> Vec<String> {
    r["reused"].as_array().unwrap().iter().map(|v| v.as_str().unwrap().to_string()).collect()
}

/// A small scene file: two spheres and a light; `shift` moves the second sphere, `light`
/// scales the light, `bulge` deforms the second sphere's mesh.
fn scene_glb(path: &Path, shift: f32, light: f32, bulge: f32) -> PathBuf {
    let mut g = Gltf::default();
    for (i, scale) in [(0, 1.0f32), (1, 1.0 + bulge)] {
        let m = cubist::scene::default::icosphere("sphere", 2, 1.0, 0);
        let p: Vec<f32> = m.positions.iter().flat_map(|v| [v.x * scale, v.y, v.z]).collect();
        let pos = g.floats(&p, 3, true);
        let idx: Vec<u32> = m.triangles.iter().flatten().copied().collect();
        let idx = g.indices(&idx);
        let mesh = g.mesh(json!({"POSITION": pos}), Some(idx), 4, None);
        let x = if i == 0 { -1.2 } else { 1.2 + shift };
        let node = g.node(json!({"mesh": mesh, "translation": [x, 0.0, 0.0]}));
        g.scene_nodes.push(node);
    }
    g.lights.push(json!({"type": "directional", "intensity": 3.0 * light}));
    g.extensions_used.push("KHR_lights_punctual".into());
    let l = g.node(
        json!({"rotation": [-0.38268343, 0.0, 0.0, 0.92387953], "extensions": {"KHR_lights_punctual": {"light": 0}}}),
    );
    g.scene_nodes.push(l);
    std::fs::write(path, g.to_glb()).unwrap();
    path.to_path_buf()
}

/// The files in `dir` other than `expected` (temporary files the server would have left).
fn strays(dir: &Path, expected: &[&str]) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !expected.contains(&n.as_str()))
        .collect()
}

#[test]
fn request_sequences_give_a_fresh_renders_pixels_at_each_invalidation_level() {
    let dir = tempfile::tempdir().unwrap();
    let work = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut server = Server::start();
    let base = json!({"width": 96, "height": 72, "spp": 2});
    let with = |extra: Value| {
        let mut s = base.clone();
        for (k, v) in extra.as_object().unwrap() {
            s[k] = v.clone();
        }
        s
    };
    let steps: Vec<(&str, Value, Vec<&str>)> = vec![
        ("first", base.clone(), vec![]),
        (
            "unchanged",
            base.clone(),
            vec!["pre-render", "saliency", "faceting", "imprecision", "re-trace", "anti-aliasing", "paint", "encode"],
        ),
        (
            "paint",
            with(json!({"border_width": 4.0, "palette": "grey"})),
            vec!["pre-render", "saliency", "faceting", "imprecision", "re-trace", "anti-aliasing"],
        ),
        (
            "aims",
            with(json!({"border_width": 4.0, "palette": "grey", "discontinuity": 60.0})),
            vec!["pre-render", "saliency", "faceting"],
        ),
        (
            "facets",
            with(json!({"border_width": 4.0, "segments": [3, 9], "thresholds": [0.0, 0.2]})),
            vec!["pre-render", "saliency"],
        ),
        ("camera", with(json!({"camera_position": [0.3, 0.4, 2.5]})), vec![]),
    ];
    for (i, (what, settings, expect)) in steps.iter().enumerate() {
        let out = d.join(format!("{what}.png"));
        let r = server.ask(render(i as u64, None, settings.clone(), &out));
        assert_eq!(r["ok"], true, "{what}: {r}");
        assert_eq!(r["output"], json!(out));
        assert_eq!(reused(&r), *expect, "{what}");
        assert!(png(&out) == fresh(work.path(), None, settings, what), "{what}: not a fresh render's pixels");
        assert!(r["timings"]["total"].as_f64().unwrap() > 0.0);
    }

    // Raw output: the same pixels, no PNG.
    let raw = d.join("camera.rgba");
    let r = server.ask(render(10, None, steps[5].1.clone(), &raw));
    assert_eq!((r["width"].as_u64(), r["height"].as_u64()), (Some(96), Some(72)));
    assert_eq!(std::fs::read(&raw).unwrap(), png(&d.join("camera.png")).into_raw());

    // Passes, named by the request: written beside the output.
    let out = d.join("passes.png");
    let mut req = render(11, None, base.clone(), &out);
    req["passes"] = json!(["depth", "facet-ids", "saliency"]);
    let r = server.ask(req);
    assert_eq!(r["ok"], true, "{r}");
    for pass in ["depth", "facet-ids", "saliency"] {
        let p = d.join(format!("passes.{pass}.png"));
        assert!(p.is_file() && r["passes"][pass] == json!(p), "{pass}: {r}");
    }

    let stats = server.ask(json!({"id": 12, "cmd": "stats"}));
    assert_eq!(stats["stats"]["scene"], "<default scene>");
    assert_eq!(stats["stats"]["served"], 8);
    assert_eq!(stats["stats"]["lanes"][0]["width"], 96);
    assert!(server.ask(json!({"id": 13, "cmd": "shutdown"}))["ok"] == true);
    assert!(server.close().success());
    let expected = [
        "first.png",
        "unchanged.png",
        "paint.png",
        "aims.png",
        "facets.png",
        "camera.png",
        "camera.rgba",
        "passes.png",
    ];
    let mut all: Vec<&str> = expected.to_vec();
    let passes = ["passes.depth.png", "passes.facet-ids.png", "passes.saliency.png"];
    all.extend(passes);
    assert_eq!(strays(d, &all), Vec::<String>::new());
}

#[test]
fn a_changed_scene_file_reuses_what_its_content_allows() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut server = Server::start();
    let settings = json!({"width": 80, "height": 60, "spp": 1});
    let cases = [
        (
            "a",
            0.0,
            1.0,
            0.0,
            json!({"changed": true, "reloaded": true, "bvh_rebuilt": true, "meshes": 2, "meshes_changed": 2}),
        ),
        // The same bytes at the same path: not even read again.
        (
            "a",
            0.0,
            1.0,
            0.0,
            json!({"changed": false, "reloaded": false, "bvh_rebuilt": false, "meshes": 2, "meshes_changed": 0}),
        ),
        // The light: a new picture, the same BVH.
        (
            "b",
            0.0,
            0.5,
            0.0,
            json!({"changed": true, "reloaded": true, "bvh_rebuilt": false, "meshes": 2, "meshes_changed": 0}),
        ),
        // A sphere moved: the BVH again, no mesh changed.
        (
            "c",
            0.4,
            0.5,
            0.0,
            json!({"changed": true, "reloaded": true, "bvh_rebuilt": true, "meshes": 2, "meshes_changed": 0}),
        ),
        // A sphere deformed: one mesh changed.
        (
            "d",
            0.4,
            0.5,
            0.3,
            json!({"changed": true, "reloaded": true, "bvh_rebuilt": true, "meshes": 2, "meshes_changed": 1}),
        ),
        // Another file with the first one's content: read, and compared with the last scene,
        // whose first sphere is the same mesh as the undeformed one.
        (
            "e",
            0.0,
            1.0,
            0.0,
            json!({"changed": true, "reloaded": true, "bvh_rebuilt": true, "meshes": 2, "meshes_changed": 0}),
        ),
    ];
    for (i, (name, shift, light, bulge, expect)) in cases.iter().enumerate() {
        let scene = scene_glb(&d.join(format!("{name}.glb")), *shift, *light, *bulge);
        let out = d.join(format!("{name}{i}.png"));
        let r = server.ask(render(i as u64, Some(&scene), settings.clone(), &out));
        assert_eq!(r["ok"], true, "{r}");
        assert_eq!(r["scene"], *expect, "step {i} ({name})");
        assert!(
            png(&out) == fresh(d, Some(&scene), &settings, &format!("fresh{i}")),
            "step {i}: not a fresh render's pixels"
        );
    }
}

#[test]
fn bad_requests_get_an_error_and_the_server_keeps_serving() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut server = Server::start();
    let out = d.join("ok.png");
    let bad: Vec<(String, &str)> = vec![
        ("this is not json".into(), "not JSON"),
        ("[1, 2]".into(), "JSON object"),
        (json!({"id": 1}).to_string(), "no `cmd`"),
        (json!({"id": 2, "cmd": "paint"}).to_string(), "unknown cmd `paint`"),
        (json!({"id": 3, "cmd": "render"}).to_string(), "missing field `output`"),
        (render(4, None, json!({"widht": 10}), &out).to_string(), "unknown key `widht`"),
        (render(5, None, json!({"width": 0}), &out).to_string(), "width"),
        (render(6, None, json!({"camera": "fisheye"}), &out).to_string(), "fisheye"),
        (render(7, Some(&d.join("missing.glb")), json!({}), &out).to_string(), "missing.glb"),
        (render(8, None, json!({"width": 16, "height": 12}), &d.join("out.jpg")).to_string(), ".png or .rgba"),
        (
            render(9, None, json!({"width": 16, "height": 12}), &d.join("no/such/dir/o.png")).to_string(),
            "does not exist",
        ),
        (json!({"id": 10, "cmd": "stats", "verbose": true}).to_string(), "unknown field `verbose`"),
        (format!("{{\"id\": 11, \"cmd\": \"stats\", \"pad\": \"{}\"}}", "x".repeat(1 << 21)), "longer than"),
    ];
    for (line, says) in &bad {
        server.send_line(line);
        let r = server.reply();
        assert_eq!(r["ok"], false, "{r}");
        let error = r["error"].as_str().unwrap();
        assert!(error.contains(says), "expected `{says}` in: {error}");
        assert!(!error.contains('\n'));
    }
    // Still serving, and the bad requests left nothing behind.
    let r = server.ask(render(20, None, json!({"width": 32, "height": 24, "spp": 1}), &out));
    assert_eq!(r["ok"], true, "{r}");
    assert!(server.close().success());
    assert_eq!(strays(d, &["ok.png"]), Vec::<String>::new());
}

#[test]
fn cancel_stops_a_running_render_and_drops_queued_ones() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let mut server = Server::start();
    // Long enough to be running when the cancel arrives (seconds uncancelled); the cancel is
    // sent once its progress shows it running.
    let big = json!({"width": 1200, "height": 1200, "spp": 4});
    let mut first = render(1, None, big.clone(), &d.join("big.png"));
    first["progress"] = json!(true);
    server.send(&first);
    server.send(&render(2, None, big.clone(), &d.join("queued.png")));
    server.send(&render(3, None, big, &d.join("third.png")));
    let line = server.stderr.recv_timeout(Duration::from_secs(120)).expect("progress");
    assert!(line.starts_with("PROGRESS "), "{line}");
    // The queued one by its id: answered at once.
    server.send(&json!({"id": 4, "cmd": "cancel", "target": 2}));
    assert_eq!(server.reply(), json!({"id": 2, "ok": false, "error": "cancelled", "cancelled": true}));
    assert_eq!(server.reply(), json!({"id": 4, "ok": true, "cancelled": [2]}));
    // Everything else: the running one stops within seconds.
    let t = Instant::now();
    server.send(&json!({"id": 5, "cmd": "cancel"}));
    let mut got = [server.reply(), server.reply(), server.reply()];
    got.sort_by_key(|r| r["id"].as_u64());
    assert_eq!(got[0], json!({"id": 1, "ok": false, "error": "cancelled", "cancelled": true}));
    assert_eq!(got[1], json!({"id": 3, "ok": false, "error": "cancelled", "cancelled": true}));
    assert_eq!(got[2]["cancelled"], json!([1, 3]));
    assert!(t.elapsed() < Duration::from_secs(20), "the cancel took {:?}", t.elapsed());
    // A cancel with nothing to cancel.
    assert_eq!(server.ask(json!({"id": 6, "cmd": "cancel"}))["cancelled"], json!([]));
    // The next render is whole and right.
    let small = json!({"width": 48, "height": 36, "spp": 1});
    let r = server.ask(render(7, None, small.clone(), &d.join("after.png")));
    assert_eq!(r["ok"], true, "{r}");
    assert!(server.close().success());
    assert_eq!(strays(d, &["after.png"]), Vec::<String>::new(), "a cancelled render wrote something");
    let work = tempfile::tempdir().unwrap();
    assert!(png(&d.join("after.png")) == fresh(work.path(), None, &small, "after"));
}

#[test]
fn the_end_of_stdin_ends_the_server_once_its_renders_are_done() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("last.png");
    let mut server = Server::start();
    server.send(&render(1, None, json!({"width": 40, "height": 30, "spp": 1}), &out));
    server.stdin = None;
    let r = server.reply();
    assert_eq!((r["id"].clone(), r["ok"].clone()), (json!(1), json!(true)), "{r}");
    let status = wait(&mut server.child, Duration::from_secs(30)).expect("ended");
    assert!(status.success());
    assert!(out.is_file());
    // Nothing at all asked: ends at once.
    let t = Instant::now();
    assert!(Server::start().close().success());
    assert!(t.elapsed() < Duration::from_secs(10));
}

/// The parent dies while its pipe to the server stays open (a grandchild holds it): the
/// server notices it has a new parent and ends. `--parent` names the parent, so a parent gone
/// before the server started is noticed too.
#[cfg(unix)]
#[test]
fn the_parents_death_ends_the_server() {
    let script = format!("exec 3<&0; {} serve --parent $$ <&3 >/dev/null 2>&1 & echo $!", common::binary().display());
    let mut sh = Command::new("sh").args(["-c", &script]).stdin(Stdio::piped()).stdout(Stdio::piped()).spawn().unwrap();
    let mut pid = String::new();
    BufReader::new(sh.stdout.take().unwrap()).read_line(&mut pid).unwrap();
    let pid: u32 = pid.trim().parse().unwrap();
    let _keep_open = sh.stdin.take();
    assert!(sh.wait().unwrap().success());
    let proc_dir = PathBuf::from(format!("/proc/{pid}"));
    let t = Instant::now();
    while proc_dir.exists() && t.elapsed() < Duration::from_secs(20) {
        // A zombie is gone for our purpose.
        let stat = std::fs::read_to_string(proc_dir.join("stat")).unwrap_or_default();
        if stat.split_whitespace().nth(2) == Some("Z") {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let stat = std::fs::read_to_string(proc_dir.join("stat")).unwrap_or_default();
    assert!(stat.is_empty() || stat.split_whitespace().nth(2) == Some("Z"), "still running: {stat}");
}

/// Every field of every reply the server gives (nested objects too) and every request field
/// is named in docs/serve.md, as `field`, and so is every timing step.
#[test]
fn a_background_render_gives_a_fresh_renders_pixels_and_keeps_its_stages() {
    let dir = tempfile::tempdir().unwrap();
    let mut server = Server::start();
    let settings = json!({"width": 64, "height": 48, "spp": 2});
    let mut request = render(1, None, settings.clone(), &dir.path().join("background.png"));
    request["background"] = json!(true);
    let r = server.ask(request);
    assert_eq!(r["ok"], json!(true), "{r}");
    assert_eq!(png(&dir.path().join("background.png")), fresh(dir.path(), None, &settings, "background"));
    // What it kept serves the same render asked in the foreground.
    let r = server.ask(render(2, None, settings, &dir.path().join("foreground.png")));
    assert!(reused(&r).contains(&"paint".to_string()), "{r}");
    assert_eq!(png(&dir.path().join("foreground.png")), png(&dir.path().join("background.png")));
}

#[test]
fn docs_serve_md_names_every_request_and_reply_field() {
    let doc = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/serve.md")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut server = Server::start();
    let settings = json!({"width": 40, "height": 30, "spp": 1});
    let mut replies = Vec::new();
    let mut request = render(1, None, settings.clone(), &dir.path().join("a.png"));
    request["passes"] = json!(["depth"]);
    request["progress"] = json!(true);
    request["background"] = json!(false);
    let requests = [
        request,
        json!({"id": 2, "cmd": "cancel", "target": 99}),
        json!({"id": 3, "cmd": "stats"}),
        json!({"id": 4, "cmd": "render", "output": dir.path().join("b.txt")}),
    ];
    for r in &requests {
        replies.push(server.ask(r.clone()));
    }
    // A cancelled render's reply: long enough to be running when the cancel arrives (seconds
    // uncancelled), the cancel sent once its progress shows it running (a fixed sleep lost the
    // race on a fast host: the render was done before the cancel came).
    while server.stderr.try_recv().is_ok() {}
    let slow = json!({"width": 1200, "height": 1200, "spp": 4});
    let mut slow = render(5, None, slow, &dir.path().join("c.png"));
    slow["progress"] = json!(true);
    server.send(&slow);
    let line = server.stderr.recv_timeout(Duration::from_secs(120)).expect("progress");
    assert!(line.starts_with("PROGRESS "), "{line}");
    server.send(&json!({"id": 6, "cmd": "cancel"}));
    replies.push(server.reply());
    replies.push(server.reply());
    replies.push(server.ask(json!({"id": 7, "cmd": "shutdown"})));
    assert!(replies.iter().any(|r| r["cancelled"] == json!(true)), "{replies:?}");

    fn keys(v: &Value, parent: &str, out: &mut Vec<String>) {
        match v {
            // Pass names and timing step names are values the docs list, not fields; settings
            // keys are `cubist settings --schema`'s.
            Value::Object(m) if !["passes", "timings", "settings"].contains(&parent) => {
                for (k, v) in m {
                    out.push(k.clone());
                    keys(v, k, out);
                }
            }
            Value::Array(items) => items.iter().for_each(|i| keys(i, parent, out)),
            _ => {}
        }
    }
    let mut fields = Vec::new();
    for v in requests.iter().chain(&replies) {
        keys(v, "", &mut fields);
    }
    for step in replies[0]["timings"].as_object().unwrap().keys() {
        fields.push(step.clone());
    }
    fields.sort();
    fields.dedup();
    let missing: Vec<&String> = fields.iter().filter(|f| !doc.contains(&format!("`{f}`"))).collect();
    assert!(missing.is_empty(), "docs/serve.md does not name {missing:?}");
    assert!(fields.len() > 30, "{fields:?}");
}

/// A FIFO as the scene or as the facet layout gets an error reply, without blocking the server
/// (hashing a file to see whether it changed must not read a FIFO).
#[cfg(unix)]
#[test]
fn a_fifo_as_scene_or_layout_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo.glb");
    let fifo_png = dir.path().join("fifo.png");
    let st = Command::new("mkfifo").arg(&fifo).arg(&fifo_png).status().expect("mkfifo");
    assert!(st.success());
    let mut server = Server::start();
    let small = json!({"width": 16, "height": 12, "spp": 1});
    server.send(&render(1, Some(&fifo), small.clone(), &dir.path().join("a.png")));
    let mut layout = small.clone();
    layout["facets"] = json!(fifo_png);
    server.send(&render(2, None, layout, &dir.path().join("b.png")));
    server.send(&render(3, None, small, &dir.path().join("c.png")));
    for id in 1..=3 {
        let r = server.replies.recv_timeout(Duration::from_secs(60)).expect("a reply within a minute");
        assert_eq!(r["id"], json!(id), "{r}");
        if id < 3 {
            assert_eq!(r["ok"], json!(false), "{r}");
            assert!(r["error"].as_str().unwrap().contains("not a regular file"), "{r}");
        } else {
            assert_eq!(r["ok"], json!(true), "{r}");
        }
    }
    server.ask(json!({"id": 4, "cmd": "shutdown"}));
}
