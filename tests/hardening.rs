//! Hardening: bounded memory and time for every input, no panic, all-or-nothing
//! output, bad input refused with errors naming the setting or the glTF object, short
//! messages, long file names, no path escape. Each class has a generator of inputs made in
//! code (not the examples alone): every numeric setting at every extreme value, every
//! file the renderer reads replaced by a special file, images and accessors of every hostile
//! size, every output write made to fail.
//!
//! The binary's runs are under an address-space limit (`ulimit -v`), so an input that made
//! the renderer allocate without bound fails the test instead of the machine.

mod common;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use common::gltf_builder::{Gltf, quad};
use cubist::pipeline::{Prepared, render};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::schema::{FIELDS, Kind};
use cubist::settings::{Preset, Settings};
use serde_json::{Map, Value, json};

const BIN: &str = env!("CARGO_BIN_EXE_cubist");
/// Address space the binary may use in these tests, KiB: the largest legitimate input here
/// needs a few hundred megabytes.
const MEMORY_KB: u64 = 3 << 20;

fn within<T: Send + 'static>(secs: u64, what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    match rx.recv_timeout(Duration::from_secs(secs)) {
        Ok(v) => v,
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("{what}: still running after {secs} s (a hang?)"),
        Err(mpsc::RecvTimeoutError::Disconnected) => panic!("{what}: panicked"),
    }
}

/// The binary's run: exit code, stderr.
struct Run {
    code: Option<i32>,
    stderr: String,
}

impl Run {
    fn first_line(&self) -> &str {
        self.stderr.lines().next().unwrap_or("")
    }
}

