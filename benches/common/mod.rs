//! Helpers the bench binaries share (each includes this file with `#[path]`): process CPU
//! time, the load average, and the target lines `scripts/bench.sh` gathers into the summary at
//! the top of BENCHMARKS.md.

#![allow(dead_code)]

use std::time::Duration;

/// CPU time (user + system) used so far by this process, every thread included, exited ones
/// too, from /proc/self/stat (10 ms resolution: time runs of a second or more, or average).
/// Unlike wall time it does not count the time other processes hold the cores, so it stays
/// comparable on a shared machine. None off Linux.
pub fn cpu_time() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // The fields after the command name (which may hold spaces) start after the last ')';
    // utime and stime are fields 14 and 15 of stat, the 12th and 13th after the ')'.
    let f: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks: u64 = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(Duration::from_millis(ticks * 10))
}

/// The 1, 5 and 15 minute load averages, "?" when unknown.
pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

/// Milliseconds, for tables.
pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// One line of the summary of targets: `TARGET | issue | what | target | measured | met |`.
/// `scripts/bench.sh` moves these lines out of the section they were printed in into the
/// summary table; run alone, a bench shows them where they were measured.
pub fn target(issue: u32, what: &str, target: &str, measured: &str, met: Option<bool>) {
    let verdict = match met {
        Some(true) => "yes",
        Some(false) => "**no**",
        None => "-",
    };
    println!("TARGET | {issue} | {what} | {target} | {measured} | {verdict} |");
}

/// `../shared/models/<name>.glb` beside the checkout, when present.
pub fn model(name: &str) -> Option<std::path::PathBuf> {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models").join(format!("{name}.glb"));
    p.is_file().then_some(p)
}
