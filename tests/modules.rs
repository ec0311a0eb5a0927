//! The library's modules import each other without a cycle (issue 40): a module lower in
//! the data flow never reaches back into one that uses it. Read from the source, not the
//! compiler: every `mod` declaration from src/lib.rs down, and every path that names a
//! module of the crate (`use crate::a::b`, `use super::x`, `crate::a::f()`, `child::f()`),
//! outside `#[cfg(test)]` items (tests may reach anywhere). Each scope in [`SCOPES`] is
//! checked on its own: the direct submodules of that module are the graph's nodes, a
//! path into a submodule's descendants counts for the submodule, and a path to an item
//! of the scope module itself (its mod.rs) counts for that file as a node of its own.

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// Modules whose direct submodules must import each other without a cycle: "" is the
/// crate (its top-level modules, src/X.rs or src/X/). One line adds a scope.
const SCOPES: &[&str] = &["", "pipeline", "fem", "detect", "video", "fit", "study"];

/// A token of Rust source, comments and literals left out.
#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Ident(String),
    /// `::`
    Sep,
    Punct(char),
    /// A string literal's text (attributes name paths in strings: `serde(with = "...")`).
    Str(String),
}

/// Tokens of `src` with their 1-based line numbers.
fn lex(src: &str) -> Vec<(Tok, usize)> {
    let c: Vec<char> = src.chars().collect();
    let (mut i, mut line, mut out) = (0, 1, Vec::new());
    let ident_char = |ch: char| ch.is_alphanumeric() || ch == '_';
    while i < c.len() {
        let ch = c[i];
        let next = c.get(i + 1).copied().unwrap_or('\0');
        if ch == '\n' {
            line += 1;
            i += 1;
        } else if ch.is_whitespace() {
            i += 1;
        } else if ch == '/' && next == '/' {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if ch == '/' && next == '*' {
            let mut depth = 0;
            while i < c.len() {
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
                    line += usize::from(c[i] == '\n');
                    i += 1;
                }
            }
        } else if ch == '"' || ((ch == 'r' || ch == 'b') && raw_or_byte_string(&c, i)) {
            // Skip the prefix, count the hashes of a raw string, then find its end.
            let mut raw = false;
            while c[i] != '"' && c[i] != '#' {
                raw |= c[i] == 'r';
                i += 1;
            }
            let mut hashes = 0;
            while c[i] == '#' {
                hashes += 1;
                i += 1;
            }
            raw |= hashes > 0;
            i += 1;
            let start = i;
            while i < c.len() {
                if !raw && c[i] == '\\' {
                    line += usize::from(c.get(i + 1) == Some(&'\n'));
                    i += 2;
                    continue;
                }
                if c[i] == '"' && (0..hashes).all(|k| c.get(i + 1 + k) == Some(&'#')) {
                    out.push((Tok::Str(c[start..i].iter().collect()), line));
                    i += 1 + hashes;
                    break;
                }
                line += usize::from(c[i] == '\n');
                i += 1;
            }
        } else if ch == '\'' {
            // A char literal ('x', '\n', '\u{..}') or a lifetime ('a).
            if next == '\\' {
                i += 2;
                while i < c.len() && c[i] != '\'' {
                    i += 1;
                }
                i += 1;
            } else if c.get(i + 2) == Some(&'\'') {
                i += 3;
            } else {
                i += 1;
                while i < c.len() && ident_char(c[i]) {
                    i += 1;
                }
            }
        } else if ident_char(ch) {
            let start = i;
            while i < c.len() && ident_char(c[i]) {
                i += 1;
            }
            out.push((Tok::Ident(c[start..i].iter().collect()), line));
        } else if ch == ':' && next == ':' {
            out.push((Tok::Sep, line));
            i += 2;
        } else {
            out.push((Tok::Punct(ch), line));
            i += 1;
        }
    }
    out
}

/// True where `c[i..]` starts a string literal with a prefix: `r"`, `r#"`, `b"`, `br"`,
/// `br#"` (and not an identifier that merely starts with r or b).
fn raw_or_byte_string(c: &[char], i: usize) -> bool {
    if i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_') {
        return false;
    }
    let mut j = i;
    if c.get(j) == Some(&'b') {
        j += 1;
    }
    if c.get(j) == Some(&'r') {
        j += 1;
        while c.get(j) == Some(&'#') {
            j += 1;
        }
        return c.get(j) == Some(&'"');
    }
    j > i && c.get(j) == Some(&'"')
}