/// Runs the binary with `args` in `dir`, under the address-space limit and a timeout.
fn cubist(dir: &Path, args: &[&str], secs: u64) -> Run {
    let mut cmd = Command::new("sh");
    cmd.arg("-c").arg(format!("ulimit -v {MEMORY_KB}; exec \"$0\" \"$@\"")).arg(BIN).args(args);
    cmd.current_dir(dir).stdin(Stdio::null()).stdout(Stdio::null()).stderr(Stdio::piped());
    let mut child = cmd.spawn().unwrap();
    let mut err = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = err.read_to_string(&mut s);
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(secs) {
            let _ = child.kill();
            panic!("cubist {args:?}: still running after {secs} s (a hang?)");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Run { code: status.code(), stderr: reader.join().unwrap() }
}

/// A clean refusal: exit `code`, one line naming `names` (any of them), no panic.
fn assert_refused(r: &Run, code: i32, names: &[&str], what: &str) {
    assert!(!r.stderr.contains("panicked"), "{what}: panic: {}", r.stderr);
    assert_eq!(r.code, Some(code), "{what}: exit {:?}: {}", r.code, r.stderr);
    let line = r.first_line();
    assert!(line.starts_with("error: "), "{what}: {}", r.stderr);
    assert!(names.iter().any(|n| line.contains(n)), "{what}: the error does not name {names:?}: {line}");
    assert!(line.chars().count() < 1000, "{what}: a {}-character message", line.chars().count());
    assert_no_long_number(line, what);
}

/// Huge numbers are shortened (`1e300`, not 301 digits): no run of 25 or more digits.
fn assert_no_long_number(line: &str, what: &str) {
    let mut run = 0;
    for c in line.chars() {
        run = if c.is_ascii_digit() { run + 1 } else { 0 };
        assert!(run < 25, "{what}: a number echoed in full: {line}");
    }
}

// ---- 1. panics: every numeric setting at every extreme

/// Extreme values of every type: the limits of f32 and f64, tiny and huge, negative zero,
/// integers past 2^53 and u64.
fn extremes() -> Vec<Value> {
    let mut v: Vec<Value> = [
        0.0,
        -0.0,
        1e-300,
        -1e-300,
        1e-40,
        1.0,
        -1.0,
        0.5,
        1e6,
        1e9,
        3.5e38,
        1e38,
        -1e38,
        1e40,
        1e300,
        -1e300,
        f64::MAX,
        f64::MIN,
        2e20,
    ]
    .iter()
    .map(|x| json!(x))
    .collect();
    v.extend([json!(u64::MAX), json!(1u64 << 53), json!(4294967296u64), json!(-1i64), json!(i64::MIN)]);
    v
}

/// Every numeric key, and every item of every numeric array, at every extreme value, through
/// the flags layer: a clean error naming the key, or settings that render a tiny image
/// without a panic, a NaN pixel or a hang.
#[test]
fn every_numeric_setting_at_every_extreme_is_refused_or_rendered() {
    let prep = std::sync::Arc::new(Prepared::new(cubist::scene::Scene::default_scene()));
    let mut cases = 0;
    for f in FIELDS {
        let kind = f.items.unwrap_or(f.kind);
        if !matches!(kind, Kind::Integer | Kind::Number) {
            continue;
        }
        for x in extremes() {
            let value = match (f.kind, f.length) {
                (Kind::Array, Some(n)) => json!(vec![x.clone(); n]),
                (Kind::Array, None) => json!([x.clone()]),
                _ => x.clone(),
            };
            let mut flags = Map::new();
            flags.insert(f.key.into(), value.clone());
            // Images stay tiny: the point is the value, not the time.
            for k in ["width", "height"] {
                if f.key != k {
                    flags.insert(k.into(), json!(16));
                }
            }
            if f.key == "thresholds" {
                flags.insert("segments".into(), json!([5]));
            }
            if f.key == "segments" {
                flags.insert("thresholds".into(), json!([0.0]));
            }
            let what = format!("{} = {value}", f.key);
            match Settings::from_layers(None, flags) {
                Err(e) => {
                    let m = e.to_string();
                    assert!(m.contains(&format!("`{}`", f.key)), "{what}: the error does not name the key: {m}");
                    assert!(m.chars().count() < 400 && !m.contains('\n'), "{what}: {m}");
                    assert_no_long_number(&m, &what);
                }
                Ok(mut s) => {
                    if s.width as u64 * s.height as u64 * s.spp as u64 > 4096 {
                        // Accepted large images are the memory test's business.
                        continue;
                    }
                    s.seed %= 1000;
                    let prep = prep.clone();
                    within(60, &what.clone(), move || {
                        if let Ok(r) = render(&prep, &s, &Progress::silent()) {
                            assert!(r.film.color.iter().all(|c| c.is_finite()), "{what}: NaN pixel");
                        }
                    });
                }
            }
            cases += 1;
        }
    }
    assert!(cases > 500, "{cases} cases");
}

/// The flag values, through the binary: exit 2 with the flag or key named, never 101.
#[test]
fn non_finite_and_huge_flag_values_name_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let mut cases = 0;
    for f in FIELDS {
        let kind = f.items.unwrap_or(f.kind);
        if kind != Kind::Number {
            continue;
        }
        let flag = format!("--{}", if f.key == "passes" { "pass" } else { f.key }.replace('_', "-"));
        for v in ["nan", "inf", "-inf", "1e308", "1e400", "1e40", "-1e308"] {
            let value = match f.length {
                Some(n) => vec![v; n].join(","),
                None => v.to_string(),
            };
            let arg = format!("{flag}={value}");
            let r = cubist(dir.path(), &["settings", &arg], 30);
            if r.code == Some(0) {
                // A value that is legal (1e308 as a camera position is not; 1e40 ambiguity is not).
                panic!("{arg} accepted");
            }
            assert_refused(&r, 2, &[&flag, &format!("`{}`", f.key)], &arg);
            assert!(!r.first_line().contains("'flags'") && !r.first_line().contains("`flags`"), "{arg}: {}", r.stderr);
            cases += 1;
        }
    }
    assert!(cases > 100, "{cases}");
    // A vector blamed on the right key, and wrong lengths.
    let r = cubist(dir.path(), &["settings", "--camera-position=1e300,1e300,1e300"], 30);
    assert_refused(&r, 2, &["camera_position"], "camera position 1e300");
    for (args, key) in [
        (["--stroke-length", "1e300"], "stroke_length"),
        (["--stroke-width", "0"], "stroke_width"),
        (["--brushwork", "nan"], "--brushwork"),
        (["--canvas-grain", "1e40"], "canvas_grain"),
        (["--border-style", "1e300"], "--border-style"),
    ] {
        let r = cubist(dir.path(), &["settings", args[0], args[1]], 30);
        assert_refused(&r, 2, &[key], &args.join(" "));
    }
    let r = cubist(dir.path(), &["settings", "--camera-up=1,2"], 30);
    assert_refused(&r, 2, &["camera_up"], "camera up of two numbers");
    let r = cubist(dir.path(), &["settings", "--segments", "1000,2000,3000", "--thresholds", "0,0,0"], 30);
    assert_refused(&r, 2, &["segments"], "segments 1000,2000,3000");
    let levels = vec!["5"; 3000].join(",");
    let zeros = vec!["0"; 3000].join(",");
    let r = cubist(dir.path(), &["settings", "--segments", &levels, "--thresholds", &zeros], 30);
    assert_refused(&r, 2, &["segments"], "3000 levels");
}

