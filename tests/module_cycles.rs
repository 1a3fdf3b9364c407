//! The house's structure, held by tests: the library's top-level modules form no import
//! cycle (`error` and the leaves `id`, `vector`, `rng`, `cache_lines` sit at the bottom, and
//! each module depends only on modules below it, so that a module can be read, tested and
//! changed without the rest of the crate); within every module, no two of its files import each
//! other, directly or through a chain; and every module opens with a doc saying what it owns.
//!
//! The dependencies are read from the source: every `crate::name` path in code (comments,
//! doc links and `#[cfg(test)]` modules left out, as they create no dependency of the
//! library) and every name at the top of a `use crate::{...}` list.
//!
//! The rule between files ([`sibling_graph`]): the children of a module (each file `a.rs`, each
//! folder `a/` with everything in it) are siblings, and sibling `a` depends on sibling `b` when
//! code in `a` names a path that leads into `b`: `super::b::f`, `crate::m::b::T`, or a name that
//! the parent re-exports from `b` (`super::T` after `pub use b::T` in the parent), since going
//! through the parent's re-export is still using `b`. The parent's own file (`mod.rs`, or `m.rs`
//! beside a folder `m/`) is the parent: its code and its re-exports depend on its children and
//! never put two siblings in a cycle. A cycle among siblings means a helper sits in the wrong
//! file: it belongs in a file both can import, or in the one that owns the concept.

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
    code_of(&fs::read_to_string(path).unwrap())
}

