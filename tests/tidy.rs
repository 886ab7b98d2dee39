//! The codebase's shape, checked on every test run so that
//! `docs/ARCHITECTURE.md` cannot drift from the code:
//!
//! - the numerical core's dependency closure (read from `Cargo.lock`) has
//!   no async runtime, HTTP or database crate, and the workspace's crates
//!   depend only downward (binary → server → core);
//! - the dependency table there lists exactly the edges between the
//!   top-level modules of the core and server crates that their paths
//!   create (`crate::`, `super::`, and the server's `sinscal_core::`);
//! - those edges, and the edges between files, have no cycle;
//! - no source file outside `tests/` is longer than 600 lines.
//!
//! The binary's command line (`src/cli`) names the two libraries as
//! `sinscal_core::…` and `sinscal_server::…` and is no module of either:
//! it is left out of the module table, and held to the line limit like any
//! file.
//!
//! A child module naming its own ancestors' items (`super::AppState` in
//! `api::upload`) is how a module shares its interface with its parts, not
//! a cycle; every other edge counts, whichever way it points.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const MAX_LINES: usize = 600;

/// Every `.rs` file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// `src/api/upload.rs` → `["api", "upload"]`; `src/api/mod.rs` → `["api"]`.
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The source without comments and string literals, so that a path in a
/// doc comment or a message is not taken for a dependency.
fn code_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let b = text.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i + 1 < b.len() && !(b[i] == b'*' && b[i + 1] == b'/') {
                i += 1;
            }
            i += 2;
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if b[i] == b'\'' && b.get(i + 2) == Some(&b'\'') {
            // A char literal such as '{' must not open a use group.
            i += 3;
        } else {
            out.push(b[i] as char);
            i += 1;
        }
    }
    out
}

fn ident_at(s: &[u8], mut i: usize) -> (String, usize) {
    let start = i;
    while i < s.len() && (s[i].is_ascii_alphanumeric() || s[i] == b'_') {
        i += 1;
    }
    (String::from_utf8_lossy(&s[start..i]).into_owned(), i)
}

fn skip_ws(s: &[u8], mut i: usize) -> usize {
    while i < s.len() && s[i].is_ascii_whitespace() {
        i += 1;
    }
    i
}

/// Parses a path or use tree starting at `i` (just after `crate::` etc.)
/// and appends every full path it names to `out`.
fn use_tree(s: &[u8], mut i: usize, prefix: &[String], out: &mut Vec<Vec<String>>) -> usize {
    let mut path = prefix.to_vec();
    loop {
        i = skip_ws(s, i);
        if s.get(i) == Some(&b'{') {
            i += 1;
            loop {
                i = skip_ws(s, i);
                if s.get(i) == Some(&b'}') {
                    return i + 1;
                }
                i = use_tree(s, i, &path, out);
                i = skip_ws(s, i);
                if s.get(i) == Some(&b',') {
                    i += 1;
                } else if s.get(i) == Some(&b'}') {
                    return i + 1;
                } else {
                    return i;
                }
            }
        }
        let (id, j) = ident_at(s, i);
        if id.is_empty() {
            out.push(path);
            return i;
        }
        path.push(id);
        i = j;
        if s.get(i) == Some(&b':') && s.get(i + 1) == Some(&b':') {
            i += 2;
        } else {
            out.push(path);
            return i;
        }
    }
}

/// The module paths a file's code names through `crate::`, `super::`,
/// `self::` and (from the server) `sinscal_core::`: the two library crates
/// share one module namespace, their top-level names being distinct.
fn named_paths(code: &str, here: &[String]) -> Vec<Vec<String>> {
    let s = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < s.len() {
        let boundary = i == 0 || !(s[i - 1].is_ascii_alphanumeric() || s[i - 1] == b'_');
        if !boundary {
            i += 1;
            continue;
        }
        let (id, j) = ident_at(s, i);
        if id.is_empty() {
            i += 1;
            continue;
        }
        if matches!(id.as_str(), "crate" | "super" | "self" | "sinscal_core")
            && s[j..].starts_with(b"::")
        {
            // `super` of a file module is its parent; of a mod.rs, the
            // parent's parent. Chained `super::super` is walked below.
            let mut base: Vec<String> = match id.as_str() {
                "crate" | "sinscal_core" => Vec::new(),
                "self" => here.to_vec(),
                _ => here[..here.len().saturating_sub(1)].to_vec(),
            };
            let mut k = j + 2;
            loop {
                let (next, m) = ident_at(s, k);
                if next == "super" && s[m..].starts_with(b"::") {
                    base.pop();
                    k = m + 2;
                } else {
                    break;
                }
            }
            let mut paths = Vec::new();
            i = use_tree(s, k, &base, &mut paths);
            out.extend(paths);
        } else {
            i = j;
        }
    }
    out
}

