//! The crate's layering and its file graph, checked on the source text: every `crate::…` and
//! `super::…` path in src/ (tests included) is resolved to the file it names, and
//!
//! - a file may refer only to its own top-level module and to those `LAYERS` allows it;
//! - no two files refer to each other, directly or around a longer loop.
//!
//! Paths relative to the current module (`vsa::partition` in convert/mod.rs) are not followed:
//! a parent reaching into its children is how a module is built, not a layer crossing.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Layers, lowest first.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Layer {
    /// Cancellation, progress, errors, profiling, the CPU BVH: any module may use them.
    Infrastructure,
    /// What the stages make and read and the renderer draws, with their files.
    DataModel,
    /// Algorithms more than one stage runs (and tools over the data model).
    Shared,
    /// Each makes or draws one kind of thing from the layers below.
    Stage,
    /// The binding layer and the tests that run one stage's output through another.
    Top,
}

use Layer::*;

/// Every top-level module of src/ and its layer. A module may refer to modules of its own layer
/// and the layers below, except that a stage may not refer to another stage: stages share only
/// what lies below them (infrastructure, the data they make and read, shared algorithms), so
/// one can change, or be left out, without the others noticing.
const LAYERS: &[(&str, Layer)] = &[
    ("error", Infrastructure),
    ("cancel", Infrastructure),
    ("progress", Infrastructure),
    ("profile", Infrastructure),
    ("bvh", Infrastructure),
    ("wide_bvh", Infrastructure),
    ("mesh", DataModel),
    ("appearance", DataModel),
    ("heightfield", DataModel),
    ("test_shapes", DataModel),
    ("gtex", DataModel),
    ("convert_options", DataModel),
    ("igt_data", DataModel),
    ("gdm_data", DataModel),
    ("surfel_data", DataModel),
    ("charts", Shared),
    ("filters", Shared),
    ("grids", Shared),
    ("convert", Stage),
    ("igt", Stage),
    ("gdm", Stage),
    ("surfels", Stage),
    ("render", Stage),
    ("python", Top),
    ("pipeline_tests", Top),
];

fn layer_of(module: &str) -> Layer {
    match LAYERS.iter().find(|(m, _)| *m == module) {
        Some(&(_, layer)) => layer,
        None => panic!("src/{module}: a new top-level module; give it a layer in LAYERS"),
    }
}

fn allowed(from: &str, to: &str) -> bool {
    let (a, b) = (layer_of(from), layer_of(to));
    from == to || b < a || (a == b && a != Stage)
}

/// Every .rs file under `dir`, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files.sort();
    files
}

/// The module path of a file: src/lib.rs is [], src/a/mod.rs and src/a.rs are [a].
fn module_of(relative: &Path) -> Vec<String> {
    let mut parts: Vec<String> = relative
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if stem != "mod" && stem != "lib" {
        parts.push(stem.to_string());
    }
    parts
}

