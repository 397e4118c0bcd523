//! The crate's module structure, read from the `crate::` paths in src/ (ARCHITECTURE.md):
//! data flows one way, cli -> settings -> pipeline -> stages, with no import cycle between
//! top-level modules. Test code (`tests.rs` files and `#[cfg(test)]` modules, which close
//! each file) may reach across, so it is not read.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Top-level module -> the top-level modules its non-test code names as `crate::<module>`.
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap();
        let first = rel.components().next().unwrap().as_os_str().to_string_lossy().into_owned();
        let module = first.trim_end_matches(".rs").to_string();
        if module == "lib" || module == "main" || rel.file_name().is_some_and(|n| n == "tests.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let code = text.split("#[cfg(test)]").next().unwrap();
        let deps = graph.entry(module.clone()).or_default();
        for line in code.lines().map(|l| l.split("//").next().unwrap()) {
            for (i, _) in line.match_indices("crate::") {
                let name: String =
                    line[i + 7..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                if !name.is_empty() && name != module {
                    deps.insert(name);
                }
            }
        }
    }
    graph
}

/// A cycle through `start`, if any (depth-first).
fn cycle_from(graph: &BTreeMap<String, BTreeSet<String>>, start: &str) -> Option<Vec<String>> {
    fn walk(
        graph: &BTreeMap<String, BTreeSet<String>>,
        start: &str,
        at: &str,
        path: &mut Vec<String>,
        seen: &mut BTreeSet<String>,
    ) -> bool {
        for next in graph.get(at).into_iter().flatten() {
            if next == start {
                path.push(next.clone());
                return true;
            }
            if seen.insert(next.clone()) {
                path.push(next.clone());
                if walk(graph, start, next, path, seen) {
                    return true;
                }
                path.pop();
            }
        }
        false
    }
    let mut path = vec![start.to_string()];
    walk(graph, start, start, &mut path, &mut BTreeSet::new()).then_some(path)
}

#[test]
fn no_import_cycle_between_top_level_modules() {
    let graph = imports();
    assert!(graph.len() > 15, "read {} modules: {:?}", graph.len(), graph.keys());
    for m in graph.keys() {
        if let Some(cycle) = cycle_from(&graph, m) {
            panic!("import cycle: {}", cycle.join(" -> "));
        }
    }
}

#[test]
fn settings_depends_only_on_error() {
    let graph = imports();
    let deps: Vec<&String> = graph["settings"].iter().collect();
    assert_eq!(deps, ["error"], "settings imports {deps:?}");
}

/// Stages take their own parameters: only the fronts (the command line, the render server)
/// and the pipeline (which builds every stage's parameters, `pipeline::params`) read
/// `Settings`; only the fronts run the pipeline.
#[test]
fn only_the_fronts_and_the_pipeline_read_settings() {
    let graph = imports();
    let readers: BTreeSet<&str> =
        graph.iter().filter(|(_, d)| d.contains("settings")).map(|(m, _)| m.as_str()).collect();
    assert_eq!(readers, BTreeSet::from(["cli", "pipeline", "serve"]));
    let runners: BTreeSet<&str> =
        graph.iter().filter(|(_, d)| d.contains("pipeline")).map(|(m, _)| m.as_str()).collect();
    assert_eq!(runners, BTreeSet::from(["cli", "serve"]));
    // The check reads what it should: a stage that does import others is seen doing so.
    assert!(graph["pipeline"].contains("facets") && graph["facets"].contains("film"));
}