/// A config file's bad value is blamed on the file and its key.
#[test]
fn config_values_name_their_key() {
    let dir = tempfile::tempdir().unwrap();
    for (key, value) in [
        ("fill", json!("x")),
        ("weight_colour", json!(1e38)),
        ("border_width", json!(1e40)),
        ("camera_up", json!([1, 2])),
        ("exposure", json!(1e39)),
        ("segments", json!([100000])),
        // The painterly keys, added after the hardening: the same classes hold.
        ("stroke_length", json!(1e300)),
        ("stroke_length", json!(-1.0)),
        ("stroke_width", json!(0.0)),
        ("stroke_width", json!(-0.0)),
        ("brushwork", json!(1e39)),
        ("brushwork", json!(null)),
        ("plane_light", json!(-1e-300)),
        ("canvas_grain", json!(f64::MAX)),
        ("border_style", json!("x")),
        ("border_style", json!(1e300)),
    ] {
        let cfg = dir.path().join("c.json");
        std::fs::write(&cfg, json!({ key: value }).to_string()).unwrap();
        let r = cubist(dir.path(), &["settings", "--config", cfg.to_str().unwrap()], 30);
        assert_refused(&r, 2, &[&format!("`{key}`")], &format!("config {key} = {value}"));
    }
    // Every numeric key of the schema (new ones included) at hostile values: refused naming
    // the key, or accepted; never a panic, an error blaming another key, or a long echo.
    let mut cases = 0;
    for f in FIELDS {
        let kind = f.items.unwrap_or(f.kind);
        if !matches!(kind, Kind::Integer | Kind::Number) {
            continue;
        }
        for x in [json!(1e300), json!(-1e300), json!(f64::MIN_POSITIVE), json!("nan"), json!(u64::MAX)] {
            let value = match (f.kind, f.length) {
                (Kind::Array, Some(n)) => json!(vec![x.clone(); n]),
                (Kind::Array, None) => json!([x.clone()]),
                _ => x.clone(),
            };
            let cfg = dir.path().join("c.json");
            std::fs::write(&cfg, json!({ f.key: value }).to_string()).unwrap();
            let r = cubist(dir.path(), &["settings", "--config", cfg.to_str().unwrap()], 30);
            let what = format!("config {} = {value}", f.key);
            if r.code != Some(0) {
                assert_refused(&r, 2, &[&format!("`{}`", f.key)], &what);
            }
            cases += 1;
        }
    }
    assert!(cases >= 200, "{cases}");
}

/// stderr closed or its reader gone: an error, a warning or a `-v` line never panics.
#[test]
fn a_closed_stderr_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    for (args, want) in [
        (vec!["render", "--spp", "0"], 2),
        (vec!["render", "--preset", "plain", "--width", "8", "--height", "8", "-v", "-o", "o.png"], 0),
        (vec!["render", "missing.glb"], 1),
    ] {
        let mut child = Command::new(BIN)
            .args(&args)
            .current_dir(dir.path())
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        drop(child.stderr.take()); // the reader goes away: writes fail with EPIPE
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(want), "{args:?}");
    }
}

// ---- 2. unbounded memory: counts, images, special files

/// A GLB of a triangle whose POSITION accessor is replaced by `position`.
fn glb_with_position(position: Value) -> Vec<u8> {
    let mut g = Gltf::default();
    let m = quad(&mut g, None);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    g.accessors[0] = position;
    g.to_glb()
}

