//! What `docs/guide/house.md` says of the house and the code can check: the crate graph
//! (each crate imports only the workspace crates its floor allows) and the files' sizes
//! (no source file past `MAX_LINES` lines of non-test code).

use std::path::{Path, PathBuf};

/// The workspace's crates (folder, package name) and the workspace crates each may import
/// in `[dependencies]`: the floors of `house.md`'s table.
const FLOORS: &[(&str, &[&str])] = &[
    ("manifolds", &[]),
    ("estimator-core", &["manifolds"]),
    ("adaptive", &["manifolds", "estimator-core"]),
    ("models", &["manifolds", "estimator-core"]),
    ("gnss", &["estimator-core"]),
    ("ins-gnss-core", &["manifolds", "estimator-core", "gnss"]),
    ("ins-gnss-io", &["manifolds", "gnss", "ins-gnss-core"]),
    ("ins-gnss-sim", &["manifolds", "gnss", "ins-gnss-core"]),
    (
        "ins-gnss",
        &[
            "manifolds",
            "estimator-core",
            "adaptive",
            "models",
            "gnss",
            "ins-gnss-core",
            "ins-gnss-io",
            "ins-gnss-sim",
        ],
    ),
    (
        "python",
        &[
            "manifolds",
            "estimator-core",
            "adaptive",
            "models",
            "gnss",
            "ins-gnss-core",
            "ins-gnss-io",
            "ins-gnss-sim",
            "ins-gnss",
        ],
    ),
    ("firmware", &["manifolds", "estimator-core", "models"]),
];

/// "Files stay under about 600 lines of non-test code" (`house.md`): the bound the test
/// holds them to.
const MAX_LINES: usize = 700;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The workspace crates named in a manifest's `[dependencies]` (not dev- or build-).
fn workspace_dependencies(manifest: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(manifest).unwrap();
    let names: Vec<&str> = FLOORS.iter().map(|f| f.0).collect();
    let mut inside = false;
    let mut found = Vec::new();
    for line in text.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            inside = line == "[dependencies]";
            continue;
        }
        if !inside {
            continue;
        }
        let key = line.split(['=', '.', ' ']).next().unwrap_or("").trim();
        if names.contains(&key) {
            found.push(key.to_string());
        }
    }
    found
}

#[test]
fn each_crate_imports_only_the_floors_below_it() {
    let mut checked = 0;
    for (dir, allowed) in FLOORS {
        let manifest = root().join(dir).join("Cargo.toml");
        assert!(
            manifest.exists(),
            "{} is gone: update house.md and this table",
            manifest.display()
        );
        for dep in workspace_dependencies(&manifest) {
            assert!(
                allowed.contains(&dep.as_str()),
                "{dir} imports {dep}, above its floor (house.md)"
            );
            checked += 1;
        }
    }
    // the graph is not empty: the reader found the dependencies
    assert!(checked >= 15, "only {checked} workspace dependencies found");
    // a crate the table does not know is a crate house.md does not know
    let members = std::fs::read_to_string(root().join("Cargo.toml")).unwrap();
    let line = members.lines().find(|l| l.starts_with("members")).unwrap();
    for (i, name) in line.split('"').enumerate() {
        if i % 2 == 1 {
            assert!(
                FLOORS.iter().any(|f| f.0 == name),
                "workspace member {name} is not in house.md's table"
            );
        }
    }
}

fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn no_source_file_is_past_the_house_size() {
    let mut files = Vec::new();
    for (dir, _) in FLOORS {
        let src = root().join(dir).join("src");
        if src.exists() {
            sources(&src, &mut files);
        }
    }
    assert!(files.len() > 100, "only {} source files found", files.len());
    let mut over = Vec::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let code = text.lines().take_while(|l| !is_test_marker(l)).count();
        if code > MAX_LINES {
            over.push(format!("{} ({code} lines)", f.strip_prefix(root()).unwrap().display()));
        }
    }
    assert!(over.is_empty(), "past {MAX_LINES} lines of non-test code, to be split: {over:?}");
}

/// "No function in `ins-gnss/src` or `ins-gnss-core/src` over 80 lines" (the house
/// issue; and in the crates split out of `ins-gnss-core`, `gnss` and `ins-gnss-io`): the
/// bound, and the functions still over it with the length each may not pass
/// (a ratchet: a new one over the bound, or one of these growing, fails; one brought under
/// the bound is taken off the list).
const MAX_FN_LINES: usize = 80;
const LONG_FUNCTIONS: &[(&str, &str, usize)] = &[];