/// Whether a path was read from a `use` item or from code.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    Use,
    Code,
}

/// A path as written, where it was written.
#[derive(Debug, Clone)]
struct PathRef {
    /// The module it is written in.
    module: Vec<String>,
    segments: Vec<String>,
    kind: Kind,
    /// The name a `use` binds (to follow a module re-exported under another path).
    bound: Option<String>,
    /// `file:line`, for the message.
    site: String,
}

/// The crate as read: its modules and the paths written in them.
#[derive(Debug, Default)]
struct Crate {
    modules: BTreeSet<Vec<String>>,
    paths: Vec<PathRef>,
    /// (module, name a `use` binds there) -> indices in `paths`.
    bindings: HashMap<(Vec<String>, String), Vec<usize>>,
}

impl Crate {
    /// Reads the crate whose root file is `lib` through `read` (file -> text), following
    /// `mod NAME;` declarations to NAME.rs or NAME/mod.rs.
    fn read(lib: &Path, read: &dyn Fn(&Path) -> Option<String>) -> Crate {
        let mut krate = Crate::default();
        krate.modules.insert(vec![]);
        // (file, its module, the folder its child files live in)
        let dir = lib.parent().unwrap_or(Path::new("")).to_path_buf();
        // Files are named from the folder above the source folder (`src/x.rs`).
        let root = dir.parent().unwrap_or(Path::new("")).to_path_buf();
        let mut queue = vec![(lib.to_path_buf(), vec![], dir)];
        while let Some((file, module, dir)) = queue.pop() {
            let text = read(&file).unwrap_or_else(|| panic!("{} cannot be read", file.display()));
            let name = file
                .strip_prefix(&root)
                .unwrap_or(&file)
                .display()
                .to_string();
            for (child, child_dir) in krate.parse(&lex(&text), &module, &dir, &name) {
                let stem = child.last().cloned().unwrap_or_default();
                let flat = child_dir.join(format!("{stem}.rs"));
                let (path, sub) = if read(&flat).is_some() {
                    (flat, child_dir.join(&stem))
                } else {
                    (child_dir.join(&stem).join("mod.rs"), child_dir.join(&stem))
                };
                queue.push((path, child, sub));
            }
        }
        for (k, p) in krate.paths.iter().enumerate() {
            if let Some(name) = &p.bound {
                krate
                    .bindings
                    .entry((p.module.clone(), name.clone()))
                    .or_default()
                    .push(k);
            }
        }
        krate
    }

