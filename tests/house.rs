//! The house rules that a reader relies on: no source file of the engine or the service over 800
//! lines, no library function over 100, and no import circle between the files of a crate (a
//! module that imports another never is imported back, directly or around a circle; a folder's
//! `mod.rs` names its rooms and what they offer, and no room imports it back).

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

fn sources() -> Vec<PathBuf> {
    let mut files = Vec::new();
    for dir in ["engine/src", "service/src", "predictor/src"] {
        rust_files(&repo().join(dir), &mut files);
    }
    assert!(files.len() > 30, "{} files found", files.len());
    files
}

#[test]
fn no_source_file_is_over_800_lines() {
    let long: Vec<String> = sources()
        .iter()
        .map(|f| (f, std::fs::read_to_string(f).unwrap().lines().count()))
        .filter(|(_, n)| *n > 800)
        .map(|(f, n)| format!("{}: {n} lines", f.display()))
        .collect();
    assert!(long.is_empty(), "split these into rooms: {long:?}");
}

/// The functions of a file's code (its test module left out) with their line counts: from the
/// `fn` line to the line that closes its body at the same indentation.
fn functions(text: &str) -> Vec<(String, usize)> {
    let code = match text.find("#[cfg(test)]") {
        Some(at) => &text[..at],
        None => text,
    };
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let trimmed = line.trim_start();
        let words =
            trimmed.trim_start_matches("pub(crate) ").trim_start_matches("pub(super) ").trim_start_matches("pub ");
        let words = words.trim_start_matches("const ").trim_start_matches("unsafe ");
        let Some(rest) = words.strip_prefix("fn ") else { continue };
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let indent = line.len() - trimmed.len();
        let close = format!("{}}}", " ".repeat(indent));
        // A declaration without a body (a trait's) ends with `;` before any `{` line.
        if let Some(end) = lines[i..].iter().position(|l| *l == close || l.starts_with(&format!("{close} "))) {
            let body = &lines[i..i + end];
            if body.iter().any(|l| l.trim_end().ends_with('{')) {
                out.push((name, end + 1));
            }
        }
    }
    out
}