struct Tree {
    /// Module path → file.
    files: BTreeMap<Vec<String>, PathBuf>,
    /// File-level edges (module → module), ancestors excluded.
    edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
}

/// The library crates' source folders, whose top-level modules make the
/// architecture's table.
const LIBRARY_SOURCES: [&str; 2] = ["crates/core/src", "crates/server/src"];

fn read_tree() -> Tree {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = BTreeMap::new();
    for dir in LIBRARY_SOURCES {
        let src = root.join(dir);
        for f in rust_files(&src) {
            if f.parent() == Some(src.as_path()) && f.file_name().is_some_and(|n| n == "lib.rs") {
                continue;
            }
            let module = module_path(&src, &f);
            assert!(
                files.insert(module.clone(), f).is_none(),
                "module {} is in both library crates",
                module.join("::")
            );
        }
    }
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (m, f) in &files {
        let text = std::fs::read_to_string(f).unwrap();
        // A file's own unit tests sit in `mod tests` at its end, where
        // `super` means the file itself: they are left out.
        let text = text.split("#[cfg(test)]\nmod tests").next().unwrap_or("");
        for path in named_paths(&code_only(text), m) {
            // The longest prefix that is a module of this crate.
            let target = (1..=path.len())
                .rev()
                .map(|n| path[..n].to_vec())
                .find(|p| files.contains_key(p));
            if let Some(t) = target {
                let ancestor = m.len() > t.len() && m[..t.len()] == t[..];
                if t != *m && !ancestor {
                    edges.entry(m.clone()).or_default().insert(t);
                }
            }
        }
    }
    Tree { files, edges }
}