/// `text` with comments, string and char literals blanked out (newlines kept), so only code is
/// searched.
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    let blank = |out: &mut String, ch: char| out.push(if ch == '\n' { '\n' } else { ' ' });
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            loop {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    blank(&mut out, c[i]);
                    i += 1;
                }
            }
        } else if c[i] == 'r' && matches!(next, Some('"') | Some('#')) && !ident_char(&c, i) {
            // A raw string: r"…" or r#"…"#.
            let hashes = c[i + 1..].iter().take_while(|&&h| h == '#').count();
            let mut j = i + 1 + hashes;
            if c.get(j) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            while !(c[j] == '"' && c[j + 1..].iter().take(hashes).all(|&h| h == '#')) {
                blank(&mut out, c[j]);
                j += 1;
            }
            i = j + 1 + hashes;
        } else if c[i] == '"' {
            i += 1;
            while c[i] != '"' {
                if c[i] == '\\' {
                    i += 1;
                }
                blank(&mut out, c[i]);
                i += 1;
            }
            i += 1;
        } else if c[i] == '\'' && (next == Some('\\') || c.get(i + 2) == Some(&'\'')) {
            // A char literal ('x', '\'', '\u{..}'), not a lifetime.
            i += if next == Some('\\') { 3 } else { 2 };
            while c[i] != '\'' {
                i += 1;
            }
            i += 1;
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

/// Whether the character before `i` continues an identifier.
fn ident_char(c: &[char], i: usize) -> bool {
    i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_')
}

/// The paths written at `rest` (just after `crate::` or `super::`): one, or a `{…}` group's.
fn paths_at(rest: &str) -> Vec<Vec<String>> {
    let mut segments = Vec::new();
    let mut s = rest.trim_start();
    loop {
        if let Some(body) = s.strip_prefix('{') {
            return group(body)
                .into_iter()
                .map(|tail| [segments.clone(), tail].concat())
                .collect();
        }
        let end = s
            .find(|ch: char| !(ch.is_alphanumeric() || ch == '_'))
            .unwrap_or(s.len());
        if end == 0 {
            return vec![segments];
        }
        segments.push(s[..end].to_string());
        s = s[end..].trim_start();
        match s.strip_prefix("::") {
            Some(after) => s = after.trim_start(),
            None => return vec![segments],
        }
    }
}

/// The paths of a `{…}` group, `body` starting after its `{`.
fn group(body: &str) -> Vec<Vec<String>> {
    let (mut depth, mut start, mut items) = (0, 0, Vec::new());
    for (k, ch) in body.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' if depth == 0 => {
                items.push(&body[start..k]);
                break;
            }
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(&body[start..k]);
                start = k + 1;
            }
            _ => {}
        }
    }
    let items = items.into_iter().filter(|i| !i.trim().is_empty());
    items.flat_map(paths_at).collect()
}

/// Every module path `code` (of the module at `module`) names through `crate::` or `super::`,
/// resolved from the crate root; `super` counts from the inline module it is written in.
fn referenced_paths(code: &str, module: &[String]) -> Vec<Vec<String>> {
    let chars: Vec<char> = code.chars().collect();
    // The inline modules (`mod tests { … }`) open here, each with the brace depth it opened at.
    let mut inline: Vec<(String, usize)> = Vec::new();
    let (mut depth, mut found) = (0, Vec::new());
    for (i, &ch) in chars.iter().enumerate() {
        match ch {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if inline.last().is_some_and(|&(_, d)| d == depth) {
                    inline.pop();
                }
            }
            _ => {}
        }
        if ident_char(&chars, i) || !matches!(ch, 'c' | 's' | 'm') {
            continue;
        }
        let rest: String = chars[i..chars.len().min(i + 400)].iter().collect();
        if let Some(after) = rest.strip_prefix("mod ") {
            let after = after.trim_start();
            let name = after
                .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                .next();
            let name = name.unwrap_or_default();
            if after[name.len()..].trim_start().starts_with('{') {
                inline.push((name.to_string(), depth));
            }
        } else if let Some(after) = rest.strip_prefix("crate::") {
            found.extend(paths_at(after));
        } else if let Some(after) = rest.strip_prefix("super::") {
            let here: Vec<&String> = module.iter().chain(inline.iter().map(|(m, _)| m)).collect();
            for path in paths_at(after) {
                let ups = 1 + path.iter().take_while(|s| *s == "super").count();
                let base = here[..here.len() - ups].iter().map(|s| s.to_string());
                found.push(base.chain(path.into_iter().skip(ups - 1)).collect());
            }
        }
    }
    found
}

struct SourceTree {
    /// Files by module path.
    files: BTreeMap<Vec<String>, String>,
    /// Each file's code, comments and literals blanked.
    code: BTreeMap<String, (Vec<String>, String)>,
}

fn source_tree() -> SourceTree {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let (mut files, mut code) = (BTreeMap::new(), BTreeMap::new());
    for path in rust_files(&src) {
        let relative = path.strip_prefix(&src).unwrap();
        let name = format!("src/{}", relative.display());
        let module = module_of(relative);
        let text = std::fs::read_to_string(&path).unwrap();
        files.insert(module.clone(), name.clone());
        code.insert(name, (module, code_only(&text)));
    }
    SourceTree { files, code }
}

