//! The memory bound (README "Limits"): a job's peak memory stays under the estimate
//! its settings are checked against (`Settings::memory_estimate`, refused above
//! `MAX_JOB_MEMORY`). Each run's peak resident memory is read from the kernel (wait4's
//! ru_maxrss) and compared with the estimate, for every kind of job at 1 Mpx: the estimate is
//! bytes per pixel, so holding here it holds at any size. The largest allowed jobs themselves
//! (8192 x 8192) take minutes: `scripts/memory_bound.sh` runs them, with its figures in
//! README.md, "Limits".
#![cfg(target_os = "linux")]

use std::process::{Command, Stdio};

use cubist::settings::Settings;
use serde_json::{Map, Value};

/// Runs the binary and returns its exit code and peak resident memory, bytes.
// The child is reaped by wait4 (for its rusage), which clippy does not see.
#[allow(clippy::zombie_processes)]
fn peak(args: &[&str], dir: &std::path::Path) -> (i32, u64) {
    let child = Command::new(env!("CARGO_BIN_EXE_cubist"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut status = 0;
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32);
    let code = if libc::WIFEXITED(status) { libc::WEXITSTATUS(status) } else { -1 };
    (code, usage.ru_maxrss as u64 * 1024)
}

/// The settings the flags make (as the binary resolves them).
fn settings_of(flags: &[&str]) -> Settings {
    let out = Command::new(env!("CARGO_BIN_EXE_cubist")).arg("settings").args(flags).output().unwrap();
    assert!(out.status.success(), "{flags:?}: {}", String::from_utf8_lossy(&out.stderr));
    let v: Value = serde_json::from_slice(&out.stdout).unwrap();
    let Value::Object(map) = v else { panic!("not an object") };
    Settings::from_layers(None, map.into_iter().collect::<Map<String, Value>>()).unwrap()
}

#[test]
fn peak_memory_stays_under_the_estimate_of_every_kind_of_job() {
    let dir = tempfile::tempdir().unwrap();
    let size = ["--width", "1024", "--height", "1024"];
    let jobs: Vec<(&str, Vec<&str>)> = vec![
        ("render", vec!["--preset", "plain", "--spp", "1"]),
        ("render", vec!["--preset", "plain", "--spp", "4"]),
        ("render", vec!["--preset", "plain", "--spp", "16"]),
        ("render", vec!["--spp", "1"]),
        ("render", vec!["--spp", "4"]),
        ("render", vec!["--faceting", "voronoi", "--spp", "1"]),
        ("render", vec!["--faceting", "patch", "--spp", "1", "--chiaroscuro", "0.5", "--colors", "8"]),
        ("render", vec!["--spp", "1", "--segments", "5,10,20,30,60,90,120,150", "--thresholds", "0,0,0,0,0,0,0,0"]),
        (
            "render",
            vec![
                "--spp",
                "1",
                "--pass",
                "saliency",
                "--pass",
                "facets",
                "--pass",
                "facet-ids",
                "--pass",
                "segments",
                "--pass",
                "objects",
                "--pass",
                "normals",
                "--pass",
                "depth",
            ],
        ),
        ("facets", vec!["--spp", "1", "--pass", "segments"]),
        ("saliency", vec!["--spp", "4"]),
    ];
    let mut report = Vec::new();
    for (command, flags) in &jobs {
        let mut f: Vec<&str> = flags.clone();
        f.extend(size);
        let estimate = settings_of(&f).memory_estimate();
        let mut args = vec![*command, "-o", "out.png"];
        args.extend(&f);
        let (code, peak) = peak(&args, dir.path());
        assert_eq!(code, 0, "{command} {f:?}");
        report.push(format!("{command} {flags:?}: peak {} MB, estimate {} MB", peak >> 20, estimate >> 20));
        // The estimate's per-pixel part against the peak less a fixed 16 MB (the binary, the
        // still life, thread stacks): so the bytes per pixel hold, not just the constant.
        let per_pixel_part = estimate - (64 << 20);
        assert!(
            peak <= per_pixel_part + (16 << 20),
            "{command} {f:?}: peak {peak} bytes above the estimate {estimate}\n{report:#?}"
        );
    }
    eprintln!("{}", report.join("\n"));
}

#[test]
fn jobs_above_the_bound_are_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    for flags in [
        vec!["--preset", "plain", "--width", "8192", "--height", "8192", "--spp", "4"],
        vec!["--width", "8192", "--height", "8192", "--spp", "1"],
        vec!["--preset", "plain", "--width", "16384", "--height", "4096", "--spp", "3"],
    ] {
        let mut args = vec!["render", "-o", "out.png"];
        args.extend(&flags);
        let t = std::time::Instant::now();
        let (code, peak) = peak(&args, dir.path());
        assert_eq!(code, 2, "{flags:?}");
        assert!(peak < 64 << 20 && t.elapsed().as_secs() < 10, "{flags:?}: {peak} bytes, {:?}", t.elapsed());
    }
    assert!(!dir.path().join("out.png").exists());
}
