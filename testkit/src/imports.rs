//! Import circles between the files of a crate, read from its source: every `use` path and
//! every `crate::…`/`super::…` path written in the code, resolved to the file that holds the
//! module it names (a path `a::b::Item` goes to `a/b.rs` or `a/b/mod.rs`, the longest prefix
//! that is a file). A file that reaches itself again along such edges is in a circle. An
//! inline module (`mod tests { use super::*; }`) is part of its file: its `super` is the
//! file's own module.
//!
//! Comments, string and character literals are blanked first, so a path in a doc comment or a
//! message is not an edge, and braces in them do not confuse the module nesting.
//!
//! Also here, from the same reading: functions longer than a limit ([`long_functions`]).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// A module path inside the crate (`[]` is the crate root).
type ModPath = Vec<String>;

/// The circles among the files of the crate whose `src` folder is `src`: each the sorted
/// list of its files (relative to `src`), the circles sorted; empty when there is none.
pub fn import_circles(src: &Path) -> Vec<Vec<String>> {
    let files = module_files(src);
    let mut edges: BTreeMap<ModPath, BTreeSet<ModPath>> = BTreeMap::new();
    for (m, path) in &files {
        let text = std::fs::read_to_string(path).unwrap_or_default();
        let entry = edges.entry(m.clone()).or_default();
        for target in references(&blank(&text), m, &files) {
            if &target != m {
                entry.insert(target);
            }
        }
    }
    let mut circles: Vec<Vec<String>> = strongly_connected(&edges)
        .into_iter()
        .filter(|c| c.len() > 1)
        .map(|c| {
            let mut names: Vec<String> = c.iter().map(|m| rel_name(&files[m], src)).collect();
            names.sort();
            names
        })
        .collect();
    circles.sort();
    circles
}

/// Panic naming every circle among the files of the crate at `manifest_dir` (its `src`).
pub fn assert_no_import_circles(manifest_dir: &str) {
    let src = Path::new(manifest_dir).join("src");
    let circles = import_circles(&src);
    assert!(
        circles.is_empty(),
        "import circles between the files of {}: {}. Move what both sides need into a file \
         of its own that imports neither.",
        src.display(),
        circles
            .iter()
            .map(|c| format!("[{}]", c.join(" ↔ ")))
            .collect::<Vec<_>>()
            .join(", ")
    );
}

/// The functions of the crate whose `src` folder is `src` that are longer than `max_lines`
/// lines (from the line of `fn` to the closing brace): file (relative to `src`), name and
/// length, longest first.
pub fn long_functions(src: &Path, max_lines: usize) -> Vec<(String, String, usize)> {
    let mut out = Vec::new();
    for path in module_files(src).values() {
        let text = blank(&std::fs::read_to_string(path).unwrap_or_default());
        let b = text.as_bytes();
        let mut i = 0;
        while let Some(k) = text[i..].find("fn ") {
            let at = i + k;
            i = at + 3;
            if at > 0 && (b[at - 1].is_ascii_alphanumeric() || b[at - 1] == b'_') {
                continue;
            }
            let (name, after) = ident(b, skip_ws(b, at + 3));
            if name.is_empty() {
                continue;
            }
            // The body: the first `{` before any `;` (a declaration without body has none).
            let Some(open) = text[after..].find(['{', ';']).map(|o| after + o) else {
                continue;
            };
            if b[open] == b';' {
                continue;
            }
            let mut depth = 0usize;
            let mut close = open;
            for (j, c) in b.iter().enumerate().skip(open) {
                match c {
                    b'{' => depth += 1,
                    b'}' => {
                        depth -= 1;
                        if depth == 0 {
                            close = j;
                            break;
                        }
                    }
                    _ => {}
                }
            }
            let lines = text[at..=close].matches('\n').count() + 1;
            if lines > max_lines {
                out.push((rel_name(path, src), name, lines));
            }
        }
    }
    out.sort_by(|a, b| b.2.cmp(&a.2).then(a.0.cmp(&b.0)));
    out
}

