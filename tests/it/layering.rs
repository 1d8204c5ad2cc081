//! The library's imports run down the flow: config → sampler → kernel →
//! stats → output, with the engine above them and the study, the accuracy
//! ladders and the stress families on top (`docs/design.md`, "Layout").
//!
//! The test reads `src/` as text: every `crate::…` and `super::…` path
//! outside comments and test modules is resolved to the file that defines
//! what it names, and then
//! - a path from one top-level module into another must be allowed by
//!   [`ALLOWED`] (the table `docs/design.md` shows);
//! - inside every folder, the files (a subfolder counts as one) import
//!   each other without a cycle, `mod.rs` included.
//!
//! A failure names the file and line of each offending path.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Each library module and the modules it may import. `physics` and
/// `lanes` are the ground floor; the binary (`main.rs`, `cli/`) may import
/// anything and is not checked.
const ALLOWED: &[(&str, &[&str])] = &[
    ("physics", &[]),
    ("lanes", &[]),
    ("config", &["physics"]),
    ("sampler", &["physics", "lanes", "config"]),
    ("kernel", &["physics", "lanes", "config", "sampler"]),
    (
        "stats",
        &["physics", "lanes", "config", "sampler", "kernel"],
    ),
    ("output", &["physics", "config", "stats"]),
    (
        "engine",
        &[
            "physics", "lanes", "config", "sampler", "kernel", "stats", "output",
        ],
    ),
    (
        "study",
        &["physics", "config", "kernel", "stats", "output", "engine"],
    ),
    (
        "accuracy",
        &[
            "physics", "lanes", "config", "sampler", "kernel", "stats", "output", "engine", "study",
        ],
    ),
    (
        "stress",
        &[
            "physics", "lanes", "config", "sampler", "kernel", "stats", "output", "engine",
        ],
    ),
];

/// A source file: its path under `src/` and its module path.
struct File {
    rel: PathBuf,
    module: Vec<String>,
    /// The text with comments blanked and test modules cut, so that byte
    /// offsets still give line numbers.
    code: String,
}

fn library_files() -> Vec<File> {
    let src = super::support::repo("src");
    let mut out = Vec::new();
    let mut stack = vec![src.clone()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(&src).unwrap().to_path_buf();
                if rel == Path::new("main.rs") || rel.starts_with("cli") {
                    continue;
                }
                let mut module: Vec<String> = rel
                    .with_extension("")
                    .iter()
                    .map(|c| c.to_string_lossy().into_owned())
                    .collect();
                if module.last().is_some_and(|m| m == "mod" || m == "lib") {
                    module.pop();
                }
                let text = std::fs::read_to_string(&p).unwrap();
                out.push(File {
                    rel,
                    module,
                    code: code_of(&text),
                });
            }
        }
    }
    out.sort_by(|a, b| a.rel.cmp(&b.rel));
    out
}

/// Blanks `//` comments and `#[cfg(test)] mod … { … }` blocks, keeping
/// the lines so that byte offsets still give line numbers.
fn code_of(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut lines = text.lines().peekable();
    // Open braces of a test module being skipped (0: not in one).
    let mut skipping = 0usize;
    while let Some(line) = lines.next() {
        let code = match line.find("//") {
            Some(i) if !line[..i].contains('"') => &line[..i],
            _ => line,
        };
        if skipping == 0
            && code.trim() == "#[cfg(test)]"
            && lines
                .peek()
                .is_some_and(|l| l.trim_start().starts_with("mod ") && l.contains('{'))
        {
            skipping = 1;
            out.push('\n');
            let l = lines.next().unwrap();
            skipping += l.matches('{').count() - 1;
            skipping -= l.matches('}').count().min(skipping);
            out.push('\n');
            continue;
        }
        if skipping > 0 {
            skipping += code.matches('{').count();
            skipping -= code.matches('}').count().min(skipping);
            out.push('\n');
            continue;
        }
        out.push_str(code);
        out.push('\n');
    }
    out
}

