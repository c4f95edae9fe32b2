//! The architecture's rules (ARCHITECTURE.md), checked from the source:
//! - inside every crate, no import cycle between the top-level modules, nor between sibling
//!   files or folders inside any folder;
//! - the layer diagram of ARCHITECTURE.md: every top-level module uses only modules on lower
//!   lines;
//! - the code map of ARCHITECTURE.md names every source file and folder, and only existing ones;
//! - the render core does no I/O;
//! - every file with `unsafe` code allows it explicitly and says why.
//!
//! The graph is drawn from the code itself: `use` trees, and inline `crate::…`, `super::…` and
//! `self::…` paths, test modules (`#[cfg(test)]`) left out. Each path is resolved to the module
//! that defines the item, following `pub use` re-exports, so a re-export in a `mod.rs` cannot
//! hide a dependency. An edge joins two siblings X → Y when anything inside X uses anything
//! defined inside Y. A module naming its own children (as `mod.rs` does) is not an edge between
//! siblings, so it cannot make a cycle; everything else is.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// A module path inside one crate: `["accel", "bvh"]`; the root is empty.
type ModPath = Vec<String>;

/// One crate's modules and the references of each.
struct Crate {
    name: String,
    /// Every module that is a file or folder.
    modules: BTreeSet<ModPath>,
    /// `pub use` re-exports: (module, exported name) → the full path it names.
    reexports: BTreeMap<(ModPath, String), ModPath>,
    /// (module the reference is written in, path as written, resolved from that module).
    refs: Vec<(ModPath, ModPath)>,
}

/// The repository's root.
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn workspace_crates() -> Vec<PathBuf> {
    let root = repo().join("crates");
    let mut dirs: Vec<PathBuf> = fs::read_dir(&root)
        .expect("crates/ is readable")
        .map(|e| e.expect("a directory entry").path())
        .filter(|p| p.join("src").is_dir())
        .collect();
    dirs.sort();
    dirs
}

