//! The house rules that a reader relies on: no source file of the engine or the service over 800
//! lines, and no import cycle among the service's modules (the library's and the binary's each
//! form a one-way graph).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_source_file_is_over_800_lines() {
    let mut files = Vec::new();
    rust_files(&repo().join("engine/src"), &mut files);
    rust_files(&repo().join("service/src"), &mut files);
    assert!(files.len() > 30, "{} files found", files.len());
    let long: Vec<String> = files
        .iter()
        .map(|f| (f, std::fs::read_to_string(f).unwrap().lines().count()))
        .filter(|(_, n)| *n > 800)
        .map(|(f, n)| format!("{}: {n} lines", f.display()))
        .collect();
    assert!(long.is_empty(), "split these into rooms: {long:?}");
}

/// The modules a crate root declares (`mod x;` / `pub mod x;`).
fn declared_modules(root: &str) -> BTreeSet<String> {
    root.lines()
        .filter_map(|l| {
            let l = l.trim_start().trim_start_matches("pub ").trim_start_matches("pub(crate) ");
            l.strip_prefix("mod ").and_then(|r| r.strip_suffix(';')).map(str::to_string)
        })
        .collect()
}

/// The code of a top-level module (its file, or every file of its folder), comments left out:
/// a doc link is not a dependency.
fn module_source(src: &Path, name: &str) -> String {
    let file = src.join(format!("{name}.rs"));
    let mut files = Vec::new();
    if file.is_file() {
        files.push(file);
    } else {
        rust_files(&src.join(name), &mut files);
    }
    files
        .iter()
        .flat_map(|f| std::fs::read_to_string(f).unwrap().lines().map(str::to_string).collect::<Vec<_>>())
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// A cycle in `graph`, if there is one.
fn find_cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = path.iter().position(|n| n == node) {
            let mut cycle = path[i..].to_vec();
            cycle.push(node.to_string());
            return Some(cycle);
        }
        if done.contains(node) {
            return None;
        }
        path.push(node.to_string());
        for next in graph.get(node).into_iter().flatten() {
            if let Some(c) = visit(next, graph, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(node.to_string());
        None
    }
    let mut done = BTreeSet::new();
    graph.keys().find_map(|n| visit(n, graph, &mut Vec::new(), &mut done))
}

#[test]
fn service_modules_import_one_way() {
    let src = repo().join("service/src");
    for root in ["lib.rs", "main.rs"] {
        let modules = declared_modules(&std::fs::read_to_string(src.join(root)).unwrap());
        assert!(modules.len() >= 4, "{root}: {modules:?}");
        let graph: BTreeMap<String, BTreeSet<String>> = modules
            .iter()
            .map(|m| {
                let text = module_source(&src, m);
                let uses =
                    modules.iter().filter(|o| *o != m && text.contains(&format!("crate::{o}"))).cloned().collect();
                (m.clone(), uses)
            })
            .collect();
        assert_eq!(find_cycle(&graph), None, "{root}: an import cycle among {graph:?}");
    }
    // The check finds a cycle where there is one.
    let cyclic = BTreeMap::from([
        ("a".to_string(), BTreeSet::from(["b".to_string()])),
        ("b".to_string(), BTreeSet::from(["a".to_string()])),
    ]);
    assert!(find_cycle(&cyclic).is_some());
}