    /// Reads the tokens of one file of module `module` (child files in `dir`): records
    /// inline modules and paths, returns the declared file modules with their folder.
    fn parse(
        &mut self,
        toks: &[(Tok, usize)],
        module: &[String],
        dir: &Path,
        file: &str,
    ) -> Vec<(Vec<String>, PathBuf)> {
        let mut files = Vec::new();
        // Inline modules open: (module, brace depth inside it, its child folder).
        let mut stack: Vec<(Vec<String>, usize, PathBuf)> =
            vec![(module.to_vec(), 0, dir.to_path_buf())];
        let mut depth = 0;
        let mut i = 0;
        let ident = |k: usize| match toks.get(k) {
            Some((Tok::Ident(s), _)) => Some(s.as_str()),
            _ => None,
        };
        let punct = |k: usize, p: char| matches!(toks.get(k), Some((Tok::Punct(q), _)) if *q == p);
        while i < toks.len() {
            let (current, _, current_dir) = stack.last().cloned().unwrap_or_default();
            let line = toks[i].1;
            if punct(i, '#') && punct(i + 1, '[') {
                let end = matching(toks, i + 1, '[', ']');
                let attr: Vec<&str> = (i + 2..end).filter_map(ident).collect();
                for (t, l) in &toks[i + 2..end] {
                    let Tok::Str(text) = t else { continue };
                    let segments: Vec<String> = text.split("::").map(str::to_string).collect();
                    let is_path = segments.len() > 1
                        && segments.iter().all(|s| {
                            !s.is_empty() && s.chars().all(|c| c.is_alphanumeric() || c == '_')
                        });
                    if is_path {
                        self.paths.push(PathRef {
                            module: current.clone(),
                            segments,
                            kind: Kind::Code,
                            bound: None,
                            site: format!("{file}:{l}"),
                        });
                    }
                }
                i = end + 1;
                if attr.first() == Some(&"cfg") && attr.contains(&"test") && !attr.contains(&"not")
                {
                    // Further attributes, then the item itself.
                    while punct(i, '#') && punct(i + 1, '[') {
                        i = matching(toks, i + 1, '[', ']') + 1;
                    }
                    while i < toks.len() && !punct(i, ';') && !punct(i, '{') {
                        i += 1;
                    }
                    if punct(i, '{') {
                        i = matching(toks, i, '{', '}');
                    }
                    i += 1;
                }
                continue;
            }
            match &toks[i].0 {
                Tok::Punct('{') => depth += 1,
                Tok::Punct('}') => {
                    depth -= 1;
                    if stack.len() > 1 && stack.last().map(|s| s.1) == Some(depth + 1) {
                        stack.pop();
                    }
                }
                Tok::Ident(w) if w == "mod" => {
                    if let Some(name) = ident(i + 1) {
                        let mut child = current.clone();
                        child.push(name.to_string());
                        self.modules.insert(child.clone());
                        if punct(i + 2, ';') {
                            files.push((child, current_dir.clone()));
                        } else if punct(i + 2, '{') {
                            depth += 1;
                            stack.push((child, depth, current_dir.join(name)));
                            i += 3;
                            continue;
                        }
                    }
                }
                Tok::Ident(w) if w == "use" => {
                    let end = (i..toks.len())
                        .find(|&k| punct(k, ';'))
                        .unwrap_or(toks.len());
                    for (segments, bound) in use_tree(&toks[i + 1..end]) {
                        self.paths.push(PathRef {
                            module: current.clone(),
                            segments,
                            kind: Kind::Use,
                            bound,
                            site: format!("{file}:{line}"),
                        });
                    }
                    i = end + 1;
                    continue;
                }
                Tok::Ident(w)
                    if matches!(toks.get(i + 1), Some((Tok::Sep, _)))
                        && !matches!(toks.get(i.wrapping_sub(1)), Some((Tok::Sep, _)))
                        && ident(i.wrapping_sub(1)) != Some("in") =>
                {
                    let mut segments = vec![w.clone()];
                    let mut k = i + 1;
                    while matches!(toks.get(k), Some((Tok::Sep, _))) {
                        match ident(k + 1) {
                            Some(s) => segments.push(s.to_string()),
                            None => break,
                        }
                        k += 2;
                    }
                    self.paths.push(PathRef {
                        module: current.clone(),
                        segments,
                        kind: Kind::Code,
                        bound: None,
                        site: format!("{file}:{line}"),
                    });
                    i = k;
                    continue;
                }
                _ => {}
            }
            i += 1;
        }
        files
    }

    /// The module a path leads to (the longest prefix that is a module of the crate,
    /// through modules re-exported by `use`), or None for a path outside the crate (std,
    /// other crates, local types and variants).
    fn target(&self, p: &PathRef) -> Option<Vec<String>> {
        self.resolve(&p.module, &p.segments, 0).map(|(m, _)| m)
    }

    /// The module `segments` (written in `module`) lead to, and whether every segment
    /// named a module.
    fn resolve(
        &self,
        module: &[String],
        segments: &[String],
        depth: usize,
    ) -> Option<(Vec<String>, bool)> {
        let first = segments.first()?;
        if depth > 8 {
            return None;
        }
        let (mut base, rest): (Vec<String>, &[String]) = match first.as_str() {
            "crate" => (vec![], &segments[1..]),
            "self" => (module.to_vec(), &segments[1..]),
            "super" => {
                let ups = segments.iter().take_while(|s| *s == "super").count();
                let keep = module.len().checked_sub(ups)?;
                (module[..keep].to_vec(), &segments[ups..])
            }
            _ => {
                let mut child = module.to_vec();
                child.push(first.clone());
                if self.modules.contains(&child) {
                    (module.to_vec(), segments)
                } else {
                    (self.alias(module, first, depth)?, &segments[1..])
                }
            }
        };
        for s in rest {
            let mut next = base.clone();
            next.push(s.clone());
            if self.modules.contains(&next) {
                base = next;
            } else if let Some(m) = self.alias(&base, s, depth) {
                base = m;
            } else {
                return Some((base, false));
            }
        }
        Some((base, true))
    }

    /// The module `name` stands for in `module` through a `use` there, if it is one.
    fn alias(&self, module: &[String], name: &str, depth: usize) -> Option<Vec<String>> {
        self.bindings
            .get(&(module.to_vec(), name.to_string()))?
            .iter()
            .find_map(
                |&k| match self.resolve(module, &self.paths[k].segments, depth + 1) {
                    Some((m, true)) => Some(m),
                    _ => None,
                },
            )
    }