/// A cycle in `edges`, if there is one, as the list of its nodes.
fn find_cycle<N: Ord + Clone>(edges: &BTreeMap<N, BTreeSet<N>>) -> Option<Vec<N>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        Open,
        Done,
    }
    fn visit<N: Ord + Clone>(
        n: &N,
        edges: &BTreeMap<N, BTreeSet<N>>,
        marks: &mut BTreeMap<N, Mark>,
        stack: &mut Vec<N>,
    ) -> Option<Vec<N>> {
        match marks.get(n) {
            Some(Mark::Done) => return None,
            Some(Mark::Open) => {
                let at = stack.iter().position(|x| x == n).unwrap();
                return Some(stack[at..].to_vec());
            }
            None => {}
        }
        marks.insert(n.clone(), Mark::Open);
        stack.push(n.clone());
        for next in edges.get(n).into_iter().flatten() {
            if let Some(c) = visit(next, edges, marks, stack) {
                return Some(c);
            }
        }
        stack.pop();
        marks.insert(n.clone(), Mark::Done);
        None
    }
    let mut marks = BTreeMap::new();
    for n in edges.keys() {
        if let Some(c) = visit(n, edges, &mut marks, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

fn top_level_edges(tree: &Tree) -> BTreeMap<String, BTreeSet<String>> {
    let mut top: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for m in tree.files.keys() {
        top.entry(m[0].clone()).or_default();
    }
    for (from, tos) in &tree.edges {
        for to in tos {
            if from[0] != to[0] {
                top.entry(from[0].clone())
                    .or_default()
                    .insert(to[0].clone());
            }
        }
    }
    top
}

/// The table between the `dependencies:begin` and `dependencies:end`
/// markers of docs/ARCHITECTURE.md: `| module | uses |`, names in
/// backticks.
fn documented_edges() -> BTreeMap<String, BTreeSet<String>> {
    let doc =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/ARCHITECTURE.md"))
            .unwrap();
    let start = doc
        .find("<!-- dependencies:begin -->")
        .expect("docs/ARCHITECTURE.md has a dependencies:begin marker");
    let end = doc
        .find("<!-- dependencies:end -->")
        .expect("docs/ARCHITECTURE.md has a dependencies:end marker");
    let mut table = BTreeMap::new();
    for line in doc[start..end].lines().filter(|l| l.starts_with('|')) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 3 || cells[1].starts_with('-') || cells[1] == "module" {
            continue;
        }
        let names = |cell: &str| -> BTreeSet<String> {
            cell.split('`')
                .skip(1)
                .step_by(2)
                .map(str::to_string)
                .collect()
        };
        let module = names(cells[1]).into_iter().next().unwrap_or_default();
        table.insert(module, names(cells[2]));
    }
    table
}

#[test]
fn the_architecture_dependency_table_lists_exactly_the_edges_in_the_code() {
    let actual = top_level_edges(&read_tree());
    let documented = documented_edges();
    let mut diff = Vec::new();
    for m in actual
        .keys()
        .chain(documented.keys())
        .collect::<BTreeSet<_>>()
    {
        let a = actual.get(m).cloned().unwrap_or_default();
        let d = documented.get(m).cloned().unwrap_or_default();
        if !actual.contains_key(m) {
            diff.push(format!("`{m}` is documented but is not a module"));
        } else if !documented.contains_key(m) {
            diff.push(format!("`{m}` is missing from the table (uses {a:?})"));
        } else if a != d {
            let missing: Vec<_> = a.difference(&d).collect();
            let extra: Vec<_> = d.difference(&a).collect();
            diff.push(format!(
                "`{m}`: undocumented edges {missing:?}, documented edges the code lacks {extra:?}"
            ));
        }
    }
    // On a mismatch, print the table as it should read.
    let table: String = actual
        .iter()
        .map(|(m, uses)| {
            let uses: Vec<String> = uses.iter().map(|u| format!("`{u}`")).collect();
            format!("| `{m}` | {} |\n", uses.join(", "))
        })
        .collect();
    assert!(
        diff.is_empty(),
        "docs/ARCHITECTURE.md: {}\nthe code's table:\n{table}",
        diff.join("; ")
    );
}

#[test]
fn no_dependency_cycle_between_modules_or_files() {
    let tree = read_tree();
    let top = top_level_edges(&tree);
    assert_eq!(find_cycle(&top), None, "top-level modules");
    assert_eq!(find_cycle(&tree.edges), None, "files");
}

#[test]
fn no_source_file_is_longer_than_the_limit() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut long = Vec::new();
    for dir in ["src", "crates/core/src", "crates/server/src", "benches"] {
        for f in rust_files(&root.join(dir)) {
            let n = std::fs::read_to_string(&f).unwrap().lines().count();
            if n > MAX_LINES {
                long.push(format!(
                    "{} ({n} lines)",
                    f.strip_prefix(root).unwrap().display()
                ));
            }
        }
    }
    assert!(long.is_empty(), "over {MAX_LINES} lines: {long:?}");
}

#[test]
fn the_path_reader_sees_groups_and_ignores_comments() {
    let code = code_only(
        "use crate::{a::{b, c::D}, e};\n// use crate::zzz;\nlet s = \"crate::q\";\nsuper::f::g();",
    );
    let here = vec!["x".to_string(), "y".to_string()];
    let paths = named_paths(&code, &here);
    let joined: Vec<String> = paths.iter().map(|p| p.join("::")).collect();
    assert_eq!(joined, ["a::b", "a::c::D", "e", "x::f::g"]);
}