/// Panic naming every function of the crate at `manifest_dir` longer than `max_lines` lines.
pub fn assert_no_long_functions(manifest_dir: &str, max_lines: usize) {
    let src = Path::new(manifest_dir).join("src");
    let long = long_functions(&src, max_lines);
    assert!(
        long.is_empty(),
        "functions over {max_lines} lines in {}: {}. Split each into steps that do one thing.",
        src.display(),
        long.iter()
            .map(|(f, n, l)| format!("{f}: {n} ({l} lines)"))
            .collect::<Vec<_>>()
            .join(", ")
    );
}

fn rel_name(path: &Path, src: &Path) -> String {
    path.strip_prefix(src)
        .unwrap_or(path)
        .to_string_lossy()
        .replace('\\', "/")
}

/// Every `.rs` file under `src` by the module path it holds.
fn module_files(src: &Path) -> BTreeMap<ModPath, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let Ok(rd) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(src).unwrap_or(&p).with_extension("");
                let mut m: ModPath = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if matches!(m.last().map(String::as_str), Some("mod" | "lib" | "main")) {
                    m.pop();
                }
                out.insert(m, p);
            }
        }
    }
    out
}

/// `text` with comments, string literals and brace/quote character literals replaced by
/// blanks (line breaks kept).
fn blank(text: &str) -> String {
    let b = text.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    let keep = |c: u8| if c == b'\n' { b'\n' } else { b' ' };
    while i < b.len() {
        match b[i] {
            b'/' if b.get(i + 1) == Some(&b'/') => {
                while i < b.len() && b[i] != b'\n' {
                    out.push(b' ');
                    i += 1;
                }
            }
            b'/' if b.get(i + 1) == Some(&b'*') => {
                let mut depth = 0;
                while i < b.len() {
                    if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                        depth += 1;
                        out.extend([b' ', b' ']);
                        i += 2;
                    } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                        depth -= 1;
                        out.extend([b' ', b' ']);
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else {
                        out.push(keep(b[i]));
                        i += 1;
                    }
                }
            }
            b'r' if raw_string_start(b, i).is_some() => {
                let (hashes, body) = raw_string_start(b, i).unwrap_or_default();
                out.extend(std::iter::repeat_n(b' ', body - i));
                i = body;
                let close: Vec<u8> = std::iter::once(b'"')
                    .chain(std::iter::repeat_n(b'#', hashes))
                    .collect();
                while i < b.len() && !b[i..].starts_with(&close) {
                    out.push(keep(b[i]));
                    i += 1;
                }
                out.extend(std::iter::repeat_n(b' ', close.len().min(b.len() - i)));
                i += close.len();
            }
            b'"' => {
                out.push(b' ');
                i += 1;
                while i < b.len() && b[i] != b'"' {
                    if b[i] == b'\\' && i + 1 < b.len() {
                        out.push(b' ');
                        i += 1;
                    }
                    out.push(keep(b[i]));
                    i += 1;
                }
                out.push(b' ');
                i += 1;
            }
            b'\''
                if matches!(
                    b.get(i + 1..i + 3),
                    Some(b"{'") | Some(b"}'") | Some(b"\"'")
                ) =>
            {
                out.extend([b' ', b' ', b' ']);
                i += 3;
            }
            b'\''
                if b.get(i + 1..i + 4) == Some(b"\\''")
                    || b.get(i + 1..i + 4) == Some(b"\\\"'") =>
            {
                out.extend([b' ', b' ', b' ', b' ']);
                i += 4;
            }
            c => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out[..out.len().min(b.len())]).into_owned()
}

/// Whether a raw string (`r"`, `r#"`, `br"` …) starts at `i`: its number of `#` and where
/// its body starts.
fn raw_string_start(b: &[u8], i: usize) -> Option<(usize, usize)> {
    if i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_') && b[i - 1] != b'b' {
        return None;
    }
    let mut j = i + 1;
    while b.get(j) == Some(&b'#') {
        j += 1;
    }
    (b.get(j) == Some(&b'"')).then_some((j - i - 1, j + 1))
}