    /// Edges between the direct submodules of `scope` (and the scope's own file, named
    /// `scope (its own file)`), each with the sites that make it.
    fn edges(&self, scope: &[String]) -> BTreeMap<(String, String), Vec<String>> {
        let node = |m: &[String]| -> Option<String> {
            if !m.starts_with(scope) {
                None
            } else if m.len() == scope.len() {
                Some(format!("{} (its own file)", label(scope)))
            } else {
                Some(m[scope.len()].clone())
            }
        };
        let mut edges: BTreeMap<(String, String), Vec<String>> = BTreeMap::new();
        for p in &self.paths {
            let Some(to) = self.target(p) else { continue };
            if let (Some(a), Some(b)) = (node(&p.module), node(&to)) {
                if a != b {
                    let how = match p.kind {
                        Kind::Use => "use",
                        Kind::Code => "path",
                    };
                    edges.entry((a, b)).or_default().push(format!(
                        "{} ({how} {})",
                        p.site,
                        p.segments.join("::")
                    ));
                }
            }
        }
        edges
    }
}

/// Index of the token closing the bracket opened at `open`.
fn matching(toks: &[(Tok, usize)], open: usize, o: char, c: char) -> usize {
    let mut depth = 0;
    for (k, (t, _)) in toks.iter().enumerate().skip(open) {
        if *t == Tok::Punct(o) {
            depth += 1;
        } else if *t == Tok::Punct(c) {
            depth -= 1;
            if depth == 0 {
                return k;
            }
        }
    }
    toks.len()
}

/// The paths of a use tree (`a::b::{c, d::{self, e as f}, *}`), each with the name it
/// binds (`c`, `d`, `f`; none for a glob or `_`); `self` stands for its group's prefix.
fn use_tree(toks: &[(Tok, usize)]) -> Vec<(Vec<String>, Option<String>)> {
    fn walk(
        toks: &[(Tok, usize)],
        mut k: usize,
        prefix: &[String],
        out: &mut Vec<(Vec<String>, Option<String>)>,
    ) -> usize {
        let mut path = prefix.to_vec();
        let mut bound = None;
        while k < toks.len() {
            match &toks[k].0 {
                Tok::Ident(s) if s == "as" => {
                    k += 1;
                    bound = match toks.get(k).map(|t| &t.0) {
                        Some(Tok::Ident(a)) if a != "_" => Some(a.clone()),
                        _ => None,
                    };
                }
                Tok::Ident(s) if s == "self" => bound = path.last().cloned(),
                Tok::Ident(s) => {
                    path.push(s.clone());
                    bound = Some(s.clone());
                }
                Tok::Sep | Tok::Str(_) => {}
                Tok::Punct('*') => bound = None,
                Tok::Punct('{') => {
                    k += 1;
                    loop {
                        k = walk(toks, k, &path, out);
                        match toks.get(k).map(|t| &t.0) {
                            Some(Tok::Punct(',')) => k += 1,
                            _ => break,
                        }
                        if matches!(toks.get(k).map(|t| &t.0), Some(Tok::Punct('}'))) {
                            break;
                        }
                    }
                    // The closing brace of the group: this branch has no leaf of its own.
                    return k + 1;
                }
                Tok::Punct(',') | Tok::Punct('}') => break,
                Tok::Punct(_) => {}
            }
            k += 1;
        }
        // A leaf; `self` or a glob in a group is the group's prefix itself.
        out.push((path, bound));
        k
    }
    let mut out = Vec::new();
    walk(toks, 0, &[], &mut out);
    out.retain(|p| !p.0.is_empty());
    out
}

fn label(scope: &[String]) -> String {
    if scope.is_empty() {
        "crate".into()
    } else {
        scope.join("::")
    }
}

