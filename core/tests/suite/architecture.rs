//! The layering of the core: no import cycle between its top-level modules,
//! and `bsdf` below `scene`.
//!
//! [`import_graph`] reads a crate's source tree and links module A to
//! module B when A's code names a path into B: `use` statements (with their
//! `{…}` groups) and inline paths alike, written from the crate root
//! (`crate::b::…`), relative to the module (`super::…`, `self::…`) or
//! through a child module's name. Modules are cut at a depth: at depth 1
//! `scene::material` counts as `scene`, so the graph is that of the
//! top-level modules. [`find_cycle`] then looks for a cycle. Comments (doc
//! links included) and literals do not count: they name paths without
//! using them.
//!
//! The cycle check reads the code that is built ([`Code::Built`]) and
//! leaves out test code (items under `#[cfg(test)]`, or `all(test, …)`,
//! and the files of such modules): nothing imports a test, so a test that
//! reaches into a higher module (geometry's triangle tests hold the BVH's
//! register kernels to the portable form) makes no module depend on
//! another in any build. The tests' own edges can still be read
//! ([`Code::WithTests`]), as the check that `bsdf` names nothing of
//! `scene` does.
//!
//! The reader is a sketch of Rust's path rules, not a parser: a path
//! reached only through a `use` of a re-export is attributed to the module
//! that re-exports it, and macros' expansions are not seen.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// A module path from the crate root (`["scene", "material"]`); empty for
/// the root.
type ModPath = Vec<String>;

/// Where an edge of the graph was first seen: file and line.
type Evidence = (PathBuf, usize);

/// Edges between the modules of a crate cut at some depth, each with the
/// first place it is named.
pub type Graph = BTreeMap<ModPath, BTreeMap<ModPath, Evidence>>;

/// Which code a graph is read from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Code {
    /// The code of the crate's builds: test code left out.
    Built,
    /// Every line, test code included.
    WithTests,
}

/// A token of Rust source with comments removed.
#[derive(Clone, Debug, PartialEq)]
enum Token {
    Ident(String),
    /// `::`
    PathSep,
    /// A string or character literal.
    Literal,
    /// Any other character.
    Punct(char),
}

/// The tokens of `src`, each with its line: comments are skipped,
/// lifetimes read as a `'` and an identifier (harmless: they never precede
/// `::`).
fn tokens(src: &str) -> Vec<(Token, usize)> {
    let c: Vec<char> = src.chars().collect();
    let at = |k: usize| c.get(k).copied().unwrap_or('\0');
    // The index after the literal closed by `close` from `from` on,
    // skipping escapes.
    let literal_end = |from: usize, close: char| {
        let mut j = from;
        while j < c.len() && c[j] != close {
            j += if c[j] == '\\' { 2 } else { 1 };
        }
        j + 1
    };
    let mut out = Vec::new();
    let (mut i, mut line) = (0, 1);
    while i < c.len() {
        let start = i;
        let token = match c[i] {
            '/' if at(i + 1) == '/' => {
                i = (i..c.len()).find(|&k| c[k] == '\n').unwrap_or(c.len());
                None
            }
            '/' if at(i + 1) == '*' => {
                // Block comments nest.
                let mut depth = 0;
                loop {
                    if i >= c.len() {
                        break;
                    } else if c[i] == '/' && at(i + 1) == '*' {
                        depth += 1;
                        i += 2;
                    } else if c[i] == '*' && at(i + 1) == '/' {
                        depth -= 1;
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        i += 1;
                    }
                }
                None
            }
            'r' | 'b' if raw_string(&c, i).is_some() => {
                let (body, hashes) = raw_string(&c, i).unwrap();
                let close: Vec<char> = std::iter::once('"')
                    .chain(std::iter::repeat_n('#', hashes))
                    .collect();
                i = (body..c.len())
                    .find(|&k| c[k..].starts_with(&close))
                    .map_or(c.len(), |k| k + close.len());
                Some(Token::Literal)
            }
            '"' => {
                i = literal_end(i + 1, '"');
                Some(Token::Literal)
            }
            // A character literal: 'x', '\n', '\u{…}' (not a lifetime).
            '\'' if at(i + 1) == '\\' || at(i + 2) == '\'' => {
                i = literal_end(i + 1, '\'');
                Some(Token::Literal)
            }
            ':' if at(i + 1) == ':' => {
                i += 2;
                Some(Token::PathSep)
            }
            x if x == '_' || x.is_alphanumeric() => {
                i = (i..c.len())
                    .find(|&k| !(c[k] == '_' || c[k].is_alphanumeric()))
                    .unwrap_or(c.len());
                Some(Token::Ident(c[start..i].iter().collect()))
            }
            x => {
                i += 1;
                (!x.is_whitespace()).then_some(Token::Punct(x))
            }
        };
        if let Some(token) = token {
            out.push((token, line));
        }
        line += c[start..i.min(c.len())]
            .iter()
            .filter(|&&x| x == '\n')
            .count();
    }
    out
}