#[test]
fn accessor_counts_are_checked_before_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let mut cases = 0;
    for count in [(1u64 << 26) + 1, (1 << 28) - 1, (1 << 31) - 1, u32::MAX as u64] {
        for view in [None, Some(0), Some(-1)] {
            let mut acc =
                json!({"componentType": 5126, "count": count, "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 0]});
            match view {
                Some(-1) => {
                    // No data but one sparse substitution: all zeros, legal glTF.
                    acc["sparse"] = json!({"count": 1, "indices": {"bufferView": 2, "componentType": 5125},
                                           "values": {"bufferView": 0}});
                }
                Some(v) => acc["bufferView"] = json!(v),
                None => {}
            }
            let p = dir.path().join("a.glb");
            std::fs::write(&p, glb_with_position(acc)).unwrap();
            let r = cubist(dir.path(), &["render", "a.glb", "-o", "o.png"], 60);
            assert_refused(&r, 1, &["accessor 0", "accessors[0]", "POSITION"], &format!("count {count} view {view:?}"));
            cases += 1;
        }
    }
    assert_eq!(cases, 12);
    assert!(!dir.path().join("o.png").exists());
}

/// A tiny PNG declaring a huge image: 1-bit (compresses 8x better) or grey 8-bit.
fn huge_png(w: u32, h: u32, one_bit: bool) -> Vec<u8> {
    let mut out = Vec::new();
    write_huge_png(&mut out, w, h, one_bit);
    out
}

fn write_huge_png(out: &mut Vec<u8>, w: u32, h: u32, one_bit: bool) {
    let mut enc = png::Encoder::new(out, w, h);
    enc.set_color(png::ColorType::Grayscale);
    enc.set_depth(if one_bit { png::BitDepth::One } else { png::BitDepth::Eight });
    enc.set_compression(png::Compression::High);
    let mut wr = enc.write_header().unwrap();
    let row = if one_bit { w.div_ceil(8) } else { w } as usize;
    let mut stream = wr.stream_writer().unwrap();
    let zeros = vec![0u8; row];
    for _ in 0..h {
        std::io::Write::write_all(&mut stream, &zeros).unwrap();
    }
    stream.finish().unwrap();
}

#[test]
fn huge_images_are_refused_before_decoding_everywhere_an_image_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let images = [("bits.png", huge_png(23000, 23000, true)), ("grey.png", huge_png(16000, 16000, false))];
    for (name, png) in &images {
        assert!(png.len() < 1 << 20, "{name}: {} bytes", png.len());
        std::fs::write(d.join(name), png).unwrap();
        // As a texture: embedded in a GLB, and as a data: URI.
        let mut g = Gltf::default();
        let tex = g.texture_png(png);
        g.materials.push(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": tex}}}));
        let m = quad(&mut g, Some(0));
        let n = g.node(json!({"mesh": m}));
        g.scene_nodes.push(n);
        std::fs::write(d.join("t.glb"), g.to_glb()).unwrap();
        let r = cubist(d, &["render", "t.glb", "-o", "o.png"], 60);
        assert_refused(&r, 1, &["image 0"], &format!("{name} as a texture"));
        let mut json: Value = serde_json::from_str(&g.to_json()).unwrap();
        use base64::Engine;
        json["images"][0] = json!({"uri": format!("data:image/png;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(png))});
        std::fs::write(d.join("u.gltf"), json.to_string()).unwrap();
        let r = cubist(d, &["render", "u.gltf", "-o", "o.png"], 60);
        assert_refused(&r, 1, &["image 0"], &format!("{name} as a data: URI"));
        // As a facet map, a palette painting and a PNG layout.
        for args in [
            vec!["render", "--faceting", "constant", "--facet-map", name],
            vec!["render", "--palette-image", name],
            vec!["render", "--facets", name],
        ] {
            let mut a = args.clone();
            a.extend(["-o", "o.png", "--width", "32", "--height", "24"]);
            let r = cubist(d, &a, 60);
            assert_refused(&r, 1, &[name], &format!("{args:?}"));
        }
    }
    assert!(!d.join("o.png").exists());
}

/// Every file the renderer reads, replaced by a FIFO, /dev/zero, a symlink to it, a directory:
/// refused at once (a FIFO never blocks), whatever the role.
#[cfg(unix)]
#[test]
fn special_files_are_refused_in_every_role() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fifo = d.join("fifo.png");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.png")).unwrap();
    std::fs::create_dir(d.join("dir.png")).unwrap();
    for special in ["fifo.png", "zero.png", "/dev/zero", "/dev/urandom", "dir.png"] {
        // The scene itself, --config, a layout, a facet map, a palette painting.
        let roles: Vec<Vec<&str>> = vec![
            vec!["render", special],
            vec!["render", "--config", special],
            vec!["render", "--facets", special],
            vec!["render", "--faceting", "constant", "--facet-map", special],
            vec!["render", "--palette-image", special],
        ];
        for args in roles {
            let mut a = args.clone();
            a.extend(["-o", "o.png", "--width", "16", "--height", "12"]);
            let r = cubist(d, &a, 30);
            assert!(matches!(r.code, Some(1) | Some(2)), "{args:?}: {:?} {}", r.code, r.stderr);
            assert!(r.first_line().starts_with("error: "), "{args:?}: {}", r.stderr);
        }
        // As an image and as a buffer URI of a glTF in the same folder (allowed folder, so
        // the special file itself is what is refused).
        let name = Path::new(special).file_name().unwrap().to_str().unwrap();
        let local = if special.starts_with('/') { "link" } else { name };
        if special.starts_with('/') {
            let _ = std::fs::remove_file(d.join("link"));
            std::os::unix::fs::symlink(special, d.join("link")).unwrap();
        }
        let mut g = Gltf::default();
        let m = quad(&mut g, None);
        let n = g.node(json!({"mesh": m}));
        g.scene_nodes.push(n);
        let mut json: Value = serde_json::from_str(&g.to_json()).unwrap();
        json["buffers"][0]["uri"] = json!(local);
        std::fs::write(d.join("b.gltf"), json.to_string()).unwrap();
        let r = cubist(d, &["render", "b.gltf", "-o", "o.png", "--allow-external-files"], 30);
        assert_refused(&r, 1, &["buffer 0"], &format!("buffer uri {special}"));
    }
    // A saliency-cache entry that is a symlink to /dev/zero is ignored (and rewritten).
    let cache = d.join("cache");
    let r = cubist(d, &["saliency", "--saliency-cache", "cache", "-o", "s.png", "--width", "16", "--height", "12"], 60);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    for e in std::fs::read_dir(&cache).unwrap() {
        let p = e.unwrap().path();
        std::fs::remove_file(&p).unwrap();
        std::os::unix::fs::symlink("/dev/zero", &p).unwrap();
    }
    let r = cubist(d, &["saliency", "--saliency-cache", "cache", "-o", "s.png", "--width", "16", "--height", "12"], 60);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(!d.join("o.png").exists());
}

// ---- 3. hangs: work bounded up front

#[test]
fn layouts_that_would_take_hours_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let layout = |sites: Vec<[f64; 2]>, polygons: Value| {
        json!({"format": "cubist-facet-layout", "version": 1, "facet_count": 65536, "base": null,
               "sites": sites, "polygons": polygons})
    };
    // 65,536 sites, all outside the image.
    let outside: Vec<[f64; 2]> = (0..65536).map(|i| [2.0 + i as f64 * 1e-3, -1.0]).collect();
    // 65,536 full-image polygons.
    let full: Vec<Value> =
        (0..65536).map(|i| json!({"facet": i, "points": [[0, 0], [1, 0], [1, 1], [0, 1]]})).collect();
    // One polygon of a million points.
    let spiky: Vec<[f64; 2]> = (0..1_100_000).map(|i| [(i % 2) as f64, i as f64 / 1.1e6]).collect();
    let cases = [
        ("outside.json", layout(outside, json!([]))),
        ("full.json", layout(vec![], json!(full))),
        ("spiky.json", layout(vec![], json!([{"facet": 0, "points": spiky}]))),
    ];
    for (name, l) in cases {
        std::fs::write(d.join(name), l.to_string()).unwrap();
        let r = cubist(d, &["render", "--facets", name, "-o", "o.png", "--width", "1280", "--height", "960"], 60);
        assert_refused(&r, 1, &[name], name);
    }
    // Clustered sites inside the image are legal and fast (a k-d tree, not a bucket grid).
    let cluster: Vec<[f64; 2]> =
        (0..65536).map(|i| [0.5 + (i % 256) as f64 * 1e-7, 0.5 + (i / 256) as f64 * 1e-7]).collect();
    std::fs::write(d.join("cluster.json"), layout(cluster, json!([])).to_string()).unwrap();
    let r = cubist(
        d,
        &[
            "render",
            "--preset",
            "plain",
            "--facets",
            "cluster.json",
            "-o",
            "o.png",
            "--width",
            "1280",
            "--height",
            "960",
            "--spp",
            "1",
        ],
        60,
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
}

#[test]
fn many_lights_are_refused_before_tracing() {
    // 100,000 point lights: refused when loaded (a 4 MB file that would take half an hour).
    let mut g = Gltf::default();
    let m = quad(&mut g, None);
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    for i in 0..100_000 {
        g.lights.push(json!({"type": "point", "intensity": 1.0}));
        let n = g.node(json!({"extensions": {"KHR_lights_punctual": {"light": i}}}));
        g.scene_nodes.push(n);
    }
    let t = Instant::now();
    let e = Scene::from_slice(g.to_json().as_bytes()).unwrap_err().to_string();
    assert!(e.contains("lights"), "{e}");
    assert!(t.elapsed() < Duration::from_secs(30));
    // The most lights a file may hold, at a size where every light at every sample is too much.
    let mut scene = Scene::default_scene();
    let light = scene.lights.first().cloned().unwrap_or(cubist::scene::Light {
        kind: cubist::scene::LightKind::Point,
        color: glam::Vec3::ONE,
        intensity: 10.0,
        position: glam::DVec3::new(0.0, 3.0, 3.0),
        direction: glam::DVec3::NEG_Y,
    });
    scene.lights = vec![light; cubist::util::limits::MAX_LIGHTS];
    let prep = Prepared::new(scene);
    let mut s = Settings::preset(Preset::Plain);
    s.width = 1920;
    s.height = 1080;
    let t = Instant::now();
    let e = render(&prep, &s, &Progress::silent()).err().expect("refused").to_string();
    assert!(e.contains("light evaluations"), "{e}");
    assert!(t.elapsed() < Duration::from_secs(30), "refused after {:?}", t.elapsed());
}

// ---- 4. all or nothing

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn a_failed_write_leaves_nothing_new() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let small = ["--width", "32", "--height", "24", "--spp", "1"];
    // Each output made to fail in turn: a pass (its name taken by a directory), the layout
    // (a missing folder, and a bad extension), the main image (a directory).
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["render", "-o", "out.png", "--pass", "depth"], "out.depth.png"),
        (vec!["render", "-o", "out.png", "--pass", "facet-ids", "--pass", "normals"], "out.normals.png"),
        (vec!["render", "-o", "out.png", "--save-facets", "missing/l.json"], ""),
        (vec!["render", "-o", "out.png", "--save-facets", "taken.json"], "taken.json"),
        (vec!["facets", "-o", "out.png", "--save-facets", "taken.json"], "taken.json"),
        (vec!["facets", "-o", "out.png", "--pass", "segments"], "out.level2.png"),
        (vec!["render", "-o", "taken.png"], "taken.png"),
    ];
    for (args, blocker) in cases {
        if !blocker.is_empty() {
            std::fs::create_dir(d.join(blocker)).unwrap();
            std::fs::write(d.join(blocker).join("keep"), "").unwrap();
        }
        let before = names(d);
        let mut a = args.clone();
        a.extend(small);
        let r = cubist(d, &a, 60);
        assert_eq!(r.code, Some(1), "{args:?}: {}", r.stderr);
        assert_eq!(names(d), before, "{args:?} left files behind: {}", r.stderr);
        if !blocker.is_empty() {
            std::fs::remove_dir_all(d.join(blocker)).unwrap();
        }
    }
    // An existing output stays as it was when a later one fails.
    std::fs::write(d.join("out.png"), "old").unwrap();
    std::fs::create_dir(d.join("out.depth.png")).unwrap();
    std::fs::write(d.join("out.depth.png").join("keep"), "").unwrap();
    let mut a = vec!["render", "-o", "out.png", "--pass", "saliency", "--pass", "depth"];
    a.extend(small);
    let r = cubist(d, &a, 60);
    assert_eq!(r.code, Some(1), "{}", r.stderr);
    assert_eq!(std::fs::read_to_string(d.join("out.png")).unwrap(), "old");
    assert_eq!(names(d), ["out.depth.png", "out.png"]);
}