/// The nodes of every cycle of `edges` (strongly connected components of more than one
/// node), each as one cycle `a -> b -> ... -> a` with the sites of its edges.
fn cycles(edges: &BTreeMap<(String, String), Vec<String>>) -> Vec<String> {
    let mut next: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for (a, b) in edges.keys() {
        next.entry(a).or_default().push(b);
        next.entry(b).or_default();
    }
    // Tarjan's strongly connected components.
    struct State<'a> {
        index: HashMap<&'a str, usize>,
        low: HashMap<&'a str, usize>,
        stack: Vec<&'a str>,
        on: BTreeSet<&'a str>,
        comps: Vec<Vec<&'a str>>,
    }
    fn visit<'a>(v: &'a str, next: &BTreeMap<&'a str, Vec<&'a str>>, s: &mut State<'a>) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on.insert(v);
        for &w in &next[v] {
            if !s.index.contains_key(w) {
                visit(w, next, s);
                let l = s.low[w].min(s.low[v]);
                s.low.insert(v, l);
            } else if s.on.contains(w) {
                let l = s.index[w].min(s.low[v]);
                s.low.insert(v, l);
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                comp.push(w);
                if w == v {
                    break;
                }
            }
            s.comps.push(comp);
        }
    }
    let mut s = State {
        index: HashMap::new(),
        low: HashMap::new(),
        stack: vec![],
        on: BTreeSet::new(),
        comps: vec![],
    };
    for &v in next.keys() {
        if !s.index.contains_key(v) {
            visit(v, &next, &mut s);
        }
    }
    let mut found = Vec::new();
    for comp in s.comps.iter().filter(|c| c.len() > 1) {
        let inside: BTreeSet<&str> = comp.iter().copied().collect();
        // A shortest way back from the component's first node to itself, inside it.
        let start = *inside.iter().next().unwrap_or(&"");
        let mut prev: BTreeMap<&str, &str> = BTreeMap::new();
        let mut queue = std::collections::VecDeque::from([start]);
        'search: while let Some(v) = queue.pop_front() {
            for &w in &next[v] {
                if !inside.contains(w) {
                    continue;
                }
                if w == start {
                    prev.insert(start, v);
                    break 'search;
                }
                if !prev.contains_key(w) {
                    prev.insert(w, v);
                    queue.push_back(w);
                }
            }
        }
        let mut cycle = vec![start];
        let mut v = prev[start];
        while v != start {
            cycle.push(v);
            v = prev[v];
        }
        cycle.push(start);
        cycle.reverse();
        let mut text = format!(
            "{} (modules in the cycle: {})",
            cycle.join(" -> "),
            inside.iter().copied().collect::<Vec<_>>().join(", ")
        );
        for w in cycle.windows(2) {
            let sites = &edges[&(w[0].to_string(), w[1].to_string())];
            text.push_str(&format!(
                "\n    {} -> {}: {}{}",
                w[0],
                w[1],
                sites[..sites.len().min(3)].join(", "),
                if sites.len() > 3 {
                    format!(" and {} more", sites.len() - 3)
                } else {
                    String::new()
                }
            ));
        }
        found.push(text);
    }
    found
}

fn src() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src")
}

fn the_crate() -> Crate {
    Crate::read(&src().join("lib.rs"), &|p| std::fs::read_to_string(p).ok())
}

fn scope(s: &str) -> Vec<String> {
    s.split("::")
        .filter(|p| !p.is_empty())
        .map(str::to_string)
        .collect()
}

#[test]
fn no_module_imports_one_that_imports_it_back() {
    let krate = the_crate();
    let mut failures = Vec::new();
    for s in SCOPES {
        let scope = scope(s);
        assert!(
            krate.modules.contains(&scope),
            "scope `{s}` is not a module of the crate"
        );
        for c in cycles(&krate.edges(&scope)) {
            failures.push(format!("in {}: {c}", label(&scope)));
        }
    }
    assert!(
        failures.is_empty(),
        "module import cycles:\n{}",
        failures.join("\n")
    );
}

/// The reader sees the crate as it is: its modules and some edges every version of the
/// crate has (so the cycle test cannot pass by reading nothing).
#[test]
fn the_reader_finds_the_crates_modules_and_known_edges() {
    let krate = the_crate();
    for m in [
        "pipeline",
        "pipeline::video_run",
        "measure::records",
        "calib",
        "report",
    ] {
        assert!(krate.modules.contains(&scope(m)), "module {m} not found");
    }
    assert!(
        !krate.modules.contains(&scope("cli")),
        "cli belongs to the binary"
    );
    let top = krate.edges(&[]);
    for (a, b) in [
        ("pipeline", "calib"),
        ("pipeline", "session"),
        ("scale", "calib"),
    ] {
        assert!(
            top.contains_key(&(a.into(), b.into())),
            "edge {a} -> {b} not found"
        );
    }
    let pipeline = krate.edges(&scope("pipeline"));
    assert!(
        pipeline.contains_key(&("output".into(), "markers".into())),
        "edge pipeline::output -> pipeline::markers not found"
    );
}