/// The paths starting with `crate::`, `super::`, `self::` or the name of
/// one of the file's child modules (`children`) in `code`, brace groups
/// expanded, each with the byte offset where it starts.
fn paths(code: &str, children: &[String]) -> Vec<(usize, Vec<String>)> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    let ident = |c: u8| c.is_ascii_alphanumeric() || c == b'_';
    let mut i = 0;
    while i < b.len() {
        let starts = |w: &str| {
            b[i..].starts_with(w.as_bytes())
                && b[i + w.len()..].starts_with(b"::")
                && (i == 0 || !(ident(b[i - 1]) || b[i - 1] == b':'))
        };
        if ["crate", "super", "self"].iter().any(|w| starts(w))
            || children.iter().any(|c| starts(c))
        {
            let at = i;
            let mut prefix = Vec::new();
            i = path_at(code, i, &mut prefix, &mut |p| out.push((at, p)));
        } else {
            i += 1;
        }
    }
    out
}

/// Parses one path (or brace group of paths) at `i`, with `prefix` before
/// it; calls `emit` for every full path and returns the offset after it.
fn path_at(
    code: &str,
    mut i: usize,
    prefix: &mut Vec<String>,
    emit: &mut dyn FnMut(Vec<String>),
) -> usize {
    let b = code.as_bytes();
    let skip_ws = |mut i: usize| {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        i
    };
    let depth = prefix.len();
    loop {
        i = skip_ws(i);
        if i < b.len() && b[i] == b'{' {
            i += 1;
            loop {
                i = skip_ws(i);
                if i >= b.len() || b[i] == b'}' {
                    i += 1;
                    break;
                }
                i = path_at(code, i, prefix, emit);
                i = skip_ws(i);
                if i < b.len() && b[i] == b',' {
                    i += 1;
                }
            }
            prefix.truncate(depth);
            return i;
        }
        let s = i;
        while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'*') {
            i += 1;
        }
        if s == i {
            break;
        }
        prefix.push(code[s..i].to_string());
        if b[i..].starts_with(b"::") {
            i += 2;
        } else {
            break;
        }
    }
    // `as alias` and anything else after the path is not part of it.
    emit(prefix.clone());
    prefix.truncate(depth);
    i
}

/// Whether `file` defines an item called `name` (not by `use`).
fn defines(file: &File, name: &str) -> bool {
    const KINDS: [&str; 9] = [
        "struct ", "enum ", "fn ", "const ", "static ", "type ", "trait ", "mod ", "union ",
    ];
    file.code.lines().any(|l| {
        let l = l.trim_start();
        let l = l
            .strip_prefix("pub(crate) ")
            .or_else(|| l.strip_prefix("pub(super) "))
            .or_else(|| l.strip_prefix("pub "))
            .unwrap_or(l);
        KINDS.iter().any(|k| {
            l.strip_prefix(k).is_some_and(|r| {
                r.starts_with(name)
                    && !r[name.len()..].starts_with(|c: char| c.is_alphanumeric() || c == '_')
            })
        }) || l.starts_with(&format!("macro_rules! {name}"))
    })
}

/// The file a path leads to: its modules followed as far as files exist,
/// then the item looked up in that module's file or, for a re-export, in
/// its children.
fn resolve<'a>(files: &'a [File], from: &File, path: &[String]) -> Option<&'a File> {
    let mut module: Vec<String> = Vec::new();
    let mut rest = path;
    match path.first().map(String::as_str) {
        Some("crate") => rest = &path[1..],
        Some("self") => {
            module = from.module.clone();
            rest = &path[1..];
        }
        Some(child) if child != "super" => {
            module = from.module.clone();
            module.push(child.to_string());
            rest = &path[1..];
        }
        Some(_) => {
            // `super` of `a/b.rs` and of `a/b/mod.rs` is `a`.
            module = from.module.clone();
            while rest.first().is_some_and(|s| s == "super") {
                module.pop();
                rest = &rest[1..];
            }
        }
        None => return None,
    }
    let find = |m: &[String]| files.iter().find(|f| f.module == m);
    for seg in rest {
        let mut next = module.clone();
        next.push(seg.clone());
        if find(&next).is_some() {
            module = next;
        } else {
            let here = find(&module)?;
            if seg == "*" || seg == "self" || defines(here, seg) {
                return Some(here);
            }
            let child = files.iter().find(|f| {
                f.module.len() == module.len() + 1
                    && f.module.starts_with(&module)
                    && defines(f, seg)
            });
            return child.or(Some(here));
        }
    }
    find(&module)
}