/// For a raw (byte) string opening at `i` (`r"`, `r#"`, `br#"`…): the index
/// after its opening quote and its number of `#`.
fn raw_string(c: &[char], i: usize) -> Option<(usize, usize)> {
    // Not the tail of an identifier (`for"`…).
    if i > 0 && (c[i - 1] == '_' || c[i - 1].is_alphanumeric()) {
        return None;
    }
    let j = i + usize::from(c[i] == 'b');
    if c.get(j) != Some(&'r') {
        return None;
    }
    let hashes = c[j + 1..].iter().take_while(|&&x| x == '#').count();
    (c.get(j + 1 + hashes) == Some(&'"')).then_some((j + hashes + 2, hashes))
}

/// The module paths of the `.rs` files under `src` (`lib.rs`/`main.rs`: the
/// root; `a/mod.rs` and `a.rs`: `a`), parents before their children.
fn modules(src: &Path) -> BTreeMap<ModPath, PathBuf> {
    fn walk(dir: &Path, prefix: &ModPath, out: &mut BTreeMap<ModPath, PathBuf>) {
        let entries = fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        for path in entries.map(|e| e.unwrap().path()) {
            let name = path.file_stem().unwrap().to_string_lossy().into_owned();
            let mut module = prefix.clone();
            if path.is_dir() {
                module.push(name);
                walk(&path, &module, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let root = prefix.is_empty() && (name == "lib" || name == "main");
                if name != "mod" && !root {
                    module.push(name);
                }
                out.insert(module, path);
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(src, &Vec::new(), &mut out);
    out
}

/// The graph of the crate under `src` with modules cut at `depth` path
/// segments (1: the top-level modules; the root is the empty path), read
/// from `code`.
pub fn import_graph(src: &Path, depth: usize, code: Code) -> Graph {
    let files = modules(src);
    let node = |m: &[String]| -> ModPath {
        // The longest file-backed module containing `m`, cut at `depth`.
        let mut m = &m[..m.len().min(depth)];
        while !m.is_empty() && !files.contains_key(m) {
            m = &m[..m.len() - 1];
        }
        m.to_vec()
    };
    let mut graph = Graph::new();
    // Modules declared under `#[cfg(test)]`: their files are test code.
    let mut test_modules: BTreeSet<ModPath> = BTreeSet::new();
    for (module, file) in &files {
        let in_test = (0..=module.len()).any(|n| test_modules.contains(&module[..n]));
        if in_test && code == Code::Built {
            continue;
        }
        let from = node(module);
        let read = read_paths(&tokens(&fs::read_to_string(file).unwrap()), module);
        if !in_test {
            test_modules.extend(read.test_modules);
        }
        for (path, here, line, test) in read.paths {
            if test && code == Code::Built {
                continue;
            }
            let Some(target) = resolve(&path, &here, &files) else {
                continue;
            };
            let to = node(&target);
            if to != from {
                graph
                    .entry(from.clone())
                    .or_default()
                    .entry(to)
                    .or_insert_with(|| (file.clone(), line));
            }
        }
    }
    graph
}

/// What [`read_paths`] finds in a file.
struct FilePaths {
    /// Each path named, with the module it is written in, its line and
    /// whether it is test code.
    paths: Vec<(Vec<String>, ModPath, usize, bool)>,
    /// The file modules declared under `#[cfg(test)]` (`mod tests;`).
    test_modules: Vec<ModPath>,
}

/// The paths named in a file of module `module`. Inline `mod name { … }`
/// blocks are followed, since `super` inside one is the file's module.
fn read_paths(tokens: &[(Token, usize)], module: &ModPath) -> FilePaths {
    let is = |k: usize, t: &Token| tokens.get(k).is_some_and(|(x, _)| x == t);
    let ident = |k: usize| match tokens.get(k) {
        Some((Token::Ident(s), _)) => Some(s.as_str()),
        _ => None,
    };
    let mut found = FilePaths {
        paths: Vec::new(),
        test_modules: Vec::new(),
    };
    // The inline modules open, each with the brace depth outside it.
    let mut scopes: Vec<(usize, String)> = Vec::new();
    // The brace depth of the item a `#[cfg(test)]` applies to, while in it.
    let mut test: Option<usize> = None;
    let mut test_attribute = false;
    let mut depth = 0;
    let mut k = 0;
    while k < tokens.len() {
        match &tokens[k].0 {
            Token::Punct('#') if is(k + 1, &Token::Punct('[')) => {
                let end = matching(tokens, k + 1);
                test_attribute |= is_cfg_test(&tokens[k + 2..end]);
                k = end + 1;
                continue;
            }
            Token::Punct('{') => depth += 1,
            Token::Punct('}') => {
                depth -= 1;
                if scopes.last().is_some_and(|(d, _)| *d == depth) {
                    scopes.pop();
                }
                // The end of the item's body, or of the block holding it.
                if test.is_some_and(|d| d >= depth) {
                    test = None;
                }
            }
            // The end of an item without a body (`mod a;`, `use …;`).
            Token::Punct(';') if test == Some(depth) => test = None,
            Token::Ident(word) if word == "mod" => {
                if let Some(name) = ident(k + 1) {
                    let mut child = module.clone();
                    child.extend(scopes.iter().map(|(_, n)| n.clone()));
                    child.push(name.to_string());
                    if is(k + 2, &Token::Punct('{')) {
                        scopes.push((depth, name.to_string()));
                    } else if test.is_some() || test_attribute {
                        found.test_modules.push(child);
                    }
                }
            }
            _ => {}
        }
        // Attributes apply to the next item, which starts here.
        if test_attribute && test.is_none() {
            test = Some(depth);
        }
        test_attribute = false;
        // A path starts at an identifier not preceded by `::` (nor by `.`:
        // a method's turbofish, `x.collect::<…>()`).
        let continues = k > 0 && (is(k - 1, &Token::PathSep) || is(k - 1, &Token::Punct('.')));
        if matches!(tokens[k].0, Token::Ident(_)) && !continues {
            let mut paths = Vec::new();
            let next = use_tree(tokens, k, &mut Vec::new(), &mut paths);
            let mut here = module.clone();
            here.extend(scopes.iter().map(|(_, n)| n.clone()));
            let in_test = test.is_some();
            found.paths.extend(
                paths
                    .into_iter()
                    .map(|(p, line)| (p, here.clone(), line, in_test)),
            );
            // Past the path: a `use` group's braces are not blocks.
            if next > k + 1 {
                k = next;
                continue;
            }
        }
        k += 1;
    }
    found
}

/// The index of the bracket closing the one at `open` (`[`, `(` or `{`).
fn matching(tokens: &[(Token, usize)], open: usize) -> usize {
    let (o, c) = match tokens[open].0 {
        Token::Punct('[') => ('[', ']'),
        Token::Punct('(') => ('(', ')'),
        _ => ('{', '}'),
    };
    let mut depth = 0;
    for (k, (t, _)) in tokens.iter().enumerate().skip(open) {
        if *t == Token::Punct(o) {
            depth += 1;
        } else if *t == Token::Punct(c) {
            depth -= 1;
            if depth == 0 {
                return k;
            }
        }
    }
    tokens.len()
}

/// Whether an attribute's tokens (inside `#[…]`) are a `cfg` that holds
/// only in tests: `cfg(test)`, `cfg(all(…, test, …))`.
fn is_cfg_test(attr: &[(Token, usize)]) -> bool {
    fn test_only(p: &[(Token, usize)]) -> bool {
        match p.first().map(|t| &t.0) {
            Some(Token::Ident(s)) if s == "test" => p.len() == 1,
            Some(Token::Ident(s)) if s == "all" && p.len() > 1 => {
                // The comma-separated arguments inside `all(…)`.
                let end = matching(p, 1);
                let mut k = 2;
                let mut any = false;
                while k < end {
                    let mut j = k;
                    while j < end && p[j].0 != Token::Punct(',') {
                        if p[j].0 == Token::Punct('(') {
                            j = matching(p, j);
                        }
                        j += 1;
                    }
                    any |= test_only(&p[k..j]);
                    k = j + 1;
                }
                any
            }
            _ => false,
        }
    }
    matches!(attr.first(), Some((Token::Ident(s), _)) if s == "cfg")
        && attr.len() > 2
        && test_only(&attr[2..attr.len() - 1])
}

/// Reads the path (or `use` tree) at token `k` under `prefix` into `out`
/// and returns the index after it. `a::b::{c, d::e}` yields `a::b::c` and
/// `a::b::d::e`, `a::*` yields `a`.
fn use_tree(
    tokens: &[(Token, usize)],
    mut k: usize,
    prefix: &mut Vec<String>,
    out: &mut Vec<(Vec<String>, usize)>,
) -> usize {
    let base = prefix.len();
    let line = tokens[k].1;
    let mut separated = false;
    while let Some((Token::Ident(s), _)) = tokens.get(k) {
        prefix.push(s.clone());
        k += 1;
        if tokens.get(k).map(|t| &t.0) != Some(&Token::PathSep) {
            break;
        }
        separated = true;
        k += 1;
        if tokens.get(k).map(|t| &t.0) == Some(&Token::Punct('{')) {
            let end = matching(tokens, k);
            k += 1;
            while k < end {
                match tokens[k].0 {
                    Token::Ident(_) => k = use_tree(tokens, k, prefix, out),
                    _ => k += 1,
                }
            }
            prefix.truncate(base);
            return end + 1;
        }
    }
    // A lone identifier is a name, not a path (but in a `use` group it
    // continues the group's path).
    if separated || base > 0 {
        out.push((prefix.clone(), line));
    }
    prefix.truncate(base);
    k
}

/// The module of the crate (or an item in it; the caller cuts it to its
/// module) that `path`, written in module `here`, names; `None` when it
/// leads out of the crate. `crate::a` is `a`; `super::a` and `self::a`
/// are relative, and so is a first segment naming a child module of
/// `here` (`mod a;` beside the code). Any other first segment is an
/// external crate, a local item or a name a `use` brought in, which is
/// counted at that `use`.
fn resolve(
    path: &[String],
    here: &[String],
    files: &BTreeMap<ModPath, PathBuf>,
) -> Option<Vec<String>> {
    let (base, rest) = match path[0].as_str() {
        "crate" => (&[][..], &path[1..]),
        "self" => (here, &path[1..]),
        "super" => {
            let ups = path.iter().take_while(|s| *s == "super").count();
            (here.get(..here.len().checked_sub(ups)?)?, &path[ups..])
        }
        first => {
            let child: ModPath = here.iter().cloned().chain([first.to_string()]).collect();
            if !files.contains_key(&child) {
                return None;
            }
            (here, path)
        }
    };
    Some(base.iter().chain(rest).cloned().collect())
}

/// A cycle of `graph` as its modules, the first repeated at the end, or
/// `None` when the graph is acyclic.
pub fn find_cycle(graph: &Graph) -> Option<Vec<ModPath>> {
    /// Depth-first search from `m`; `stack` holds the modules being
    /// visited, `done` those whose every path has been followed.
    fn visit(
        g: &Graph,
        m: &ModPath,
        stack: &mut Vec<ModPath>,
        done: &mut BTreeSet<ModPath>,
    ) -> Option<Vec<ModPath>> {
        if let Some(start) = stack.iter().position(|s| s == m) {
            let mut cycle = stack[start..].to_vec();
            cycle.push(m.clone());
            return Some(cycle);
        }
        if done.contains(m) {
            return None;
        }
        stack.push(m.clone());
        for next in g.get(m).into_iter().flat_map(|e| e.keys()) {
            if let Some(cycle) = visit(g, next, stack, done) {
                return Some(cycle);
            }
        }
        stack.pop();
        done.insert(m.clone());
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|m| visit(graph, m, &mut Vec::new(), &mut done))
}

/// A module path as Rust writes it (`crate` for the root).
fn name(m: &ModPath) -> String {
    if m.is_empty() {
        "crate".into()
    } else {
        m.join("::")
    }
}

/// Panics with the cycle, and where each of its edges is first named, when
/// the built code of the crate under `src` cut at `depth` has one.
pub fn assert_acyclic(src: &Path, depth: usize) {
    let graph = import_graph(src, depth, Code::Built);
    if let Some(cycle) = find_cycle(&graph) {
        let steps: Vec<String> = cycle
            .windows(2)
            .map(|w| {
                let (file, line) = &graph[&w[0]][&w[1]];
                let (from, to) = (name(&w[0]), name(&w[1]));
                format!("  {from} -> {to} ({}:{line})", file.display())
            })
            .collect();
        panic!(
            "import cycle between the modules of {}:\n{}",
            src.display(),
            steps.join("\n")
        );
    }
}

/// The core's source tree.
fn core_src() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/src"))
}

#[test]
fn core_top_level_modules_have_no_import_cycle() {
    assert_acyclic(core_src(), 1);
}

/// The C API's modules (allocator, errors, calls, scene, renderer, host
/// callbacks) depend one way too: the workspace keeps the two crates side
/// by side, so the core's suite reads the C API's tree beside its own.
#[test]
fn c_api_modules_have_no_import_cycle() {
    let capi = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../capi/src"));
    assert!(capi.join("lib.rs").is_file(), "{}", capi.display());
    assert_acyclic(capi, 1);
}

/// The BSDF models know nothing of materials, as pbrt-v4's BxDFs: `scene` builds
/// `Bsdf`s, `bsdf` names nothing of `scene`, not even in its tests.
#[test]
fn bsdf_does_not_use_scene() {
    let graph = import_graph(core_src(), 1, Code::WithTests);
    let bsdf = graph.get(&m("bsdf")).expect("bsdf uses other modules");
    assert!(
        !bsdf.contains_key(&m("scene")),
        "bsdf uses scene at {:?}",
        bsdf[&m("scene")]
    );
    assert!(graph[&m("scene")].contains_key(&m("bsdf")));
}

/// A throw-away source tree under the system's temporary directory.
struct TempTree(PathBuf);

impl TempTree {
    fn new(name: &str, files: &[(&str, &str)]) -> Self {
        let root =
            std::env::temp_dir().join(format!("cmlt-architecture-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&root);
        for (path, text) in files {
            let path = root.join(path);
            fs::create_dir_all(path.parent().unwrap()).unwrap();
            fs::write(path, text).unwrap();
        }
        TempTree(root)
    }
}

impl Drop for TempTree {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.0);
    }
}

/// `"a::b"` as a module path (`""`: the root).
fn m(path: &str) -> ModPath {
    path.split("::")
        .filter(|s| !s.is_empty())
        .map(String::from)
        .collect()
}

/// The modules `from` has an edge to.
fn edges(graph: &Graph, from: &str) -> Vec<String> {
    graph
        .get(&m(from))
        .map(|e| e.keys().map(name).collect())
        .unwrap_or_default()
}

/// The checker itself: each way of naming a module makes an edge, the
/// ways of not naming one do not, test code counts only when asked for,
/// and a cycle is found and reported.
#[test]
fn import_cycles_are_found() {
    let tree = TempTree::new(
        "acyclic",
        &[
            ("lib.rs", "pub mod a;\npub mod b;\npub mod c;\npub mod d;\n"),
            // A `use` group, an inline path, a child module and the root.
            (
                "a/mod.rs",
                "mod inner;\nuse crate::{b::{B, self}, c};\n\
                 pub fn f() { crate::c::g(); crate::Root; }\npub use inner::I;\n",
            ),
            ("a/inner.rs", "pub struct I;\n"),
            // `super` from a module inside a file climbs from the file's
            // module; that module is test code, and so is the file of a
            // test module.
            (
                "b.rs",
                "pub struct B;\n#[cfg(test)]\nmod tests {\n    use super::super::d::D;\n}\n\
                 #[cfg(all(test, feature = \"x\"))]\nmod more;\n\
                 #[cfg(any(test, feature = \"x\"))]\nuse crate::c::C;\n",
            ),
            ("b/more.rs", "use crate::d;\n"),
            // Comments, literals and lifetimes name nothing.
            (
                "c.rs",
                "pub struct C;\npub fn g() {}\n// crate::a::f\n/* crate::a /* nested */ */\n\
                 /// [`crate::a`]\nconst S: &str = \"crate::a::f\";\n\
                 const R: &str = r#\"crate::a \" \"#;\nconst Q: char = '\"';\n\
                 fn h<'a>(x: &'a str) -> &'a str { x }\n",
            ),
            ("d.rs", "pub struct D;\n"),
        ],
    );
    let graph = import_graph(&tree.0, 1, Code::Built);
    assert_eq!(edges(&graph, "a"), ["crate", "b", "c"]);
    assert_eq!(edges(&graph, "b"), ["c"]);
    assert_eq!(edges(&graph, "c"), [""; 0]);
    let with_tests = import_graph(&tree.0, 1, Code::WithTests);
    assert_eq!(edges(&with_tests, "b"), ["c", "d"]);
    assert_eq!(find_cycle(&with_tests), None);
    assert_acyclic(&tree.0, 1);
    // At depth 2 the child module is a node of its own.
    assert!(edges(&import_graph(&tree.0, 2, Code::Built), "a").contains(&"a::inner".into()));

    let tree = TempTree::new(
        "cycle",
        &[
            ("lib.rs", "pub mod a;\npub mod b;\npub mod c;\n"),
            ("a.rs", "use crate::b::B;\n"),
            ("b.rs", "pub struct B;\npub fn f() { crate::c::g(); }\n"),
            (
                "c.rs",
                "pub fn g() {}\n#[cfg(test)]\nmod tests {}\nfn h() {\n    super::a::f();\n}\n",
            ),
        ],
    );
    let graph = import_graph(&tree.0, 1, Code::Built);
    assert_eq!(
        find_cycle(&graph),
        Some(vec![m("a"), m("b"), m("c"), m("a")])
    );
    let message = std::panic::catch_unwind(|| assert_acyclic(&tree.0, 1))
        .expect_err("the cycle must fail the check");
    let message = message.downcast_ref::<String>().unwrap();
    assert!(
        message.contains("a -> b (") && message.contains("c.rs:5)"),
        "{message}"
    );
}
