//! The workspace's layout rule: no two modules import each other. Every `.rs` file is a
//! module; a file imports another when it names that module's path after `crate::` (or
//! `super::`). A module and the folder it heads (`x.rs` or `x/mod.rs` and `x/…`) are one
//! concern and may refer to each other. The host-sim binary's modules (those `main.rs`
//! declares) form their own tree. `shared` is built in floors ([`SHARED_FLOORS`], ground
//! first): no module imports a floor above its own, the crate's top level holds at most eight
//! floors beside lib.rs, and no file of it is over 1 200 lines. Sources are read, not built:
//! O(lines of the workspace).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path (`a::b`) → the file's text, for every `.rs` file under `src` whose top-level
/// module is accepted by `keep`.
fn modules(src: &Path, keep: &dyn Fn(&str) -> bool) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                let rel = path.strip_prefix(src).unwrap().with_extension("");
                let mut parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                if parts.last().is_some_and(|p| p == "mod") {
                    parts.pop();
                }
                if parts == ["lib"] || parts == ["main"] {
                    parts.clear();
                }
                let top = parts.first().cloned().unwrap_or_default();
                if keep(&top) || parts.is_empty() {
                    out.insert(parts.join("::"), std::fs::read_to_string(&path).unwrap());
                }
            }
        }
    }
    out
}

/// The module paths a text names after `prefix::`, lower-case segments only, comments left
/// out.
fn named_paths(text: &str, prefix: &str) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        let mut rest = code;
        while let Some(at) = rest.find(prefix) {
            let before = rest[..at].chars().last();
            rest = &rest[at + prefix.len()..];
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let mut segments = Vec::new();
            let mut tail = rest;
            loop {
                let end = tail
                    .find(|c: char| !(c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'))
                    .unwrap_or(tail.len());
                if end == 0 {
                    break;
                }
                segments.push(tail[..end].to_string());
                tail = &tail[end..];
                match tail.strip_prefix("::") {
                    Some(t) => tail = t,
                    None => break,
                }
            }
            if !segments.is_empty() {
                out.push(segments);
            }
        }
    }
    out
}

/// Pairs of modules that import each other.
fn mutual_imports(tree: &BTreeMap<String, String>) -> Vec<(String, String)> {
    let mut edges: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for (module, text) in tree {
        let own: Vec<&str> = if module.is_empty() {
            Vec::new()
        } else {
            module.split("::").collect()
        };
        let mut targets = named_paths(text, "crate::");
        for path in named_paths(text, "super::") {
            let parent = &own[..own.len().saturating_sub(1)];
            targets.push(parent.iter().map(|s| s.to_string()).chain(path).collect());
        }
        for path in targets {
            // The longest prefix of the path that is a module.
            let target = (1..=path.len())
                .rev()
                .map(|n| path[..n].join("::"))
                .find(|m| tree.contains_key(m));
            let Some(target) = target else { continue };
            let related = target == *module
                || module.starts_with(&format!("{target}::"))
                || target.starts_with(&format!("{module}::"))
                || module.is_empty();
            if !related {
                let (key, _) = tree.get_key_value(&target).unwrap();
                edges
                    .entry(module.as_str())
                    .or_default()
                    .insert(key.as_str());
            }
        }
    }
    let mut pairs = Vec::new();
    for (a, targets) in &edges {
        for b in targets {
            if a < b && edges.get(b).is_some_and(|t| t.contains(a)) {
                pairs.push((a.to_string(), b.to_string()));
            }
        }
    }
    pairs
}

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// The top-level modules `main.rs` declares: the binary's own tree.
fn binary_modules(main: &Path) -> BTreeSet<String> {
    std::fs::read_to_string(main)
        .unwrap()
        .lines()
        .filter_map(|l| l.trim().strip_prefix("mod "))
        .filter_map(|l| l.strip_suffix(';'))
        .map(str::to_string)
        .collect()
}

#[test]
fn no_two_modules_import_each_other() {
    let root = workspace();
    let mut found = Vec::new();
    for krate in ["shared", "firmware"] {
        let src = root.join(krate).join("src");
        // The firmware's binary and library share a folder but not modules' paths.
        found.extend(
            mutual_imports(&modules(&src, &|_| true))
                .into_iter()
                .map(|p| (krate, p)),
        );
    }
    let src = root.join("host-sim").join("src");
    let bin = binary_modules(&src.join("main.rs"));
    assert!(bin.contains("commands"), "{bin:?}");
    let library = modules(&src, &|top| !bin.contains(top));
    let binary = modules(&src, &|top| bin.contains(top));
    assert!(library.contains_key("plant::reference") && binary.contains_key("commands"));
    for tree in [library, binary] {
        found.extend(mutual_imports(&tree).into_iter().map(|p| ("host-sim", p)));
    }
    assert!(found.is_empty(), "modules importing each other: {found:?}");
}