/// The files that the paths written in `text` (the blanked source of module `file_mod`)
/// reach.
fn references(text: &str, file_mod: &ModPath, files: &BTreeMap<ModPath, PathBuf>) -> Vec<ModPath> {
    let mut out = Vec::new();
    for (here, path) in paths(text, file_mod) {
        let full = match path.first().map(String::as_str) {
            Some("crate") => path[1..].to_vec(),
            Some("super") | Some("self") => {
                let mut base = here.clone();
                let mut rest = &path[..];
                if rest[0] == "self" {
                    rest = &rest[1..];
                }
                while rest.first().map(String::as_str) == Some("super") {
                    base.pop();
                    rest = &rest[1..];
                }
                base.extend(rest.iter().cloned());
                base
            }
            Some(first) => {
                // A child module of the file's module named without `self::`.
                let mut child = file_mod.clone();
                child.push(first.to_string());
                if here == *file_mod && files.contains_key(&child) {
                    let mut p = file_mod.clone();
                    p.extend(path.iter().cloned());
                    p
                } else {
                    continue;
                }
            }
            None => continue,
        };
        if let Some(target) = (0..=full.len())
            .rev()
            .map(|k| full[..k].to_vec())
            .find(|p| files.contains_key(p))
        {
            out.push(target);
        }
    }
    out
}

/// Every path of `use` declarations (braces expanded) and every `crate::…`/`super::…`/
/// `self::…` path elsewhere in `text`, with the module it is written in (the file's module, or
/// an inline module inside it).
fn paths(text: &str, file_mod: &ModPath) -> Vec<(ModPath, Vec<String>)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    // Inline modules: (module path, brace depth inside it).
    let mut stack: Vec<(ModPath, usize)> = vec![(file_mod.clone(), 0)];
    let mut depth = 0usize;
    let mut i = 0;
    // The module at the current position (the stack never empties: the file's own stays).
    let here = |stack: &[(ModPath, usize)]| stack[stack.len() - 1].0.clone();
    while i < b.len() {
        match b[i] {
            b'{' => {
                depth += 1;
                i += 1;
                continue;
            }
            b'}' => {
                if stack.len() > 1 && stack.last().is_some_and(|s| s.1 == depth) {
                    stack.pop();
                }
                depth = depth.saturating_sub(1);
                i += 1;
                continue;
            }
            _ => {}
        }
        // `$crate::…` in a macro is resolved where the macro is used: not an edge here.
        let word_start =
            i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b'$');
        if word_start && keyword_at(b, i, "mod") {
            let j = skip_ws(b, i + 3);
            let (name, k) = ident(b, j);
            let k = skip_ws(b, k);
            if !name.is_empty() && b.get(k) == Some(&b'{') {
                let mut m = here(&stack);
                m.push(name);
                depth += 1;
                stack.push((m, depth));
                i = k + 1;
                continue;
            }
        }
        if word_start && keyword_at(b, i, "use") {
            let end = text[i..].find(';').map_or(b.len(), |e| i + e);
            // Blanks kept single so that `x as y` stays readable.
            let decl = text[i + 3..end]
                .split_whitespace()
                .collect::<Vec<_>>()
                .join(" ");
            for p in expand(&decl) {
                out.push((here(&stack), p));
            }
            i = end + 1;
            continue;
        }
        if word_start
            && ["crate::", "super::", "self::"]
                .iter()
                .any(|k| b[i..].starts_with(k.as_bytes()))
        {
            let mut segs = Vec::new();
            let mut j = i;
            loop {
                let (id, k) = ident(b, j);
                if id.is_empty() {
                    break;
                }
                segs.push(id);
                j = k;
                if text[j..].starts_with("::") {
                    j += 2;
                } else {
                    break;
                }
            }
            out.push((here(&stack), segs));
            i = j.max(i + 1);
            continue;
        }
        i += 1;
    }
    out
}

fn keyword_at(b: &[u8], i: usize, kw: &str) -> bool {
    b[i..].starts_with(kw.as_bytes())
        && b.get(i + kw.len()).is_some_and(|c| c.is_ascii_whitespace())
}