/// A line with its string and character literals and its `//` comment taken out (enough
/// to count braces in this code base's Rust).
fn code_of(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    let mut in_str = false;
    while let Some(c) = chars.next() {
        if in_str {
            match c {
                '\\' => {
                    chars.next();
                }
                '"' => in_str = false,
                _ => {}
            }
            continue;
        }
        match c {
            '"' => in_str = true,
            '/' if chars.peek() == Some(&'/') => break,
            // a character literal ('{', '\'', '\\'): a lifetime has no closing quote
            '\'' => {
                let rest: String = chars.clone().take(3).collect();
                if rest.starts_with('\\') && rest.chars().nth(2) == Some('\'') {
                    chars.nth(2);
                } else if rest.chars().nth(1) == Some('\'') {
                    chars.nth(1);
                } else {
                    out.push(c);
                }
            }
            _ => out.push(c),
        }
    }
    out
}

/// Every function of a file's non-test code with its length in lines (from its `fn` line
/// to its closing brace).
fn function_lengths(text: &str) -> Vec<(String, usize)> {
    let lines: Vec<&str> = text.lines().take_while(|l| !is_test_marker(l)).collect();
    let mut found = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        let t = lines[i].trim_start();
        let t = t.strip_prefix("pub(crate) ").or(t.strip_prefix("pub(super) ")).unwrap_or(t);
        let t = t.strip_prefix("pub ").unwrap_or(t);
        let t = t.strip_prefix("const ").unwrap_or(t);
        let Some(rest) = t.strip_prefix("fn ") else {
            i += 1;
            continue;
        };
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let (mut depth, mut opened, mut j) = (0i64, false, i);
        while j < lines.len() {
            let code = code_of(lines[j]);
            for c in code.chars() {
                match c {
                    '{' => (depth, opened) = (depth + 1, true),
                    '}' => depth -= 1,
                    _ => {}
                }
            }
            if (opened && depth == 0) || (!opened && code.trim_end().ends_with(';')) {
                break;
            }
            j += 1;
        }
        if opened {
            found.push((name, j - i + 1));
            i = j + 1;
        } else {
            i += 1;
        }
    }
    found
}

#[test]
fn no_function_is_past_the_house_length_but_the_named_ones() {
    let mut files = Vec::new();
    for dir in ["ins-gnss", "ins-gnss-core", "ins-gnss-io", "gnss"] {
        sources(&root().join(dir).join("src"), &mut files);
    }
    let (mut over, mut counted) = (Vec::new(), 0);
    let mut seen = Vec::new();
    for f in &files {
        let rel = f.strip_prefix(root()).unwrap().to_string_lossy().replace('\\', "/");
        for (name, n) in function_lengths(&std::fs::read_to_string(f).unwrap()) {
            counted += 1;
            if n <= MAX_FN_LINES {
                continue;
            }
            match LONG_FUNCTIONS.iter().find(|l| l.0 == rel && l.1 == name) {
                Some(l) if n <= l.2 => seen.push((l.0, l.1)),
                Some(l) => over.push(format!("{rel} {name}: {n} lines, grown past {}", l.2)),
                None => over.push(format!("{rel} {name}: {n} lines")),
            }
        }
    }
    assert!(counted > 1000, "only {counted} functions found");
    assert!(over.is_empty(), "functions past {MAX_FN_LINES} lines, to be split: {over:?}");
    // a function brought under the bound leaves the list (the list only shrinks)
    let gone: Vec<_> = LONG_FUNCTIONS.iter().filter(|l| !seen.contains(&(l.0, l.1))).collect();
    assert!(
        gone.is_empty(),
        "now under {MAX_FN_LINES} lines or renamed, take off the list: {gone:?}"
    );
}

#[test]
fn the_function_counter_counts_braces_not_literals() {
    let text = "fn a() {\n    let s = \"}}\"; // }\n    let c = '{';\n    if x { y }\n}\n\
                pub(crate) fn b<'a>(x: &'a str) -> &'a str {\n    x\n}\nfn c();\n";
    assert_eq!(function_lengths(text), vec![("a".to_string(), 5), ("b".to_string(), 3)]);
}