/// The source without comments, strings and character literals (replaced by spaces, so that
/// braces and `::` inside them do not count).
fn strip(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if c == b'/' && b.get(i + 1) == Some(&b'*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    if b[i] == b'\n' {
                        out.push(b'\n');
                    }
                    i += 1;
                }
            }
            out.push(b' ');
        } else if c == b'r' && (b.get(i + 1) == Some(&b'"') || b.get(i + 1) == Some(&b'#')) && {
            let prev = if i == 0 { b' ' } else { b[i - 1] };
            !(prev.is_ascii_alphanumeric() || prev == b'_')
        } {
            // Raw string r#"..."#.
            let mut j = i + 1;
            let mut hashes = 0;
            while b.get(j) == Some(&b'#') {
                hashes += 1;
                j += 1;
            }
            if b.get(j) != Some(&b'"') {
                out.push(c);
                i += 1;
                continue;
            }
            j += 1;
            loop {
                if j >= b.len() {
                    break;
                }
                if b[j] == b'"' && (0..hashes).all(|k| b.get(j + 1 + k) == Some(&b'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push(b' ');
            i = j;
        } else if c == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                if b[i] == b'\\' {
                    i += 1;
                }
                i += 1;
            }
            i += 1;
            out.push(b' ');
        } else if c == b'\'' {
            // A character literal ('x', '\n', '\u{..}') or a lifetime ('a).
            let close = if b.get(i + 1) == Some(&b'\\') {
                (i + 2..b.len().min(i + 12)).find(|&j| b[j] == b'\'')
            } else if b.get(i + 2) == Some(&b'\'') {
                Some(i + 2)
            } else {
                // Multi-byte UTF-8 character literal.
                (i + 2..b.len().min(i + 6)).find(|&j| b[j] == b'\'' && b[i + 1] >= 0x80)
            };
            match close {
                Some(j) => {
                    out.push(b' ');
                    i = j + 1;
                }
                None => {
                    out.push(c);
                    i += 1;
                }
            }
        } else {
            out.push(c);
            i += 1;
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// The tokens of stripped source: identifiers, `::`, and single punctuation characters.
fn tokens(src: &str) -> Vec<String> {
    let mut t = Vec::new();
    let b: Vec<char> = src.chars().collect();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        if c.is_alphanumeric() || c == '_' {
            let s = i;
            while i < b.len() && (b[i].is_alphanumeric() || b[i] == '_') {
                i += 1;
            }
            t.push(b[s..i].iter().collect());
        } else if c == ':' && b.get(i + 1) == Some(&':') {
            t.push("::".into());
            i += 2;
        } else if c.is_whitespace() {
            i += 1;
        } else {
            t.push(c.to_string());
            i += 1;
        }
    }
    t
}

/// Flattens a `use` tree starting at `t[*i]` (after `use`) into full paths as written; each
/// path ends with its item (or `self`/`*`). Stops after the closing `;`.
fn use_tree(t: &[String], i: &mut usize, prefix: &[String], out: &mut Vec<(Vec<String>, String)>) {
    let mut path: Vec<String> = prefix.to_vec();
    loop {
        let Some(tok) = t.get(*i) else { return };
        match tok.as_str() {
            "{" => {
                *i += 1;
                loop {
                    use_tree(t, i, &path, out);
                    match t.get(*i).map(String::as_str) {
                        Some(",") => *i += 1,
                        Some("}") => {
                            *i += 1;
                            break;
                        }
                        _ => return,
                    }
                    if t.get(*i).map(String::as_str) == Some("}") {
                        *i += 1;
                        break;
                    }
                }
                return;
            }
            "::" => *i += 1,
            "," | "}" | ";" => {
                if !path.is_empty() && path.len() > prefix.len() {
                    let alias = path.last().cloned().unwrap_or_default();
                    out.push((path, alias));
                }
                return;
            }
            "as" => {
                let alias = t.get(*i + 1).cloned().unwrap_or_default();
                *i += 2;
                out.push((path.clone(), alias));
                // Leave the terminator for the caller.
                path.clear();
                while let Some(x) = t.get(*i) {
                    if x == "," || x == "}" || x == ";" {
                        return;
                    }
                    *i += 1;
                }
                return;
            }
            _ => {
                path.push(tok.clone());
                *i += 1;
            }
        }
    }
}

/// Resolves a path as written in module `at` into an absolute module path (items included), or
/// `None` when it leaves the crate (another crate, std).
fn absolute(at: &ModPath, written: &[String], children: &BTreeSet<ModPath>) -> Option<ModPath> {
    let first = written.first()?;
    let mut base: ModPath;
    let mut rest = written;
    match first.as_str() {
        "crate" => {
            base = Vec::new();
            rest = &rest[1..];
        }
        "self" => {
            base = at.clone();
            rest = &rest[1..];
        }
        "super" => {
            base = at.clone();
            while rest.first().map(String::as_str) == Some("super") {
                base.pop()?;
                rest = &rest[1..];
            }
        }
        name => {
            // A bare path: a child module of the current one (2018 paths), else external.
            let mut child = at.clone();
            child.push(name.to_string());
            if children.contains(&child) {
                base = at.clone();
            } else {
                return None;
            }
        }
    }
    base.extend(rest.iter().filter(|s| *s != "self").cloned());
    Some(base)
}

/// The source files of a crate, each with its module path.
fn source_files(src: &Path) -> Vec<(PathBuf, ModPath)> {
    fn walk(dir: &Path, module: &ModPath, out: &mut Vec<(PathBuf, ModPath)>) {
        let mut entries: Vec<PathBuf> = fs::read_dir(dir)
            .expect("readable source directory")
            .map(|e| e.expect("entry").path())
            .collect();
        entries.sort();
        for p in entries {
            let stem = p.file_stem().unwrap().to_string_lossy().into_owned();
            if p.is_dir() {
                let mut m = module.clone();
                m.push(stem);
                walk(&p, &m, out);
            } else if p.extension().is_some_and(|e| e == "rs") {
                let m = if ["mod", "lib", "main"].contains(&stem.as_str()) && module.is_empty()
                    || stem == "mod"
                {
                    module.clone()
                } else {
                    let mut m = module.clone();
                    m.push(stem);
                    m
                };
                out.push((p, m));
            }
        }
    }
    let mut out = Vec::new();
    walk(src, &Vec::new(), &mut out);
    out
}

fn load_crate(dir: &Path) -> Crate {
    let name = dir.file_name().unwrap().to_string_lossy().into_owned();
    let files = source_files(&dir.join("src"));
    // A binary crate's main.rs and a library's lib.rs are different crates; the CLI has only
    // main.rs, so both are the root here.
    let modules: BTreeSet<ModPath> = files.iter().map(|(_, m)| m.clone()).collect();
    let mut reexports = BTreeMap::new();
    let mut refs = Vec::new();
    for (path, module) in &files {
        let src = fs::read_to_string(path).expect("readable source");
        let t = tokens(&strip(&src));
        // Module nesting: inline `mod x { … }` blocks (test modules skipped entirely).
        let mut stack: Vec<(usize, Option<String>)> = Vec::new(); // (brace depth at open, name)
        let mut depth = 0usize;
        let mut cfg_test = false;
        let mut i = 0;
        let current = |stack: &Vec<(usize, Option<String>)>| -> ModPath {
            let mut m = module.clone();
            m.extend(stack.iter().filter_map(|(_, n)| n.clone()));
            m
        };
        while i < t.len() {
            let tok = t[i].as_str();
            match tok {
                "#" => {
                    // Attributes: note `#[cfg(test)]` (not `cfg(not(test))`).
                    let mut j = i + 1;
                    if t.get(j).map(String::as_str) == Some("!") {
                        j += 1;
                    }
                    if t.get(j).map(String::as_str) == Some("[") {
                        let start = j;
                        let mut d = 0;
                        while j < t.len() {
                            if t[j] == "[" {
                                d += 1;
                            } else if t[j] == "]" {
                                d -= 1;
                                if d == 0 {
                                    break;
                                }
                            }
                            j += 1;
                        }
                        let attr: Vec<&str> = t[start..=j.min(t.len() - 1)]
                            .iter()
                            .map(String::as_str)
                            .collect();
                        if attr == ["[", "cfg", "(", "test", ")", "]"] {
                            cfg_test = true;
                        }
                        i = j + 1;
                        continue;
                    }
                    i += 1;
                }
                "{" => {
                    depth += 1;
                    i += 1;
                }
                "}" => {
                    depth = depth.saturating_sub(1);
                    while stack.last().is_some_and(|(d, _)| *d == depth) {
                        stack.pop();
                    }
                    i += 1;
                }
                "mod" if t.get(i + 2).map(String::as_str) == Some("{") => {
                    let name = t[i + 1].clone();
                    if cfg_test {
                        // Skip the whole test module.
                        let mut d = 0;
                        let mut j = i + 2;
                        while j < t.len() {
                            if t[j] == "{" {
                                d += 1;
                            } else if t[j] == "}" {
                                d -= 1;
                                if d == 0 {
                                    break;
                                }
                            }
                            j += 1;
                        }
                        cfg_test = false;
                        i = j + 1;
                        continue;
                    }
                    stack.push((depth, Some(name)));
                    depth += 1;
                    i += 3;
                }
                "use" => {
                    let is_pub = i > 0 && (t[i - 1] == "pub" || t[i - 1] == ")");
                    let at = current(&stack);
                    let mut j = i + 1;
                    let mut paths = Vec::new();
                    use_tree(&t, &mut j, &[], &mut paths);
                    let skip = cfg_test;
                    cfg_test = false;
                    i = j + 1;
                    if skip {
                        continue;
                    }
                    let kids: BTreeSet<ModPath> = modules
                        .iter()
                        .filter(|m| m.len() == at.len() + 1 && m.starts_with(&at))
                        .cloned()
                        .collect();
                    for (written, alias) in paths {
                        if let Some(abs) = absolute(&at, &written, &kids) {
                            if is_pub && alias != "*" && alias != "self" {
                                reexports.insert((at.clone(), alias), abs.clone());
                            }
                            refs.push((at.clone(), abs));
                        }
                    }
                }
                "crate" | "super" | "self" if t.get(i + 1).map(String::as_str) == Some("::") => {
                    let at = current(&stack);
                    let mut written = vec![t[i].clone()];
                    let mut j = i + 1;
                    while t.get(j).map(String::as_str) == Some("::")
                        && t.get(j + 1)
                            .is_some_and(|s| s.chars().all(|c| c.is_alphanumeric() || c == '_'))
                    {
                        written.push(t[j + 1].clone());
                        j += 2;
                    }
                    if let Some(abs) = absolute(&at, &written, &BTreeSet::new()) {
                        refs.push((at, abs));
                    }
                    i = j;
                }
                ";" => {
                    cfg_test = false;
                    i += 1;
                }
                "fn" | "struct" | "enum" | "impl" | "const" | "static" | "type" | "trait" => {
                    if cfg_test {
                        // A test-only item: skip to its end.
                        let mut j = i;
                        let mut d = 0;
                        while j < t.len() {
                            if t[j] == "{" {
                                d += 1;
                            } else if t[j] == "}" {
                                d -= 1;
                                if d == 0 {
                                    break;
                                }
                            } else if t[j] == ";" && d == 0 {
                                break;
                            }
                            j += 1;
                        }
                        cfg_test = false;
                        i = j + 1;
                        continue;
                    }
                    i += 1;
                }
                "mod" if t.get(i + 2).map(String::as_str) == Some(";") => {
                    cfg_test = false;
                    i += 3;
                }
                _ => i += 1,
            }
        }
    }
    Crate {
        name,
        modules,
        reexports,
        refs,
    }
}

impl Crate {
    /// The module that defines what `path` names: the longest prefix that is a module, then
    /// through re-exports of that module.
    fn defining_module(&self, path: &ModPath) -> ModPath {
        let mut path = path.clone();
        for _ in 0..16 {
            let mut k = path.len();
            while k > 0 && !self.modules.contains(&path[..k]) {
                k -= 1;
            }
            let module = path[..k].to_vec();
            let Some(item) = path.get(k) else {
                return module;
            };
            match self.reexports.get(&(module.clone(), item.clone())) {
                Some(target) if *target != path[..=k] => {
                    let mut next = target.clone();
                    next.extend(path[k + 1..].iter().cloned());
                    path = next;
                }
                _ => return module,
            }
        }
        path
    }

    /// Every cycle between siblings: (parent folder, the siblings of one strongly connected
    /// component, an example edge list).
    fn cycles(&self) -> Vec<String> {
        // Module-level dependencies.
        let deps: BTreeSet<(ModPath, ModPath)> = self
            .refs
            .iter()
            .map(|(from, to)| {
                // Inline modules are part of their file.
                let mut f = from.clone();
                while !self.modules.contains(&f) {
                    f.pop();
                }
                (f, self.defining_module(to))
            })
            .filter(|(a, b)| a != b)
            .collect();
        let mut report = Vec::new();
        let parents: BTreeSet<ModPath> = self
            .modules
            .iter()
            .filter(|m| !m.is_empty())
            .map(|m| m[..m.len() - 1].to_vec())
            .collect();
        for parent in parents {
            let kids: Vec<ModPath> = self
                .modules
                .iter()
                .filter(|m| m.len() == parent.len() + 1 && m.starts_with(&parent))
                .cloned()
                .collect();
            let child_of = |m: &ModPath| -> Option<usize> {
                if m.len() <= parent.len() || !m.starts_with(&parent) {
                    return None;
                }
                kids.iter().position(|k| k[..] == m[..parent.len() + 1])
            };
            let mut edges: BTreeMap<(usize, usize), (ModPath, ModPath)> = BTreeMap::new();
            for (a, b) in &deps {
                if let (Some(x), Some(y)) = (child_of(a), child_of(b)) {
                    if x != y {
                        edges.entry((x, y)).or_insert((a.clone(), b.clone()));
                    }
                }
            }
            for comp in scc(kids.len(), &edges) {
                if comp.len() < 2 {
                    continue;
                }
                let mut comp = comp;
                comp.sort_unstable();
                let names: Vec<String> = comp.iter().map(|&k| kids[k].join("::")).collect();
                let why: Vec<String> = edges
                    .iter()
                    .filter(|((x, y), _)| comp.contains(x) && comp.contains(y))
                    .map(|(_, (a, b))| format!("{} -> {}", a.join("::"), b.join("::")))
                    .collect();
                report.push(format!(
                    "{}: cycle in {}::{{{}}}\n      {}",
                    self.name,
                    if parent.is_empty() {
                        "crate".to_string()
                    } else {
                        parent.join("::")
                    },
                    names.join(", "),
                    why.join("\n      ")
                ));
            }
        }
        report
    }
}

/// Strongly connected components (Tarjan), each as a list of node indices.
fn scc(n: usize, edges: &BTreeMap<(usize, usize), (ModPath, ModPath)>) -> Vec<Vec<usize>> {
    struct Tarjan {
        adj: Vec<Vec<usize>>,
        index: Vec<usize>,
        low: Vec<usize>,
        on: Vec<bool>,
        stack: Vec<usize>,
        counter: usize,
        out: Vec<Vec<usize>>,
    }
    impl Tarjan {
        fn visit(&mut self, v: usize) {
            self.index[v] = self.counter;
            self.low[v] = self.counter;
            self.counter += 1;
            self.stack.push(v);
            self.on[v] = true;
            for k in 0..self.adj[v].len() {
                let w = self.adj[v][k];
                if self.index[w] == usize::MAX {
                    self.visit(w);
                    self.low[v] = self.low[v].min(self.low[w]);
                } else if self.on[w] {
                    self.low[v] = self.low[v].min(self.index[w]);
                }
            }
            if self.low[v] == self.index[v] {
                let mut comp = Vec::new();
                while let Some(w) = self.stack.pop() {
                    self.on[w] = false;
                    comp.push(w);
                    if w == v {
                        break;
                    }
                }
                self.out.push(comp);
            }
        }
    }
    let mut t = Tarjan {
        adj: (0..n)
            .map(|x| {
                edges
                    .keys()
                    .filter(|(a, _)| *a == x)
                    .map(|(_, b)| *b)
                    .collect()
            })
            .collect(),
        index: vec![usize::MAX; n],
        low: vec![0; n],
        on: vec![false; n],
        stack: Vec::new(),
        counter: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if t.index[v] == usize::MAX {
            t.visit(v);
        }
    }
    t.out
}

#[test]
fn no_import_cycles_between_sibling_modules() {
    let mut report = Vec::new();
    for dir in workspace_crates() {
        report.extend(load_crate(&dir).cycles());
    }
    assert!(
        report.is_empty(),
        "import cycles (every sibling dependency of each cycle listed):\n{}",
        report.join("\n")
    );
}

#[test]
fn the_checker_sees_a_cycle() {
    // Two sibling files that import each other, through a re-export in their parent.
    let dir = std::env::temp_dir().join(format!("candela-layers-{}", std::process::id()));
    let src = dir.join("src");
    fs::create_dir_all(src.join("a")).unwrap();
    fs::write(src.join("lib.rs"), "pub mod a;\npub mod b;\n").unwrap();
    fs::write(src.join("a/mod.rs"), "mod x;\nmod y;\npub use x::X;\n").unwrap();
    fs::write(src.join("a/x.rs"), "use super::y::Y;\npub struct X;\n").unwrap();
    fs::write(
        src.join("a/y.rs"),
        "pub struct Y(super::X);\n#[cfg(test)]\nmod tests { use crate::b::B; }\n",
    )
    .unwrap();
    fs::write(src.join("b.rs"), "pub struct B;\n").unwrap();
    let c = load_crate(&dir);
    let cycles = c.cycles();
    fs::remove_dir_all(&dir).unwrap();
    assert_eq!(cycles.len(), 1, "{cycles:?}");
    assert!(cycles[0].contains("a::{a::x, a::y}"), "{}", cycles[0]);
}

impl Crate {
    /// Dependencies between distinct top-level modules (the crate root's own items left out).
    fn top_level_edges(&self) -> BTreeSet<(String, String)> {
        let mut edges = BTreeSet::new();
        for (from, to) in &self.refs {
            let mut f = from.clone();
            while !self.modules.contains(&f) {
                f.pop();
            }
            let t = self.defining_module(to);
            if let (Some(a), Some(b)) = (f.first(), t.first()) {
                if a != b {
                    edges.insert((a.clone(), b.clone()));
                }
            }
        }
        edges
    }

    /// The top-level modules.
    fn top_level(&self) -> BTreeSet<String> {
        self.modules
            .iter()
            .filter(|m| m.len() == 1)
            .map(|m| m[0].clone())
            .collect()
    }
}

/// The package name of a crate folder (`crates/render` → `candela-render`).
fn package(dir: &Path) -> String {
    let toml = fs::read_to_string(dir.join("Cargo.toml")).expect("Cargo.toml");
    toml.lines()
        .find_map(|l| l.strip_prefix("name = \""))
        .and_then(|l| l.strip_suffix('"'))
        .expect("a package name")
        .to_string()
}

fn architecture_md() -> String {
    fs::read_to_string(repo().join("ARCHITECTURE.md")).expect("ARCHITECTURE.md")
}

/// The layer diagrams of ARCHITECTURE.md: package → its lines of modules, top line first.
fn layer_diagrams(md: &str) -> BTreeMap<String, Vec<Vec<String>>> {
    let mut out = BTreeMap::new();
    let mut current: Option<String> = None;
    for line in md.lines() {
        if let Some(name) = line.strip_suffix(" (top to bottom)") {
            current = Some(name.trim().to_string());
            out.insert(name.trim().to_string(), Vec::new());
        } else if line.trim().is_empty() || line.starts_with("```") {
            current = None;
        } else if let Some(c) = &current {
            let mods = line
                .split('·')
                .map(|m| m.trim().to_string())
                .filter(|m| !m.is_empty())
                .collect();
            out.get_mut(c).expect("started").push(mods);
        }
    }
    out
}

#[test]
fn the_layer_diagrams_match_the_imports() {
    let diagrams = layer_diagrams(&architecture_md());
    let mut report = Vec::new();
    for dir in workspace_crates() {
        let c = load_crate(&dir);
        let name = package(&dir);
        let Some(lines) = diagrams.get(&name) else {
            report.push(format!("ARCHITECTURE.md has no layer diagram for {name}"));
            continue;
        };
        // Line index from the bottom: a module may use modules with a smaller index.
        let mut level = BTreeMap::new();
        for (i, mods) in lines.iter().rev().enumerate() {
            for m in mods {
                if level.insert(m.clone(), i).is_some() {
                    report.push(format!("{name}: `{m}` is listed twice"));
                }
            }
        }
        for m in c.top_level() {
            if !level.contains_key(&m) {
                report.push(format!("{name}: module `{m}` is missing from the diagram"));
            }
        }
        for m in level.keys() {
            if !c.top_level().contains(m) {
                report.push(format!(
                    "{name}: the diagram lists `{m}`, which is not a module"
                ));
            }
        }
        for (a, b) in c.top_level_edges() {
            if let (Some(la), Some(lb)) = (level.get(&a), level.get(&b)) {
                if lb >= la {
                    report.push(format!("{name}: `{a}` uses `{b}`, which is not below it"));
                }
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

/// The backticked words of each crate's code-map section (`### \`crates/NAME\``).
fn code_map_words(md: &str) -> BTreeMap<String, BTreeSet<String>> {
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut current: Option<String> = None;
    for line in md.lines() {
        if let Some(rest) = line.strip_prefix("### `crates/") {
            current = rest.split('`').next().map(str::to_string);
            continue;
        }
        if line.starts_with("## ") {
            current = None;
        }
        let Some(c) = &current else { continue };
        let words = out.entry(c.clone()).or_default();
        for (k, w) in line.split('`').enumerate() {
            if k % 2 == 1 {
                words.insert(w.to_string());
            }
        }
    }
    out
}

#[test]
fn the_code_map_names_every_source_file() {
    let map = code_map_words(&architecture_md());
    let mut report = Vec::new();
    for dir in workspace_crates() {
        let folder = dir.file_name().unwrap().to_string_lossy().into_owned();
        let src = dir.join("src");
        let Some(words) = map.get(&folder) else {
            report.push(format!(
                "ARCHITECTURE.md has no code map for crates/{folder}"
            ));
            continue;
        };
        let mut names = BTreeSet::new();
        for (path, _) in source_files(&src) {
            let rel = path
                .strip_prefix(&src)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            let file = path.file_name().unwrap().to_string_lossy().into_owned();
            names.insert(file.clone());
            for folder in Path::new(&rel).parent().into_iter().flat_map(|p| p.iter()) {
                let f = format!("{}/", folder.to_string_lossy());
                if !words.iter().any(|w| w.ends_with(&f)) {
                    report.push(format!(
                        "crates/{}: the code map does not name `{f}`",
                        src.display()
                    ));
                }
                names.insert(f);
            }
            if ["mod.rs", "lib.rs", "main.rs"].contains(&file.as_str()) {
                continue;
            }
            if !words.contains(&file) && !words.contains(&rel) {
                report.push(format!(
                    "crates/{folder}/src: the code map does not name `{rel}`"
                ));
            }
        }
        for w in words {
            let w = w.trim_start_matches("src/");
            if w.ends_with(".rs") && !w.contains('/') && !names.contains(w) {
                report.push(format!(
                    "crates/{folder}: the code map names `{w}`, which does not exist"
                ));
            }
            if w.ends_with('/') && !w.contains(' ') && !w.starts_with("crates/") {
                let last = format!("{}/", w.trim_end_matches('/').rsplit('/').next().unwrap());
                if !names.contains(&last) {
                    report.push(format!(
                        "crates/{folder}: the code map names `{w}`, which is not a folder of src/"
                    ));
                }
            }
        }
    }
    report.dedup();
    assert!(report.is_empty(), "{}", report.join("\n"));
}

#[test]
fn the_render_core_does_no_io() {
    let src = repo().join("crates/render/src");
    let mut report = Vec::new();
    for (path, _) in source_files(&src) {
        let text = strip(&fs::read_to_string(&path).unwrap());
        for bad in [
            "std::fs",
            "std::io",
            "std::net",
            "std::process",
            "println!",
            "eprintln!",
            "File::",
        ] {
            if text.contains(bad) {
                report.push(format!("{}: uses {bad}", path.display()));
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

#[test]
fn unsafe_code_lives_only_where_a_file_says_why() {
    let mut report = Vec::new();
    for dir in workspace_crates() {
        for (path, _) in source_files(&dir.join("src")) {
            let raw = fs::read_to_string(&path).unwrap();
            let t = tokens(&strip(&raw));
            if !t.iter().any(|w| w == "unsafe") {
                continue;
            }
            let allowed = raw.contains("#![allow(unsafe_code)]");
            let explained = raw.contains("Why unsafe code is allowed");
            if !(allowed && explained) {
                report.push(format!(
                    "{}: unsafe code without `#![allow(unsafe_code)]` and a `Why unsafe code is allowed` comment",
                    path.display()
                ));
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}