fn skip_ws(b: &[u8], mut i: usize) -> usize {
    while b.get(i).is_some_and(|c| c.is_ascii_whitespace()) {
        i += 1;
    }
    i
}

/// The identifier starting at `i` (empty when none) and where it ends.
fn ident(b: &[u8], i: usize) -> (String, usize) {
    let mut j = i;
    while b
        .get(j)
        .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
    {
        j += 1;
    }
    (String::from_utf8_lossy(&b[i..j]).into_owned(), j)
}

/// The paths of a `use` tree (`a::{b, c::{d, e as f}}` → `a::b`, `a::c::d`, `a::c::e`).
fn expand(decl: &str) -> Vec<Vec<String>> {
    fn rec(prefix: &[String], s: &str, out: &mut Vec<Vec<String>>) {
        let mut depth = 0;
        let mut start = 0;
        let bytes = s.as_bytes();
        let mut parts = Vec::new();
        for (k, c) in bytes.iter().enumerate() {
            match c {
                b'{' => depth += 1,
                b'}' => depth -= 1,
                b',' if depth == 0 => {
                    parts.push(&s[start..k]);
                    start = k + 1;
                }
                _ => {}
            }
        }
        parts.push(&s[start..]);
        for p in parts.into_iter().filter(|p| !p.is_empty()) {
            if let Some(open) = p.find('{') {
                let mut pre = prefix.to_vec();
                pre.extend(segments(&p[..open]));
                let inner = p[open + 1..].strip_suffix('}').unwrap_or(&p[open + 1..]);
                rec(&pre, inner, out);
            } else {
                let mut full = prefix.to_vec();
                full.extend(segments(p));
                out.push(full);
            }
        }
    }
    fn segments(s: &str) -> Vec<String> {
        let s = s.split(" as ").next().unwrap_or(s);
        s.split("::")
            .map(str::trim)
            .filter(|x| !x.is_empty() && *x != "*")
            .map(str::to_string)
            .collect()
    }
    // Blanks next to the tree's punctuation carry nothing.
    let decl = decl
        .replace(" ::", "::")
        .replace(":: ", "::")
        .replace(" {", "{")
        .replace("{ ", "{")
        .replace(" }", "}")
        .replace(", ", ",")
        .replace(" ,", ",");
    let mut out = Vec::new();
    rec(&[], decl.trim().trim_start_matches("::"), &mut out);
    out
}

/// Tarjan's strongly connected components of `edges`.
fn strongly_connected(edges: &BTreeMap<ModPath, BTreeSet<ModPath>>) -> Vec<Vec<ModPath>> {
    struct T<'a> {
        edges: &'a BTreeMap<ModPath, BTreeSet<ModPath>>,
        index: BTreeMap<&'a ModPath, usize>,
        low: BTreeMap<&'a ModPath, usize>,
        stack: Vec<&'a ModPath>,
        on: BTreeSet<&'a ModPath>,
        out: Vec<Vec<ModPath>>,
    }
    fn visit<'a>(t: &mut T<'a>, v: &'a ModPath) {
        let n = t.index.len();
        t.index.insert(v, n);
        t.low.insert(v, n);
        t.stack.push(v);
        t.on.insert(v);
        let edges = t.edges;
        for w in edges.get(v).into_iter().flatten() {
            if !t.index.contains_key(w) {
                visit(t, w);
                let lw = t.low[w];
                let lv = t.low.get_mut(v).expect("visited");
                *lv = (*lv).min(lw);
            } else if t.on.contains(w) {
                let iw = t.index[w];
                let lv = t.low.get_mut(v).expect("visited");
                *lv = (*lv).min(iw);
            }
        }
        if t.low[v] == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on.remove(w);
                comp.push(w.clone());
                if w == v {
                    break;
                }
            }
            t.out.push(comp);
        }
    }
    let mut t = T {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in edges.keys() {
        if !t.index.contains_key(v) {
            visit(&mut t, v);
        }
    }
    t.out
}