/// Every form of path on a tiny crate: `crate::`, `super::`, `self::`, use groups with
/// `self` and aliases, child paths in code, inline modules; nothing from comments,
/// strings, std or `#[cfg(test)]` items.
#[test]
fn the_reader_finds_edges_of_every_form_and_no_others() {
    let files: HashMap<PathBuf, &str> = HashMap::from([
        (
            PathBuf::from("s/lib.rs"),
            "pub mod a; pub mod b; pub mod c; pub mod d; mod e; pub mod f; mod g; mod h; mod i;",
        ),
        (PathBuf::from("s/a.rs"), "use crate::b::{self, Thing as T};\nuse std::path::Path;"),
        (PathBuf::from("s/b/mod.rs"), "pub mod inner;\npub(crate) use inner::X;"),
        (PathBuf::from("s/b/inner.rs"), "fn f() { let _ = super::super::c::g(); }"),
        (
            PathBuf::from("s/c.rs"),
            "// crate::e::x\nconst S: &str = \"crate::e::y\"; const R: &str = r#\"crate::e\"#;\n\
             fn g<'a>(c: &'a char) { let _ = '\"'; crate::d::h(); }",
        ),
        (
            PathBuf::from("s/d.rs"),
            "mod nested { pub fn h() { self::more::k() } mod more { pub fn k() { crate::f::z() } } }\n\
             #[cfg(test)]\nmod tests { use crate::a; }",
        ),
        (PathBuf::from("s/e.rs"), "#[cfg(test)]\nfn only() { crate::a::x(); }"),
        (
            PathBuf::from("s/f.rs"),
            "pub fn z() { Vec::<u8>::new(); }\n#[serde(with = \"crate::h::inner\")]\nstruct W;",
        ),
        (PathBuf::from("s/h.rs"), "pub mod inner;"),
        (PathBuf::from("s/h/inner.rs"), "pub use crate::i::deep;"),
        (PathBuf::from("s/i.rs"), "pub mod deep;"),
        (PathBuf::from("s/i/deep.rs"), "fn x() { crate::h::inner::deep::y(); }"),
        (PathBuf::from("s/g.rs"), "#[cfg(test)] mod hidden;"),
    ]);
    let krate = Crate::read(Path::new("s/lib.rs"), &|p| {
        files.get(p).map(|s| s.to_string())
    });
    assert!(krate.modules.contains(&scope("d::nested::more")));
    assert!(krate.modules.contains(&scope("b::inner")));
    assert!(!krate.modules.contains(&scope("g::hidden")));
    let top: Vec<(String, String)> = krate.edges(&[]).into_keys().collect();
    // i::deep reaches itself through h's re-export: no edge i -> h.
    let want: Vec<(String, String)> = [
        ("a", "b"),
        ("b", "c"),
        ("c", "d"),
        ("d", "f"),
        ("f", "h"),
        ("h", "i"),
    ]
    .map(|(a, b)| (a.to_string(), b.to_string()))
    .to_vec();
    assert_eq!(top, want);
    let b: Vec<(String, String)> = krate.edges(&scope("b")).into_keys().collect();
    assert_eq!(
        b,
        vec![("b (its own file)".to_string(), "inner".to_string())]
    );
}

/// A cycle is found and named with the sites of its edges.
#[test]
fn a_cycle_is_reported_with_its_sites() {
    let files: HashMap<PathBuf, &str> = HashMap::from([
        (
            PathBuf::from("s/lib.rs"),
            "pub mod a; pub mod b; pub mod c;",
        ),
        (PathBuf::from("s/a.rs"), "use crate::b::X;"),
        (PathBuf::from("s/b.rs"), "fn f() {\n crate::c::g() }"),
        (PathBuf::from("s/c.rs"), "use super::a;"),
    ]);
    let krate = Crate::read(Path::new("s/lib.rs"), &|p| {
        files.get(p).map(|s| s.to_string())
    });
    let found = cycles(&krate.edges(&[]));
    assert_eq!(found.len(), 1, "{found:#?}");
    assert!(found[0].starts_with("a -> b -> c -> a"), "{}", found[0]);
    assert!(
        found[0].contains("b -> c: s/b.rs:2 (path crate::c::g)"),
        "{}",
        found[0]
    );
    assert!(
        found[0].contains("c -> a: s/c.rs:1 (use super::a)"),
        "{}",
        found[0]
    );
}