/// The absences docs/ARCHITECTURE.md states inside the server crate: only
/// `store` names sqlx, only `api`, `web` and `server` name axum, `sim` never
/// names `calib`, and nothing names `server`. (That the core names no part
/// of the server the compiler holds: it does not depend on the server.)
#[test]
fn the_stated_absences_hold() {
    let tree = read_tree();
    let mut broken = Vec::new();
    for (m, f) in &tree.files {
        let text = std::fs::read_to_string(f).unwrap();
        let code = code_only(&text);
        if code.contains("sqlx") && m[0] != "store" {
            broken.push(format!("{} names sqlx", m.join("::")));
        }
        if code.contains("axum") && !["api", "web", "server"].contains(&m[0].as_str()) {
            broken.push(format!("{} names axum", m.join("::")));
        }
    }
    let top = top_level_edges(&tree);
    if top.get("sim").is_some_and(|u| u.contains("calib")) {
        broken.push("sim names calib".into());
    }
    for (m, uses) in &top {
        if uses.contains("server") {
            broken.push(format!("{m} names server"));
        }
    }
    assert!(broken.is_empty(), "{broken:?}");
}

/// `Cargo.lock`'s packages: name → the names of what it depends on
/// (normal, build and dev dependencies alike).
fn locked_dependencies() -> BTreeMap<String, BTreeSet<String>> {
    let lock =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("Cargo.lock")).unwrap();
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for package in lock.split("[[package]]").skip(1) {
        let name = package
            .lines()
            .find_map(|l| l.strip_prefix("name = "))
            .map(|n| n.trim_matches('"').to_string())
            .expect("every locked package has a name");
        let deps = package
            .split_once("dependencies = [")
            .map(|(_, rest)| rest.split(']').next().unwrap_or(""))
            .unwrap_or("");
        let deps = deps
            .split(',')
            .map(|d| d.trim().trim_matches('"'))
            .filter(|d| !d.is_empty())
            // "name 1.2.3" when two versions are locked
            .map(|d| d.split(' ').next().unwrap().to_string());
        graph.entry(name).or_default().extend(deps);
    }
    graph
}

/// Every package `from` reaches in `graph`, itself included.
fn closure(graph: &BTreeMap<String, BTreeSet<String>>, from: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut stack = vec![from.to_string()];
    while let Some(p) = stack.pop() {
        if seen.insert(p.clone()) {
            stack.extend(graph.get(&p).into_iter().flatten().cloned());
        }
    }
    seen
}

#[test]
fn the_core_reaches_no_runtime_http_or_database_crate_and_crates_depend_downward() {
    let graph = locked_dependencies();
    let core = closure(&graph, "sinscal-core");
    let forbidden = [
        "tokio",
        "axum",
        "hyper",
        "sqlx",
        "tower",
        "tower-http",
        "reqwest",
        "object_store",
        "maud",
        "sinscal-server",
        "sinscal",
    ];
    let reached: Vec<_> = forbidden.iter().filter(|f| core.contains(**f)).collect();
    assert!(reached.is_empty(), "sinscal-core reaches {reached:?}");
    let server = closure(&graph, "sinscal-server");
    assert!(
        server.contains("sinscal-core"),
        "the server is built on the core"
    );
    assert!(!server.contains("sinscal"), "the server names the binary");
    let binary = &graph["sinscal"];
    assert!(binary.contains("sinscal-core") && binary.contains("sinscal-server"));
}

#[test]
fn the_lock_reader_follows_versioned_names() {
    let graph = locked_dependencies();
    // sqlx is locked once, and reaches tokio through its runtime feature.
    assert!(closure(&graph, "sqlx").contains("tokio"));
}

/// `calib`'s public modules are its face, as docs/ARCHITECTURE.md lists
/// them; any other file is `pub(crate)` or private.
#[test]
fn calib_shows_only_its_face() {
    const FACE: [&str; 7] = [
        "model_check",
        "plan",
        "prescan",
        "result",
        "segment",
        "sources",
        "thermal_states",
    ];
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("crates/core/src/calib/mod.rs")).unwrap();
    let code = code_only(&text);
    let public: Vec<&str> = code
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub mod ")?.strip_suffix(';'))
        .map(str::trim)
        .collect();
    let extra: Vec<_> = public.iter().filter(|m| !FACE.contains(m)).collect();
    assert!(
        extra.is_empty(),
        "calib's public modules beyond its face: {extra:?}"
    );
    let doc = std::fs::read_to_string(root.join("docs/ARCHITECTURE.md")).unwrap();
    for m in FACE {
        assert!(
            doc.contains(&format!("`{m}`")),
            "docs/ARCHITECTURE.md does not name calib's public module {m}"
        );
    }
}
