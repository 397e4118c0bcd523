//! The crate's module structure, read from the `crate::` paths in src/ (ARCHITECTURE.md):
//! data flows one way, cli -> settings -> pipeline -> stages, with no import cycle between
//! top-level modules. Test code (`tests.rs` files and `#[cfg(test)] mod` blocks, wherever they
//! sit in a file) may reach across, so it is not read; everything else in a file is, including
//! production code after a test module.

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

/// The length of the item starting at `s[at..]` up to and including its matching `}` (or its
/// `;` when no block opens first), reading past string, char and comment text.
fn item_len(s: &str, at: usize) -> usize {
    let b = s.as_bytes();
    let (mut i, mut depth) = (at, 0usize);
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                i += s[i..].find('\n').unwrap_or(s.len() - i);
                continue;
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                i += s[i..].find("*/").map_or(s.len() - i, |e| e + 2);
                continue;
            }
            b'r' if matches!(b.get(i + 1), Some(b'"' | b'#')) && !is_ident(b, i) => {
                let hashes = b[i + 1..].iter().take_while(|&&c| c == b'#').count();
                if b.get(i + 1 + hashes) == Some(&b'"') {
                    let close = format!("\"{}", "#".repeat(hashes));
                    let body = i + 2 + hashes;
                    i = body + s[body..].find(&close).map_or(s.len() - body, |e| e + close.len());
                    continue;
                }
            }
            b'"' => {
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    i += if b[i] == b'\\' { 2 } else { 1 };
                }
            }
            // A char literal ('{', '\'', '\u{7b}'), not a lifetime ('a).
            b'\'' if b.get(i + 1) == Some(&b'\\') => {
                i += 2 + s[i + 2..].find('\'').unwrap_or(s.len() - i - 2);
            }
            b'\'' if b.get(i + 2) == Some(&b'\'') => i += 2,
            b'{' => depth += 1,
            b'}' => {
                depth -= 1;
                if depth == 0 {
                    return i + 1 - at;
                }
            }
            b';' if depth == 0 => return i + 1 - at,
            _ => {}
        }
        i += 1;
    }
    b.len() - at
}

fn is_ident(b: &[u8], i: usize) -> bool {
    i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_')
}

/// `text` without its `#[cfg(test)] mod NAME { ... }` (and `#[cfg(test)] mod NAME;`) items,
/// matched brace by brace, so production code after a test module is still read.
fn without_test_modules(text: &str) -> String {
    const ATTR: &str = "#[cfg(test)]";
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(at) = rest.find(ATTR) {
        let after = &rest[at + ATTR.len()..];
        // Further attributes (`#[allow(...)]`) and visibility may sit between it and `mod`.
        let mut item = after.trim_start();
        while item.starts_with("#[") {
            item = item[item.find(']').map_or(item.len(), |e| e + 1)..].trim_start();
        }
        let bare = item.strip_prefix("pub(crate) ").or_else(|| item.strip_prefix("pub ")).unwrap_or(item);
        if bare.starts_with("mod ") {
            let start = text.len() - item.len();
            out.push_str(&rest[..at]);
            let len = item_len(text, start);
            rest = &text[start + len..];
        } else {
            out.push_str(&rest[..at + ATTR.len()]);
            rest = after;
        }
    }
    out.push_str(rest);
    out
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
        let code = without_test_modules(&text);
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

/// The reader drops test modules, brace by brace, and keeps what follows them.
#[test]
fn test_modules_are_cut_out_and_code_after_them_is_kept() {
    let text = "use crate::a::X;\n#[cfg(test)]\nmod tests {\n    use crate::b::Y;\n    \
                fn f() { let s = \"}\"; let c = '}'; let r = r#\"}\"#; } // }\n    /* } */\n}\n\
                fn after<'a>(x: &'a str) { crate::c::z(x); }\n#[cfg(test)]\n#[allow(unused)]\n\
                pub(crate) mod more;\n#[cfg(test)]\nfn helper() { crate::d::w(); }\n";
    let kept = without_test_modules(text);
    assert!(kept.contains("crate::a::X") && kept.contains("crate::c::z"), "{kept}");
    assert!(!kept.contains("crate::b::Y") && !kept.contains("mod more"), "{kept}");
    // Only modules are test-only; another `#[cfg(test)]` item is read like any code.
    assert!(kept.contains("crate::d::w"), "{kept}");
}
