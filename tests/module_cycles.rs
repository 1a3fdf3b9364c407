//! The house's structure, held by tests: the library's top-level modules form no import
//! cycle (`error` and the leaves `id`, `vector`, `rng`, `lines` sit at the bottom, and each
//! module depends only on modules below it, so that a module can be read, tested and changed
//! without the rest of the crate), and every module opens with a doc saying what it owns.
//!
//! The dependencies are read from the source: every `crate::name` path in code (comments,
//! doc links and `#[cfg(test)]` modules left out, as they create no dependency of the
//! library) and every name at the top of a `use crate::{...}` list.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// The top-level modules of `src/` (files and directories, `lib.rs` left out).
fn top_level_modules(src: &Path) -> BTreeSet<String> {
    fs::read_dir(src)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter_map(|p| {
            let name = p.file_name()?.to_str()?.to_owned();
            let name = name.strip_suffix(".rs").map_or(name.clone(), str::to_owned);
            (name != "lib" && name != "main").then_some(name)
        })
        .collect()
}

/// Every `.rs` file under `dir`, with the top-level module it belongs to.
fn files(src: &Path) -> Vec<(String, PathBuf)> {
    let mut out = Vec::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap();
                let first = rel
                    .components()
                    .next()
                    .unwrap()
                    .as_os_str()
                    .to_str()
                    .unwrap();
                let top = first.strip_suffix(".rs").unwrap_or(first).to_owned();
                out.push((top, path));
            }
        }
    }
    out
}

/// The code of a file without comments and without its `#[cfg(test)]` items (from the first
/// one on: test modules sit at the end of a file by the house style) or a file named
/// `tests.rs`.
fn library_code(path: &Path) -> String {
    if path.file_name().is_some_and(|n| n == "tests.rs") {
        return String::new();
    }
    let text = fs::read_to_string(path).unwrap();
    let text = text.split("#[cfg(test)]").next().unwrap();
    text.lines()
        .map(|l| l.split("//").next().unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

/// The names a piece of code reaches through `crate::`: the first segment of every
/// `crate::a::...` path and the top-level names of every `crate::{a, b::c, ...}` list.
fn crate_names(code: &str) -> BTreeSet<String> {
    let mut names = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    for (at, _) in code.match_indices("crate::") {
        let rest = &code[at + "crate::".len()..];
        if let Some(list) = rest.strip_prefix('{') {
            // Names at depth 0 of the list: at its start and after each top-level comma.
            let mut depth = 0;
            let mut start = true;
            for (k, c) in list.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && (c.is_alphanumeric() || c == '_') => {
                        names.insert(ident(&list[k..]));
                        start = false;
                    }
                    _ => {}
                }
            }
        } else {
            names.insert(ident(rest));
        }
    }
    names
}

/// The dependency graph between top-level modules.
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let tops = top_level_modules(&src);
    let mut edges: BTreeMap<String, BTreeSet<String>> =
        tops.iter().map(|t| (t.clone(), BTreeSet::new())).collect();
    for (top, path) in files(&src) {
        if top == "lib" {
            continue;
        }
        for name in crate_names(&library_code(&path)) {
            if name != top && tops.contains(&name) {
                edges.get_mut(&top).unwrap().insert(name);
            }
        }
    }
    edges
}

/// A cycle of the graph, if it has one, as the modules along it (the first repeated last).
fn cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    // Depth-first search with colours: grey on the stack, black done.
    fn visit(
        v: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        grey: &mut Vec<String>,
        black: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        grey.push(v.to_owned());
        for w in &edges[v] {
            if let Some(at) = grey.iter().position(|g| g == w) {
                let mut c = grey[at..].to_vec();
                c.push(w.clone());
                return Some(c);
            }
            if !black.contains(w)
                && let Some(c) = visit(w, edges, grey, black)
            {
                return Some(c);
            }
        }
        grey.pop();
        black.insert(v.to_owned());
        None
    }
    let mut black = BTreeSet::new();
    for v in edges.keys() {
        if !black.contains(v)
            && let Some(c) = visit(v, edges, &mut Vec::new(), &mut black)
        {
            return Some(c);
        }
    }
    None
}

#[test]
fn the_top_level_modules_form_no_import_cycle() {
    let edges = graph();
    assert!(edges.len() > 20, "read {} modules", edges.len());
    if let Some(c) = cycle(&edges) {
        panic!("import cycle: {}", c.join(" -> "));
    }
    // error sits at the bottom.
    for leaf in ["error", "id", "vector", "rng", "lines"] {
        let below: Vec<_> = edges[leaf].iter().filter(|m| *m != "id").collect();
        assert!(below.is_empty(), "{leaf} depends on {below:?}");
    }
}

#[test]
fn the_reader_sees_uses_and_paths_and_finds_a_cycle() {
    let code = "use crate::{agents::{A, B}, error::Error};\nfn f() { crate::world::x(); }";
    let names = crate_names(code);
    let want: BTreeSet<String> = ["agents", "error", "world"].map(String::from).into();
    assert_eq!(names, want);
    let mut edges = BTreeMap::new();
    for (a, b) in [("a", "b"), ("b", "c"), ("c", "a"), ("d", "a")] {
        edges
            .entry(a.to_owned())
            .or_insert_with(BTreeSet::new)
            .insert(b.to_owned());
        edges.entry(b.to_owned()).or_insert_with(BTreeSet::new);
    }
    assert!(cycle(&edges).is_some());
    edges.get_mut("c").unwrap().clear();
    assert_eq!(cycle(&edges), None);
}

/// Every source file of the library, the command line and the bindings opens with a module
/// doc (`//!`) saying what it owns (test-only files named `tests.rs` aside).
#[test]
fn every_module_says_what_it_owns() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut missing = Vec::new();
    for dir in ["src", "cli/src", "python/src"] {
        for (_, path) in files(&root.join(dir)) {
            if path.file_name().is_some_and(|n| n == "tests.rs") {
                continue;
            }
            let text = fs::read_to_string(&path).unwrap();
            if !text.starts_with("//!") {
                missing.push(path.display().to_string());
            }
        }
    }
    assert!(missing.is_empty(), "no module doc: {missing:?}");
}