impl SourceTree {
    /// The file a path lands in: the longest prefix of it that is a file's module.
    fn file_of(&self, path: &[String]) -> &str {
        (0..=path.len())
            .rev()
            .find_map(|n| self.files.get(&path[..n]))
            .expect("src/lib.rs holds the root")
    }

    /// Each file and the files it refers to (itself left out), with the paths that do.
    fn graph(&self) -> BTreeMap<&str, BTreeMap<&str, BTreeSet<String>>> {
        let mut graph: BTreeMap<&str, BTreeMap<&str, BTreeSet<String>>> = BTreeMap::new();
        for (file, (module, code)) in &self.code {
            let edges = graph.entry(file).or_default();
            for path in referenced_paths(code, module) {
                let target = self.file_of(&path);
                if target != file {
                    let written = format!("crate::{}", path.join("::"));
                    edges.entry(target).or_default().insert(written);
                }
            }
        }
        graph
    }
}

/// The top-level module a file belongs to (None for src/lib.rs).
fn top_module(file: &str) -> Option<&str> {
    let inner = file.strip_prefix("src/")?;
    let top = inner.split('/').next()?.trim_end_matches(".rs");
    (top != "lib").then_some(top)
}

#[test]
fn stages_refer_only_to_the_layers_below() {
    let tree = source_tree();
    let mut crossings = Vec::new();
    for (file, targets) in tree.graph() {
        let Some(from) = top_module(file) else {
            continue; // the crate root declares every module
        };
        for (target, paths) in targets {
            let Some(to) = top_module(target) else {
                crossings.push(format!(
                    "{file} -> src/lib.rs via {paths:?}: name the module"
                ));
                continue;
            };
            if !allowed(from, to) {
                let (a, b) = (layer_of(from), layer_of(to));
                crossings.push(format!("{file} ({a:?}) -> {target} ({b:?}) via {paths:?}"));
            }
        }
    }
    assert!(
        crossings.is_empty(),
        "references across the layers:\n{}",
        crossings.join("\n")
    );
}

/// The strongly connected components of `graph` with more than one file (Tarjan).
fn circles<'a>(
    graph: &BTreeMap<&'a str, BTreeMap<&'a str, BTreeSet<String>>>,
) -> Vec<Vec<&'a str>> {
    struct Search<'g, 'a> {
        graph: &'g BTreeMap<&'a str, BTreeMap<&'a str, BTreeSet<String>>>,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        found: Vec<Vec<&'a str>>,
    }
    impl<'a> Search<'_, 'a> {
        fn visit(&mut self, v: &'a str) {
            let n = self.index.len();
            self.index.insert(v, n);
            self.low.insert(v, n);
            self.stack.push(v);
            for &w in self.graph.get(v).into_iter().flat_map(|e| e.keys()) {
                if !self.index.contains_key(w) {
                    self.visit(w);
                    self.low.insert(v, self.low[v].min(self.low[w]));
                } else if self.stack.contains(&w) {
                    self.low.insert(v, self.low[v].min(self.index[w]));
                }
            }
            if self.low[v] == self.index[v] {
                let at = self.stack.iter().position(|&s| s == v).unwrap();
                let component = self.stack.split_off(at);
                if component.len() > 1 {
                    self.found.push(component);
                }
            }
        }
    }
    let mut search = Search {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        found: Vec::new(),
    };
    for &v in graph.keys() {
        if !search.index.contains_key(v) {
            search.visit(v);
        }
    }
    search.found
}

#[test]
fn no_two_files_refer_to_each_other() {
    let tree = source_tree();
    let graph = tree.graph();
    let found = circles(&graph);
    let described: Vec<String> = found
        .iter()
        .map(|files| {
            let edges = files.iter().flat_map(|&a| {
                let graph = &graph;
                files.iter().filter_map(move |&b| {
                    graph[a]
                        .get(b)
                        .map(|paths| format!("  {a} -> {b} via {paths:?}"))
                })
            });
            edges.collect::<Vec<_>>().join("\n")
        })
        .collect();
    assert!(
        found.is_empty(),
        "import circles between files:\n{}",
        described.join("\n\n")
    );
}