/// Whether the path at `at` is in a `pub use` (a module's re-export: its
/// interface, not a use of the file it names).
fn reexport(code: &str, at: usize) -> bool {
    let start = code[..at].rfind([';', '}', '{']).map_or(0, |k| k + 1);
    let mut stmt = code[start..at].trim_start();
    // Inside a brace group, the statement starts before the group.
    if code[..start].ends_with('{') {
        let outer = code[..start - 1].rfind([';', '}']).map_or(0, |k| k + 1);
        stmt = code[outer..at].trim_start();
    }
    stmt.starts_with("pub use ") || stmt.starts_with("pub(crate) use ")
}

fn line_of(code: &str, at: usize) -> usize {
    code[..at].matches('\n').count() + 1
}

/// Every (from, to, line) import edge between two different files.
fn edges(files: &[File]) -> Vec<(usize, usize, usize)> {
    let index = |f: &File| files.iter().position(|g| std::ptr::eq(g, f)).unwrap();
    let mut out = BTreeSet::new();
    for (i, f) in files.iter().enumerate() {
        let children: Vec<String> = files
            .iter()
            .filter(|g| g.module.len() == f.module.len() + 1 && g.module.starts_with(&f.module))
            .map(|g| g.module.last().unwrap().clone())
            .collect();
        for (at, p) in paths(&f.code, &children) {
            if reexport(&f.code, at) {
                continue;
            }
            if let Some(t) = resolve(files, f, &p) {
                let j = index(t);
                if j != i {
                    out.insert((i, j, line_of(&f.code, at)));
                }
            }
        }
    }
    out.into_iter().collect()
}

fn top(f: &File) -> &str {
    f.module.first().map_or("lib", String::as_str)
}

/// Imports from one top-level module into another that [`ALLOWED`] does
/// not list, as `file:line: a -> b (path)` lines.
fn upward(files: &[File], edges: &[(usize, usize, usize)]) -> Vec<String> {
    let table: BTreeMap<&str, &[&str]> = ALLOWED.iter().copied().collect();
    let mut bad = Vec::new();
    for &(i, j, line) in edges {
        let (a, b) = (top(&files[i]), top(&files[j]));
        // lib.rs holds the crate's constants (SCHEMA_VERSION) and its front
        // door; a path through a re-export resolves to the defining file.
        if a == b || a == "lib" || b == "lib" {
            continue;
        }
        let ok = match table.get(a) {
            Some(allowed) => allowed.contains(&b),
            None => {
                bad.push(format!(
                    "src/{}: module {a} is not in the layering table",
                    files[i].rel.display()
                ));
                continue;
            }
        };
        if !ok {
            bad.push(format!(
                "src/{}:{line}: {a} imports {b} (src/{})",
                files[i].rel.display(),
                files[j].rel.display()
            ));
        }
    }
    bad
}