/// [`library_code`] of a file's text.
fn code_of(text: &str) -> String {
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

/// A module's path from its crate's root: `["steer", "cells", "kernels"]` (empty: the root).
type ModPath = Vec<String>;

/// The module a file holds, from its path below the crate's source folder: `a/b.rs` and
/// `a/b/mod.rs` hold `a::b`, `lib.rs` and `main.rs` the root.
fn module_of(rel: &str) -> ModPath {
    let mut parts: ModPath = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(str::to_owned)
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

/// One path of a `use` tree or of code, with the name it is imported as when `as` renames it.
type UsePath = (Vec<String>, Option<String>);

/// The identifier at the start of `s`, if one starts there.
fn ident_at(s: &str) -> Option<&str> {
    let end = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    let id = &s[..end];
    (!id.is_empty() && !id.starts_with(|c: char| c.is_ascii_digit())).then_some(id)
}

/// The paths of the path tree at the start of `s` (`a::b::{c, d::e as f, *}` gives `a::b::c`,
/// `a::b::d::e` as `f` and `a::b::*`), and how much of `s` it takes.
fn path_tree(s: &str) -> (Vec<UsePath>, usize) {
    let ws = |s: &str, at: usize| at + (s[at..].len() - s[at..].trim_start().len());
    let at = ws(s, 0);
    if s[at..].starts_with('{') {
        let mut out = Vec::new();
        let mut k = at + 1;
        loop {
            k = ws(s, k);
            while s[k..].starts_with(',') {
                k = ws(s, k + 1);
            }
            if k >= s.len() {
                return (out, k);
            }
            if s[k..].starts_with('}') {
                return (out, k + 1);
            }
            let (sub, used) = path_tree(&s[k..]);
            out.extend(sub);
            // Something that is no path (a stray token) is passed over.
            k += used.max(1);
        }
    }
    if s[at..].starts_with('*') {
        return (vec![(vec!["*".to_owned()], None)], at + 1);
    }
    let Some(id) = ident_at(&s[at..]) else {
        return (vec![(Vec::new(), None)], at);
    };
    let after = at + id.len();
    let next = ws(s, after);
    if s[next..].starts_with("::") {
        let (sub, used) = path_tree(&s[next + 2..]);
        let out = sub
            .into_iter()
            .map(|(mut p, alias)| {
                p.insert(0, id.to_owned());
                (p, alias)
            })
            .collect();
        return (out, next + 2 + used);
    }
    // `name as alias`.
    if let Some(rest) = s[next..].strip_prefix("as")
        && rest.starts_with(char::is_whitespace)
    {
        let a = ws(s, next + 2);
        if let Some(alias) = ident_at(&s[a..]) {
            let path = vec![id.to_owned()];
            return (vec![(path, Some(alias.to_owned()))], a + alias.len());
        }
    }
    (vec![(vec![id.to_owned()], None)], after)
}

/// Every path that starts with `crate::`, `super::` or `self::` in `code` (a file of module
/// `me`), made absolute from the crate's root.
fn absolute_paths(code: &str, me: &[String]) -> Vec<UsePath> {
    let mut out = Vec::new();
    for start in ["crate::", "super::", "self::"] {
        for (at, _) in code.match_indices(start) {
            let before = code[..at].chars().next_back();
            if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':') {
                continue;
            }
            for (path, alias) in path_tree(&code[at..]).0 {
                out.push((absolute(&path, me), alias));
            }
        }
    }
    out
}

/// A path written in module `me` (starting with `crate`, `super` or `self`), from the root.
fn absolute(path: &[String], me: &[String]) -> ModPath {
    let mut base = me.to_vec();
    let mut rest = path;
    if rest.first().is_some_and(|s| s == "crate") {
        base.clear();
        rest = &rest[1..];
    }
    while let Some(first) = rest.first() {
        match first.as_str() {
            "super" => {
                base.pop();
            }
            "self" => {}
            _ => break,
        }
        rest = &rest[1..];
    }
    base.extend(rest.iter().cloned());
    base
}

/// A crate's modules read from its source files: each module's code and the names it
/// re-exports.
struct Modules {
    /// The library code of each module's file.
    code: BTreeMap<ModPath, String>,
    /// Per module: each name it re-exports (`pub use`, `pub(crate) use`, ...) and the
    /// absolute path it stands for.
    reexports: BTreeMap<ModPath, BTreeMap<String, ModPath>>,
}

impl Modules {
    /// The modules of a crate from its files: path below the source folder, text.
    fn new(files: &BTreeMap<String, String>) -> Self {
        let code: BTreeMap<ModPath, String> = files
            .iter()
            .filter(|(rel, _)| !rel.ends_with("tests.rs"))
            .map(|(rel, text)| (module_of(rel), code_of(text)))
            .collect();
        let mut m = Modules {
            code,
            reexports: BTreeMap::new(),
        };
        let mut reexports = BTreeMap::new();
        for (me, code) in &m.code {
            let mut names = BTreeMap::new();
            for (at, _) in code.match_indices("pub") {
                let rest = &code[at + 3..];
                // `pub use`, or `pub(...) use`.
                let rest = match rest.strip_prefix('(') {
                    Some(r) => &r[r.find(')').map_or(0, |k| k + 1)..],
                    None => rest,
                };
                let Some(tree) = rest.trim_start().strip_prefix("use ") else {
                    continue;
                };
                for (path, alias) in path_tree(tree).0 {
                    let Some(last) = path.last().filter(|l| *l != "*") else {
                        continue;
                    };
                    let name = alias.unwrap_or_else(|| last.clone());
                    let target = match path[0].as_str() {
                        "crate" | "super" | "self" => absolute(&path, me),
                        // A child of the module, or another crate (not followed).
                        child if m.children(me).contains(child) => absolute(&path, me),
                        _ => continue,
                    };
                    names.insert(name, target);
                }
            }
            reexports.insert(me.clone(), names);
        }
        m.reexports = reexports;
        m
    }

    /// The names of module `m`'s children.
    fn children(&self, m: &[String]) -> BTreeSet<String> {
        self.code
            .keys()
            .filter(|k| k.len() > m.len() && k.starts_with(m))
            .map(|k| k[m.len()].clone())
            .collect()
    }

    /// The module an absolute path leads into: down the modules it names, and on through the
    /// re-exports of a module it names an item of; the deepest module reached.
    fn resolve(&self, path: &[String]) -> ModPath {
        let mut path = path.to_vec();
        let mut at = 0;
        // Re-exports followed at most this often (a loop of them would be an error anyway).
        for _ in 0..16 {
            while at < path.len() && self.code.contains_key(&path[..=at]) {
                at += 1;
            }
            let here = &path[..at];
            match path
                .get(at)
                .and_then(|name| self.reexports.get(here)?.get(name))
            {
                Some(target) if !target.starts_with(&path[..=at]) => {
                    let mut next = target.clone();
                    next.extend(path[at + 1..].iter().cloned());
                    path = next;
                    at = 0;
                }
                _ => break,
            }
        }
        let mut m = path;
        while !self.code.contains_key(&m) && !m.is_empty() {
            m.pop();
        }
        m
    }
}

/// The dependencies between sibling files of every module (see the crate's doc for the rule),
/// each node named by its module path (`plans/pass`).
fn sibling_graph(files: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let modules = Modules::new(files);
    let name = |m: &[String]| m.join("/");
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (me, code) in &modules.code {
        for (path, _) in absolute_paths(code, me) {
            let target = modules.resolve(&path);
            let common = me.iter().zip(&target).take_while(|(a, b)| a == b).count();
            if common < me.len() && common < target.len() {
                let (a, b) = (name(&me[..=common]), name(&target[..=common]));
                edges.entry(b.clone()).or_default();
                edges.entry(a).or_default().insert(b);
            }
        }
    }
    edges
}

/// The `.rs` files below a crate's source folder: path below it (with `/`), text.
fn crate_files(src: &Path) -> BTreeMap<String, String> {
    files(src)
        .into_iter()
        .map(|(_, path)| {
            let rel = path.strip_prefix(src).unwrap().to_str().unwrap();
            (rel.replace('\\', "/"), fs::read_to_string(&path).unwrap())
        })
        .collect()
}

#[test]
fn the_top_level_modules_form_no_import_cycle() {
    let edges = graph();
    assert!(edges.len() > 20, "read {} modules", edges.len());
    if let Some(c) = cycle(&edges) {
        panic!("import cycle: {}", c.join(" -> "));
    }
    // error sits at the bottom.
    for leaf in ["error", "id", "vector", "rng", "cache_lines"] {
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

/// No two files of a module import each other, directly or through a chain, in the library,
/// the command line or the bindings.
#[test]
fn no_two_files_of_a_module_import_each_other() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for dir in ["src", "cli/src", "python/src"] {
        let edges = sibling_graph(&crate_files(&root.join(dir)));
        let deep = edges.keys().filter(|k| k.contains('/')).count();
        assert!(
            dir != "src" || deep > 50,
            "{dir}: read {deep} files in modules"
        );
        if let Some(c) = cycle(&edges) {
            panic!("{dir}: files import each other: {}", c.join(" -> "));
        }
    }
}

/// The reader of file dependencies finds a cycle planted through `super::`, `crate::` paths, a
/// `use` list and a parent's re-export, and leaves out what creates no dependency: comments,
/// tests, the parent's own re-exports, a name the parent defines itself.
#[test]
fn the_file_reader_finds_a_planted_cycle() {
    let planted = |c: &str| -> BTreeMap<String, String> {
        [
            ("lib.rs", "mod m;"),
            (
                "m/mod.rs",
                "mod a; mod b; mod c; mod d;\npub(crate) use c::{Thing as Other};\n\
                 pub use self::d::Free;\npub struct Own;",
            ),
            ("m/a.rs", "//! a\nuse super::b::f;\nfn g() { super::Own; }"),
            (
                "m/b.rs",
                "use crate::m::{Other, d::Free};\n// use super::a::g;",
            ),
            ("m/c.rs", c),
            (
                "m/d.rs",
                "pub struct Free;\n#[cfg(test)]\nmod tests { use super::super::a::g; }",
            ),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v.to_owned()))
        .collect()
    };
    // a -> b (a path), b -> c (the parent's re-export, renamed), c -> a (a `use` list).
    let edges = sibling_graph(&planted("pub struct Thing;\nuse super::{a::g, d};"));
    let want = |pairs: &[(&str, &str)]| -> BTreeSet<(String, String)> {
        pairs
            .iter()
            .map(|(a, b)| ((*a).to_owned(), (*b).to_owned()))
            .collect()
    };
    let got: BTreeSet<(String, String)> = edges
        .iter()
        .flat_map(|(a, bs)| bs.iter().map(move |b| (a.clone(), b.clone())))
        .collect();
    let all = [
        ("m/a", "m/b"),
        ("m/b", "m/c"),
        ("m/b", "m/d"),
        ("m/c", "m/a"),
        ("m/c", "m/d"),
    ];
    assert_eq!(got, want(&all));
    let c = cycle(&edges).expect("the planted cycle");
    assert_eq!(c.len(), 4, "{c:?}");
    // Without c's import of a, the rest is a chain.
    let edges = sibling_graph(&planted("pub struct Thing;\nuse super::d;"));
    assert_eq!(cycle(&edges), None);
    // A cycle through deeper files counts between the folders that hold them.
    let mut nested = planted("pub struct Thing;");
    nested.insert("m/c.rs".into(), "mod deep;".into());
    nested.insert("m/c/deep.rs".into(), "use crate::m::a::g;".into());
    assert!(cycle(&sibling_graph(&nested)).is_some());
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