/// SIGTERM or SIGINT while the outputs are written: exit 143 or 130, and no temporary file.
#[cfg(unix)]
#[test]
fn a_signal_while_writing_leaves_no_temporary_file() {
    for (sig, code) in [(libc::SIGTERM, 143), (libc::SIGINT, 130)] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        // Big enough that the PNGs take a moment to encode.
        let mut child = Command::new(BIN)
            .args(["render", "--preset", "plain", "--width", "2048", "--height", "2048", "--spp", "1"])
            .args(["--pass", "depth", "--pass", "normals", "--pass", "objects", "--progress", "lines", "-o", "o.png"])
            .current_dir(d)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut err = child.stderr.take().unwrap();
        let mut seen = String::new();
        let mut buf = [0u8; 256];
        let start = Instant::now();
        while !seen.contains(" writing") {
            let n = err.read(&mut buf).unwrap();
            assert!(n > 0, "the render ended before writing: {seen}");
            seen.push_str(&String::from_utf8_lossy(&buf[..n]));
            assert!(start.elapsed() < Duration::from_secs(120), "no writing stage");
        }
        std::thread::sleep(Duration::from_millis(30));
        unsafe { libc::kill(child.id() as i32, sig) };
        let status = child.wait().unwrap();
        let left = names(d);
        if status.code() == Some(0) {
            // The write finished before the signal: all outputs, no temporary file.
            assert_eq!(left, ["o.depth.png", "o.normals.png", "o.objects.png", "o.png"]);
        } else {
            assert_eq!(status.code(), Some(code), "signal {sig}");
            assert!(
                left.is_empty() || left == ["o.depth.png", "o.normals.png", "o.objects.png", "o.png"],
                "signal {sig} left {left:?}"
            );
        }
        assert!(!left.iter().any(|n| n.ends_with(".tmp") || n.ends_with(".old")), "{left:?}");
    }
}