#[test]
fn no_library_function_is_over_100_lines() {
    let long: Vec<String> = sources()
        .iter()
        .flat_map(|f| {
            let text = std::fs::read_to_string(f).unwrap();
            functions(&text)
                .into_iter()
                .filter(|(_, n)| *n > 100)
                .map(move |(name, n)| format!("{}: {name} ({n} lines)", f.display()))
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(long.is_empty(), "split these into steps: {long:#?}");
    // The count finds a long function where there is one.
    let long_fn = format!("fn f() {{\n{}}}\n", "    x();\n".repeat(120));
    assert_eq!(functions(&long_fn), vec![("f".to_string(), 122)]);
}

#[test]
fn no_crate_has_an_import_circle() {
    // (The predictor is one file: nothing to go round.)
    for src in ["engine/src", "service/src"] {
        let graph = graph(&repo().join(src));
        assert!(!graph.is_empty(), "{src}: no modules found");
        let circles = circles(&graph);
        let shown: Vec<String> = circles
            .iter()
            .map(|c| {
                let arrows: Vec<String> = c
                    .iter()
                    .map(|m| format!("{m} -> {:?}", graph[m].iter().filter(|t| c.contains(t)).collect::<Vec<_>>()))
                    .collect();
                arrows.join("; ")
            })
            .collect();
        assert!(circles.is_empty(), "{src}: import circles: {shown:#?}");
    }
}

#[test]
fn the_import_graph_sees_what_a_file_names() {
    let modules: BTreeMap<String, PathBuf> =
        ["a", "a::b", "a::c", "d"].iter().map(|m| (m.to_string(), PathBuf::from(format!("{m}.rs")))).collect();
    let text = code("use super::{b::X, c};\nuse crate::d::Y; // crate::e\nlet s = \"crate::a\";\n");
    let found: Vec<String> = paths(&text, &[]).iter().filter_map(|p| resolve(p, "a::b", &modules)).collect();
    assert_eq!(found, ["a::b", "a::c", "d"]);
    // A child named without `self::` in a folder's mod.rs.
    assert_eq!(paths("pub use b::X;", &["b".to_string()]), ["self::b::X"]);
    // A circle is found where there is one, and only there.
    let cyclic = BTreeMap::from([
        ("a".to_string(), BTreeSet::from(["b".to_string()])),
        ("b".to_string(), BTreeSet::from(["a".to_string(), "c".to_string()])),
        ("c".to_string(), BTreeSet::new()),
    ]);
    assert_eq!(circles(&cyclic), vec![vec!["a".to_string(), "b".to_string()]]);
}

/// A crate's modules: module path ("simplify::kernel"; "" for the root) → file.
fn modules(src: &Path) -> BTreeMap<String, PathBuf> {
    fn walk(dir: &Path, prefix: &str, out: &mut BTreeMap<String, PathBuf>) {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
        entries.sort();
        for path in entries {
            let name = path.file_stem().unwrap().to_string_lossy().to_string();
            let child = if prefix.is_empty() { name.clone() } else { format!("{prefix}::{name}") };
            if path.is_dir() {
                walk(&path, &child, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let key = if matches!(name.as_str(), "mod" | "lib" | "main") { prefix.to_string() } else { child };
                out.insert(key, path);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, "", &mut out);
    out
}

/// The code of a file without comments, string literals and its test module.
fn code(text: &str) -> String {
    let text = match text.find("#[cfg(test)]") {
        Some(at) => &text[..at],
        None => text,
    };
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut line_out = String::new();
        let mut in_string = false;
        let mut chars = line.chars().peekable();
        let mut prev = ' ';
        while let Some(c) = chars.next() {
            if in_string {
                if c == '"' && prev != '\\' {
                    in_string = false;
                }
                prev = if prev == '\\' && c == '\\' { ' ' } else { c };
                continue;
            }
            if c == '/' && chars.peek() == Some(&'/') {
                break;
            }
            if c == '"' {
                in_string = true;
                prev = ' ';
                continue;
            }
            line_out.push(c);
            prev = c;
        }
        out.push_str(&line_out);
        out.push('\n');
    }
    out
}

/// Every path a piece of code names from `crate`, `super` or `self`, use trees expanded:
/// `use super::{a::X, b}` gives `super::a::X` and `super::b`.
fn paths(code: &str, children: &[String]) -> Vec<String> {
    let bytes: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    while i < bytes.len() {
        let start_ok = i == 0 || !(ident(bytes[i - 1]) || bytes[i - 1] == ':');
        let rest: String = bytes[i..(i + 7).min(bytes.len())].iter().collect();
        let head = ["crate::", "super::", "self::"].into_iter().find(|h| rest.starts_with(h));
        // A child module named without `self::` (`pub use obj::read_obj;` in a `mod.rs`).
        let child = || {
            let word: String = bytes[i..].iter().take_while(|&&c| ident(c)).collect();
            let after = i + word.chars().count();
            let path_follows = after + 1 < bytes.len() && bytes[after] == ':' && bytes[after + 1] == ':';
            (path_follows && children.contains(&word)).then_some(())
        };
        if start_ok && (head.is_some() || child().is_some()) {
            let (tree, end) = use_tree(&bytes, i);
            let tree = if head.is_some() { tree } else { tree.into_iter().map(|p| format!("self::{p}")).collect() };
            out.extend(tree);
            i = end.max(i + 1);
        } else {
            i += 1;
        }
    }
    out
}

/// Expands the use tree (or plain path) that starts at `at`; returns its paths and where it ends.
fn use_tree(chars: &[char], mut at: usize) -> (Vec<String>, usize) {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut prefix = String::new();
    loop {
        while at < chars.len() && chars[at].is_whitespace() {
            at += 1;
        }
        if at < chars.len() && chars[at] == '{' {
            at += 1;
            let mut all = Vec::new();
            loop {
                while at < chars.len() && (chars[at].is_whitespace() || chars[at] == ',') {
                    at += 1;
                }
                if at >= chars.len() || chars[at] == '}' {
                    return (all.into_iter().map(|p: String| format!("{prefix}{p}")).collect(), at + 1);
                }
                let (inner, end) = use_tree(chars, at);
                all.extend(inner);
                at = end;
            }
        }
        let start = at;
        while at < chars.len() && ident(chars[at]) {
            at += 1;
        }
        let segment: String = chars[start..at].iter().collect();
        if segment.is_empty() {
            return (vec![prefix.trim_end_matches("::").to_string()], at);
        }
        prefix.push_str(&segment);
        if at + 1 < chars.len() && chars[at] == ':' && chars[at + 1] == ':' {
            prefix.push_str("::");
            at += 2;
        } else {
            return (vec![prefix], at);
        }
    }
}

/// The module a path from module `from` lands in: the deepest module its segments name.
fn resolve(path: &str, from: &str, modules: &BTreeMap<String, PathBuf>) -> Option<String> {
    let mut segments = path.split("::");
    let mut current: Vec<String> = match segments.next()? {
        "crate" => Vec::new(),
        "self" => from.split("::").filter(|s| !s.is_empty()).map(str::to_string).collect(),
        "super" => {
            let mut m: Vec<String> = from.split("::").filter(|s| !s.is_empty()).map(str::to_string).collect();
            m.pop()?;
            m
        }
        _ => return None,
    };
    for segment in segments {
        if segment == "super" {
            current.pop()?;
            continue;
        }
        let mut next = current.clone();
        next.push(segment.to_string());
        if modules.contains_key(&next.join("::")) {
            current = next;
        } else {
            break;
        }
    }
    Some(current.join("::"))
}

/// The import graph between a crate's files (module paths), the root left out: it only declares
/// and re-exports.
fn graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let modules = modules(src);
    let mut graph = BTreeMap::new();
    for (module, file) in &modules {
        if module.is_empty() {
            continue;
        }
        let text = code(&std::fs::read_to_string(file).unwrap());
        let children: Vec<String> = modules
            .keys()
            .filter_map(|m| m.strip_prefix(&format!("{module}::")))
            .filter(|rest| !rest.contains("::"))
            .map(str::to_string)
            .collect();
        let targets: BTreeSet<String> = paths(&text, &children)
            .iter()
            .filter_map(|p| resolve(p, module, &modules))
            .filter(|t| !t.is_empty() && t != module)
            .collect();
        graph.insert(module.clone(), targets);
    }
    graph
}

/// The strongly connected groups of more than one module (Tarjan), each sorted.
fn circles(graph: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    struct T<'a> {
        graph: &'a BTreeMap<String, BTreeSet<String>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        out: Vec<Vec<String>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a str) {
        let n = t.index.len();
        t.index.insert(v, n);
        t.low.insert(v, n);
        t.stack.push(v);
        t.on.insert(v);
        let graph = t.graph;
        for w in graph.get(v).into_iter().flatten() {
            let w = w.as_str();
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(lw));
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low[v];
                t.low.insert(v, lv.min(iw));
            }
        }
        if t.low[v] == t.index[v] {
            let mut group = Vec::new();
            loop {
                let w = t.stack.pop().unwrap();
                t.on.remove(w);
                group.push(w.to_string());
                if w == v {
                    break;
                }
            }
            if group.len() > 1 {
                group.sort();
                t.out.push(group);
            }
        }
    }
    let mut t = T {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !t.index.contains_key(v.as_str()) {
            visit(&mut t, v);
        }
    }
    t.out
}