/// Cycles among the files of one folder (a subfolder is one node), each as
/// `folder: a -> b -> … -> a` with the line of every step.
fn cycles(files: &[File], edges: &[(usize, usize, usize)]) -> Vec<String> {
    let folders: BTreeSet<Vec<String>> = files
        .iter()
        .flat_map(|f| {
            let dir: Vec<String> = f
                .rel
                .parent()
                .unwrap()
                .iter()
                .map(|c| c.to_string_lossy().into_owned())
                .collect();
            (0..=dir.len()).map(move |k| dir[..k].to_vec())
        })
        .collect();
    let mut found = Vec::new();
    for folder in folders {
        // The node of a file under `folder`: its first path component below it.
        let node = |f: &File| -> Option<String> {
            let comps: Vec<String> = f
                .rel
                .iter()
                .map(|c| c.to_string_lossy().into_owned())
                .collect();
            (comps.len() > folder.len() && comps.starts_with(&folder))
                .then(|| comps[folder.len()].clone())
        };
        let mut graph: BTreeMap<String, BTreeMap<String, String>> = BTreeMap::new();
        for &(i, j, line) in edges {
            if let (Some(a), Some(b)) = (node(&files[i]), node(&files[j])) {
                if a != b {
                    graph
                        .entry(a)
                        .or_default()
                        .entry(b)
                        .or_insert_with(|| format!("src/{}:{line}", files[i].rel.display()));
                }
            }
        }
        // A depth-first search; a back edge closes a cycle.
        fn visit(
            n: &str,
            graph: &BTreeMap<String, BTreeMap<String, String>>,
            state: &mut BTreeMap<String, u8>,
            stack: &mut Vec<String>,
            found: &mut Vec<Vec<String>>,
        ) {
            state.insert(n.to_string(), 1);
            stack.push(n.to_string());
            for m in graph.get(n).into_iter().flat_map(|e| e.keys()) {
                match state.get(m.as_str()).copied().unwrap_or(0) {
                    0 => visit(m, graph, state, stack, found),
                    1 => {
                        let k = stack.iter().position(|s| s == m).unwrap();
                        let mut c = stack[k..].to_vec();
                        c.push(m.clone());
                        found.push(c);
                    }
                    _ => {}
                }
            }
            stack.pop();
            state.insert(n.to_string(), 2);
        }
        let mut state = BTreeMap::new();
        let mut raw = Vec::new();
        for n in graph.keys() {
            if !state.contains_key(n.as_str()) {
                visit(n, &graph, &mut state, &mut Vec::new(), &mut raw);
            }
        }
        for c in raw {
            let steps: Vec<String> = c
                .windows(2)
                .map(|w| format!("{} -> {} ({})", w[0], w[1], graph[&w[0]][&w[1]]))
                .collect();
            found.push(format!("src/{}: {}", folder.join("/"), steps.join(", ")));
        }
    }
    found
}

#[test]
fn imports_run_down_the_flow() {
    let files = library_files();
    assert!(files.len() > 50, "read {} files of src/", files.len());
    let edges = edges(&files);
    // The reader sees the crate's real imports: the kernel's use of
    // physics is one of them.
    assert!(edges
        .iter()
        .any(|&(i, j, _)| top(&files[i]) == "kernel" && top(&files[j]) == "physics"));
    let bad = upward(&files, &edges);
    assert!(
        bad.is_empty(),
        "imports against the flow:\n{}",
        bad.join("\n")
    );
}

#[test]
fn no_file_cycles_inside_a_folder() {
    let files = library_files();
    let edges = edges(&files);
    let found = cycles(&files, &edges);
    assert!(found.is_empty(), "import cycles:\n{}", found.join("\n"));
}

#[test]
fn the_checks_catch_what_they_are_for() {
    // An upward import and a cycle, made up: the checks must name both.
    let file = |rel: &str, code: &str| {
        let rel = PathBuf::from(rel);
        let mut module: Vec<String> = rel
            .with_extension("")
            .iter()
            .map(|c| c.to_string_lossy().into_owned())
            .collect();
        if module.last().is_some_and(|m| m == "mod") {
            module.pop();
        }
        File {
            rel,
            module,
            code: code_of(code),
        }
    };
    let files = vec![
        file(
            "physics/mod.rs",
            "mod a;\nmod b;\npub const LIMIT: usize = 6;\n",
        ),
        file("physics/a.rs", "use super::b::g;\npub fn f() {}\n"),
        file(
            "physics/b.rs",
            "// use crate::config::X; in a comment\nuse super::a::f;\npub fn g() {}\n",
        ),
        file(
            "config/mod.rs",
            "pub struct X;\nuse crate::physics::LIMIT;\n",
        ),
        file("kernel/mod.rs", "use crate::{physics::a::f, output::Y};\n"),
        file("output/mod.rs", "pub struct Y;\n"),
    ];
    let edges = edges(&files);
    let bad = upward(&files, &edges);
    assert_eq!(
        bad,
        ["src/kernel/mod.rs:1: kernel imports output (src/output/mod.rs)"]
    );
    let found = cycles(&files, &edges);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].starts_with(
            "src/physics: a.rs -> b.rs (src/physics/a.rs:1), b.rs -> a.rs (src/physics/b.rs:2)"
        ),
        "{}",
        found[0]
    );
}