// ---- 5. bad scenes accepted: each refused naming the glTF object

#[test]
fn bad_scene_values_are_refused_naming_the_object() {
    let base = || {
        let mut g = Gltf::default();
        let m = quad(&mut g, None);
        let n = g.node(json!({"mesh": m}));
        g.scene_nodes.push(n);
        g
    };
    // Orthographic cameras of zero, NaN-free but degenerate, sizes.
    for (xmag, ymag) in [(1.0, 0.0), (0.0, 1.0), (0.0, 0.0), (1.0, -0.0)] {
        let mut g = base();
        g.cameras.push(
            json!({"type": "orthographic", "orthographic": {"xmag": xmag, "ymag": ymag, "znear": 0.1, "zfar": 10}}),
        );
        let n = g.node(json!({"camera": 0, "translation": [0, 0, 5]}));
        g.scene_nodes.push(n);
        let e = Scene::from_slice(g.to_json().as_bytes()).unwrap_err().to_string();
        assert!(e.contains("camera 0"), "{xmag} {ymag}: {e}");
    }
    // Every index past u32::MAX, wherever it is: a node's mesh, a scene's node, a child, an
    // accessor's bufferView, a primitive's attribute.
    for (path, value) in [
        ("/nodes/0/mesh", 4294967296u64),
        ("/nodes/0/mesh", u64::MAX),
        ("/scenes/0/nodes/0", 4294967296),
        ("/accessors/0/bufferView", 4294967297),
        ("/meshes/0/primitives/0/attributes/POSITION", 8589934592),
    ] {
        let g = base();
        let mut json: Value = serde_json::from_str(&g.to_json()).unwrap();
        *json.pointer_mut(path).unwrap() = json!(value);
        let e = Scene::from_slice(json.to_string().as_bytes()).unwrap_err().to_string();
        assert!(e.contains(&value.to_string()), "{path}: {e}");
    }
    // But the user's own extras may hold any number.
    let g = base();
    let mut json: Value = serde_json::from_str(&g.to_json()).unwrap();
    json["nodes"][0]["extras"] = json!({"timestamp": 1_700_000_000_000u64});
    Scene::from_slice(json.to_string().as_bytes()).unwrap();
    // A GLB whose header declares a length other than the file's.
    let glb = base().to_glb();
    for delta in [-4i64, 4, 1000] {
        let mut b = glb.clone();
        if delta > 0 {
            b.extend(std::iter::repeat_n(0u8, delta as usize));
        } else {
            let n = (b.len() as i64 + delta) as u32;
            b[8..12].copy_from_slice(&n.to_le_bytes());
        }
        let e = Scene::from_slice(&b).unwrap_err().to_string();
        assert!(e.contains("declares"), "{delta}: {e}");
    }
}