/// The top-level modules ("rooms") of a crate's `src/` and, for each, the other rooms its
/// non-test code names through `crate::ROOM` (a file's code before its `#[cfg(test)]`;
/// files named `tests.rs` and `bin/` left out; comments left out). A room's own children
/// may use their parent (`super::`): a cycle is between rooms.
fn room_graph(src: &Path) -> Vec<(String, Vec<String>)> {
    let mut rooms: Vec<(String, Vec<PathBuf>)> = Vec::new();
    for entry in std::fs::read_dir(src).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if ["lib", "main", "bin"].contains(&name.as_str()) {
            continue;
        }
        let mut files = Vec::new();
        if path.is_dir() {
            sources(&path, &mut files);
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path.clone());
        } else {
            continue;
        }
        rooms.push((name, files));
    }
    let names: Vec<String> = rooms.iter().map(|r| r.0.clone()).collect();
    let mut graph = Vec::new();
    for (name, files) in &rooms {
        let mut uses = Vec::new();
        for f in files.iter().filter(|f| f.file_name().is_some_and(|n| n != "tests.rs")) {
            let text = std::fs::read_to_string(f).unwrap();
            for line in text.lines().take_while(|l| !is_test_marker(l)) {
                let code = code_of(line);
                for (i, _) in code.match_indices("crate::") {
                    let rest = &code[i + "crate::".len()..];
                    let room: String =
                        rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
                    if room != *name && names.contains(&room) && !uses.contains(&room) {
                        uses.push(room);
                    }
                }
            }
        }
        graph.push((name.clone(), uses));
    }
    graph
}

/// A cycle of the graph (its rooms in order), if there is one.
fn a_cycle(graph: &[(String, Vec<String>)]) -> Option<Vec<String>> {
    fn visit(
        at: &str,
        graph: &[(String, Vec<String>)],
        path: &mut Vec<String>,
        done: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        if let Some(k) = path.iter().position(|p| p == at) {
            return Some(path[k..].to_vec());
        }
        if done.iter().any(|d| d == at) {
            return None;
        }
        path.push(at.to_string());
        let next = graph.iter().find(|g| g.0 == at).map(|g| g.1.clone()).unwrap_or_default();
        for n in &next {
            if let Some(c) = visit(n, graph, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.push(at.to_string());
        None
    }
    let mut done = Vec::new();
    graph.iter().find_map(|g| visit(&g.0, graph, &mut Vec::new(), &mut done))
}

/// "No module cycle in any crate" (the house issue): the rooms of each crate's `src/`
/// import each other one way only.
#[test]
fn no_crate_has_a_cycle_of_rooms() {
    let mut edges = 0;
    for (dir, _) in FLOORS {
        let src = root().join(dir).join("src");
        if !src.exists() {
            continue;
        }
        let graph = room_graph(&src);
        edges += graph.iter().map(|g| g.1.len()).sum::<usize>();
        assert_eq!(a_cycle(&graph), None, "{dir}: its rooms import each other in a cycle");
    }
    // the reader found the imports
    assert!(edges > 100, "only {edges} imports between rooms found");
}

/// The cycle finder finds a cycle of three and none in a chain.
#[test]
fn the_cycle_finder_finds_cycles() {
    let g = |v: &[(&str, &[&str])]| -> Vec<(String, Vec<String>)> {
        v.iter().map(|(a, b)| (a.to_string(), b.iter().map(|s| s.to_string()).collect())).collect()
    };
    let cyclic = g(&[("a", &["b"]), ("b", &["c"]), ("c", &["a"]), ("d", &["a"])]);
    let found = a_cycle(&cyclic).unwrap();
    assert_eq!(found.len(), 3);
    let chain = g(&[("a", &["b"]), ("b", &["c"]), ("c", &[]), ("d", &["a", "c"])]);
    assert_eq!(a_cycle(&chain), None);
}

/// The line that starts a file's tests: `#[cfg(test)]`, or `#[cfg(feature =
/// "unit-tests")]` (the program's unit tests, run from its integration-test binary).
fn is_test_marker(line: &str) -> bool {
    matches!(line.trim(), "#[cfg(test)]" | "#[cfg(feature = \"unit-tests\")]")
}