#[test]
fn the_check_finds_a_pair_and_passes_a_folder() {
    let tree: BTreeMap<String, String> = [
        ("", "pub mod a; pub mod b; pub mod c;"),
        (
            "a",
            "use crate::b::Thing;\nuse crate::c::inner::X; // crate::b in a comment",
        ),
        ("b", "fn f() { crate::a::g(); }"),
        ("c", "pub mod inner; use self::inner::X;"),
        ("c::inner", "use super::Y; use crate::c::Z;"),
    ]
    .into_iter()
    .map(|(m, t)| (m.to_string(), t.to_string()))
    .collect();
    assert_eq!(mutual_imports(&tree), [("a".to_string(), "b".to_string())]);
    assert_eq!(
        named_paths("use crate::x::y::Z; notcrate::q", "crate::"),
        [vec!["x".to_string(), "y".to_string()]]
    );
}

/// `shared`'s floors from the ground up (shared/src/lib.rs): a module may name paths of its
/// own floor and of the floors below it, never of one above.
const SHARED_FLOORS: [&str; 8] = [
    "base",
    "physics",
    "test",
    "model",
    "solver",
    "preflight",
    "flight",
    "prognostics",
];

/// Modules that name a floor above their own: (module, the floor it names).
fn floors_imported_upwards(
    tree: &BTreeMap<String, String>,
    floors: &[&str],
) -> Vec<(String, String)> {
    let level = |name: &str| floors.iter().position(|f| *f == name);
    let mut found = Vec::new();
    for (module, text) in tree {
        let Some(own) = module.split("::").next().and_then(level) else {
            continue;
        };
        for path in named_paths(text, "crate::") {
            if let Some(named) = path.first().and_then(|f| level(f)) {
                if named > own {
                    found.push((module.clone(), path[0].clone()));
                }
            }
        }
    }
    found.sort();
    found.dedup();
    found
}

#[test]
fn shared_is_built_in_floors() {
    let src = workspace().join("shared").join("src");
    let tree = modules(&src, &|_| true);
    // Every module of the crate lives in a floor.
    let loose: Vec<&String> = tree
        .keys()
        .filter(|m| !m.is_empty() && !SHARED_FLOORS.contains(&m.split("::").next().unwrap()))
        .collect();
    assert!(loose.is_empty(), "modules outside the floors: {loose:?}");
    let upwards = floors_imported_upwards(&tree, &SHARED_FLOORS);
    assert!(
        upwards.is_empty(),
        "modules importing a floor above their own: {upwards:?}"
    );
    // The top level: lib.rs and the floors.
    let mut top: Vec<String> = std::fs::read_dir(&src)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n != "lib.rs")
        .collect();
    top.sort();
    assert!(
        top.len() <= 8,
        "shared/src holds {} entries beside lib.rs: {top:?}",
        top.len()
    );
    // No file over 1 200 lines.
    let mut long = Vec::new();
    let mut stack = vec![src];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let lines = std::fs::read_to_string(&path).unwrap().lines().count();
                if lines > 1200 {
                    long.push((path, lines));
                }
            }
        }
    }
    assert!(long.is_empty(), "files over 1 200 lines: {long:?}");
}

#[test]
fn the_floor_check_finds_an_upward_import() {
    let tree: BTreeMap<String, String> = [
        ("", "pub mod low; pub mod high;"),
        ("low", "pub mod a;"),
        (
            "low::a",
            "use crate::high::b::Thing; // crate::low in a comment",
        ),
        ("high", "pub mod b;"),
        ("high::b", "use crate::low::a::X; use crate::high::b::Y;"),
    ]
    .into_iter()
    .map(|(m, t)| (m.to_string(), t.to_string()))
    .collect();
    assert_eq!(
        floors_imported_upwards(&tree, &["low", "high"]),
        [("low::a".to_string(), "high".to_string())]
    );
    assert!(floors_imported_upwards(&tree, &["high", "low"])
        .contains(&("high::b".to_string(), "low".to_string())));
}