// ---- 6. messages: short, one line, first line names the problem

#[test]
fn long_paths_and_huge_numbers_are_shortened() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let long = format!("{}.glb", "x/".repeat(20_000));
    let r = cubist(d, &["render", &long], 30);
    assert_refused(&r, 1, &["…"], "a long scene path");
    let long_out = format!("{}.png", "y".repeat(5000));
    let r = cubist(d, &["render", "-o", &long_out, "--preset", "plain", "--width", "8", "--height", "8"], 30);
    assert_eq!(r.code, Some(1));
    assert!(r.first_line().chars().count() < 400, "{}", r.first_line());
    let digits = "9".repeat(10_000);
    let r = cubist(d, &["settings", "--width", &digits], 30);
    assert_eq!(r.code, Some(2));
    assert!(r.first_line().contains("--width") && r.first_line().chars().count() < 800, "{}", r.first_line());
    // clap's usage errors: the first line names what is missing.
    let r = cubist(d, &["faces"], 30);
    assert!(r.first_line().contains("<SCENES>"), "{}", r.stderr);
}

// ---- 7. a legal long output name works

#[test]
fn a_250_character_output_name_works() {
    let dir = tempfile::tempdir().unwrap();
    let name = format!("{}.png", "n".repeat(246));
    let save = format!("{}.json", "l".repeat(245));
    let r = cubist(
        dir.path(),
        &[
            "render",
            "--faceting",
            "voronoi",
            "-o",
            &name,
            "--pass",
            "facets",
            "--save-facets",
            &save,
            "--width",
            "16",
            "--height",
            "12",
        ],
        60,
    );
    // The pass's name (stem + ".facets.png") is past NAME_MAX: that one error is legitimate,
    // and then nothing is written.
    assert_eq!(r.code, Some(1), "{}", r.stderr);
    assert!(names(dir.path()).is_empty());
    let r = cubist(dir.path(), &["render", "-o", &name, "--save-facets", &save, "--width", "16", "--height", "12"], 60);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert_eq!(names(dir.path()), [save.clone(), name.clone()]);
}

// ---- 8. no path escape

#[test]
fn uris_outside_the_scene_folder_are_refused_unless_allowed() {
    let root = tempfile::tempdir().unwrap();
    let scene_dir = root.path().join("scene");
    std::fs::create_dir_all(scene_dir.join("textures")).unwrap();
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(2, 2, image::Rgba([200, 30, 30, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    std::fs::write(root.path().join("outside.png"), &png).unwrap();
    std::fs::write(scene_dir.join("textures/inside.png"), &png).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(root.path().join("outside.png"), scene_dir.join("link.png")).unwrap();
    let outside_abs = root.path().join("outside.png").to_str().unwrap().to_string();
    let mut uris = vec![
        "../outside.png".to_string(),
        "textures/../../outside.png".into(),
        "%2E%2E/outside.png".into(),
        "..%2Foutside.png".into(),
        outside_abs.clone(),
        "/etc/passwd".into(),
        "textures/../../../../../../../../etc/passwd".into(),
    ];
    if cfg!(unix) {
        uris.push("link.png".into());
    }
    for uri in &uris {
        for role in ["image", "buffer"] {
            let mut g = Gltf::default();
            let tex = g.texture_png(&png);
            g.materials.push(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": tex}}}));
            let m = quad(&mut g, Some(0));
            let n = g.node(json!({"mesh": m}));
            g.scene_nodes.push(n);
            let mut json: Value = serde_json::from_str(&g.to_json()).unwrap();
            if role == "image" {
                json["images"][0] = json!({"uri": uri});
            } else {
                json["buffers"].as_array_mut().unwrap().push(json!({"uri": uri, "byteLength": 1}));
            }
            std::fs::write(scene_dir.join("s.gltf"), json.to_string()).unwrap();
            let r = cubist(&scene_dir, &["render", "s.gltf", "-o", "o.png", "--width", "16", "--height", "12"], 30);
            assert_refused(&r, 1, &["outside the scene's folder", "absolute path"], &format!("{role} {uri}"));
            assert!(r.first_line().contains("--allow-external-files"), "{}", r.first_line());
            // The opt-out reads it (a PNG as a texture; anything as a buffer of 1 byte).
            if uri.ends_with("outside.png") || uri == "link.png" {
                let r = cubist(
                    &scene_dir,
                    &["render", "s.gltf", "-o", "o.png", "--width", "16", "--height", "12", "--allow-external-files"],
                    30,
                );
                assert_eq!(r.code, Some(0), "{role} {uri} allowed: {}", r.stderr);
            }
        }
    }
    // A file inside the folder is read by default.
    let mut g = Gltf::default();
    let tex = g.texture_png(&png);
    g.materials.push(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": tex}}}));
    let m = quad(&mut g, Some(0));
    let n = g.node(json!({"mesh": m}));
    g.scene_nodes.push(n);
    let mut json: Value = serde_json::from_str(&g.to_json()).unwrap();
    json["images"][0] = json!({"uri": "textures/inside.png"});
    std::fs::write(scene_dir.join("s.gltf"), json.to_string()).unwrap();
    let r = cubist(&scene_dir, &["render", "s.gltf", "-o", "o.png", "--width", "16", "--height", "12"], 30);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    // And from another working directory, by a relative scene path.
    let r = cubist(root.path(), &["render", "scene/s.gltf", "-o", "o.png", "--width", "16", "--height", "12"], 30);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
}

#[allow(dead_code)]
fn unused(_: PathBuf) {}
