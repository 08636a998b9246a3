//! Tidy tests of the shared vocabulary (issue 49): each thing the crates used to spell out again
//! has one home now, and these keep it so, naming the file and line that drifted.
//!
//! - run keys (`swarm/{run}/...`) are made by `swarm_wire::Keys` only: no other `src/` file
//!   formats one (benches may format layouts `Keys` does not have, to measure them; end-to-end
//!   tests spell keys as a person types them, on purpose);
//! - one angle wrap, `swarm_types::wrap_angle`;
//! - the hover command is `Cmd::hover` on the wire and `Command::hover` between the controllers,
//!   never its fields spelled out;
//! - a mode's name comes from the mode (`name()`), never from its `Debug` text;
//! - no whole module is exempted from dead-code warnings;
//! - the modules of a folder (or of a crate's root) import one another one way: no two sibling
//!   modules name each other, and no longer circle closes among them.
//!
//! Pure file reading: nothing is built or run.

mod common;

use common::{files_with_extension, member_dirs, read, rel, root};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, recursively, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    files_with_extension(dir, "rs")
}

/// The `src/` folders of the workspace's members.
fn src_dirs() -> Vec<PathBuf> {
    member_dirs().into_iter().map(|d| root().join(d).join("src")).collect()
}

/// The code of `text` before its first `#[cfg(test)]` (a file's tests come last), as numbered
/// lines with comments left out.
fn code_before_tests(text: &str) -> Vec<(usize, &str)> {
    text.lines()
        .enumerate()
        .take_while(|(_, l)| l.trim() != "#[cfg(test)]")
        .filter(|(_, l)| !l.trim_start().starts_with("//"))
        .map(|(i, l)| (i + 1, l))
        .collect()
}

/// `file:line: code` for every code line of the workspace's `src/` outside `except` that `bad`
/// says is wrong.
fn offending_lines(except: &[&str], bad: impl Fn(&str) -> bool) -> Vec<String> {
    let mut found = Vec::new();
    for file in src_dirs().iter().flat_map(|d| rust_files(d)) {
        let name = rel(&file);
        if except.iter().any(|e| name == *e) {
            continue;
        }
        let text = read(&file);
        for (n, line) in code_before_tests(&text).into_iter().filter(|(_, l)| bad(l)) {
            found.push(format!("{name}:{n}: `{}`", line.trim()));
        }
    }
    found
}

/// Pieces of a run key as a format string writes them.
const RUN_KEY_PIECES: [&str; 8] =
    ["swarm/{", "}/clock", "}/uav/", "}/truth/", "}/alive/", "}/netem/", "}/scenario", "}/share/"];

/// Whether a line formats a run key.
fn formats_a_run_key(line: &str) -> bool {
    line.contains("format!(\"") && RUN_KEY_PIECES.iter().any(|p| line.contains(p))
}

#[test]
fn run_keys_are_made_by_wire_keys_only() {
    let found = offending_lines(&["wire/src/keys.rs"], formats_a_run_key);
    assert!(found.is_empty(), "run keys formatted outside swarm_wire::Keys (add a Keys method):\n{}", found.join("\n"));
    assert!(formats_a_run_key(r#"let k = format!("swarm/{run}/uav/{i}/cmd");"#), "the check sees a key");
    assert!(!formats_a_run_key(r#"ctx.channel_builder(format!("/uav/{id}/pose"))"#), "an MCAP topic is no key");
}

#[test]
fn one_angle_wrap() {
    let found = offending_lines(&["types/src/frame.rs"], |l| l.contains("fn wrap_angle"));
    assert!(found.is_empty(), "a second angle wrap (use swarm_types::wrap_angle):\n{}", found.join("\n"));
}

#[test]
fn the_hover_command_has_one_spelling() {
    let homes = ["wire/src/msg.rs", "uav-agent/src/control/controller.rs"];
    let found = offending_lines(&homes, |l| l.contains("kind: CmdKind::Hover,"));
    assert!(
        found.is_empty(),
        "a hover command spelled out (use Cmd::hover(tick), or the controllers' Command::hover()):\n{}",
        found.join("\n")
    );
}

#[test]
fn mode_names_come_from_the_modes() {
    let found = offending_lines(&[], |l| l.contains(").to_lowercase()") && l.contains("format!(\"{:?}\""));
    assert!(found.is_empty(), "a name made from Debug text (use the mode's name()):\n{}", found.join("\n"));
}

/// Whether `line` declares a module (`mod x;`, `pub mod x;`, `pub(crate) mod x {`).
fn declares_a_module(line: &str) -> bool {
    line.trim_start().trim_start_matches("pub(crate) ").trim_start_matches("pub ").starts_with("mod ")
}

#[test]
fn no_module_is_exempt_from_dead_code_warnings() {
    let mut found = offending_lines(&[], |l| l.contains("#![allow(dead_code)]"));
    for file in src_dirs().iter().flat_map(|d| rust_files(d)) {
        let text = read(&file);
        let lines: Vec<&str> = text.lines().collect();
        for (i, w) in lines.windows(2).enumerate() {
            if w[0].contains("allow(dead_code)") && declares_a_module(w[1]) {
                found.push(format!("{}:{}: `{}` over `{}`", rel(&file), i + 1, w[0].trim(), w[1].trim()));
            }
        }
    }
    assert!(
        found.is_empty(),
        "a whole module exempt from dead-code warnings (gate the test-only items with #[cfg(test)] instead):\n{}",
        found.join("\n")
    );
    assert!(declares_a_module("pub(crate) mod database;") && !declares_a_module("let model = 1;"));
}

/// The sibling modules of each module folder: folder -> (module name -> its code).
fn sibling_groups() -> BTreeMap<PathBuf, BTreeMap<String, String>> {
    let mut groups: BTreeMap<PathBuf, BTreeMap<String, String>> = BTreeMap::new();
    for file in src_dirs().iter().flat_map(|d| rust_files(d)) {
        let stem = file.file_stem().and_then(|s| s.to_str()).expect("a file name").to_string();
        let (folder, name) = match stem.as_str() {
            // A folder module is a sibling in its parent folder, under the folder's name.
            "mod" => {
                let dir = file.parent().expect("a folder");
                let name = dir.file_name().and_then(|s| s.to_str()).expect("a folder name").to_string();
                (dir.parent().expect("a parent").to_path_buf(), name)
            }
            "lib" | "main" => continue,
            _ => (file.parent().expect("a folder").to_path_buf(), stem),
        };
        let code: String = code_before_tests(&read(&file)).into_iter().map(|(_, l)| format!("{l}\n")).collect();
        groups.entry(folder).or_default().insert(name, code);
    }
    groups
}

/// The module path of a folder under its crate's `src/` (`control` for `uav-agent/src/control`).
fn module_path(folder: &Path) -> String {
    let mut parts = Vec::new();
    let mut at = folder;
    while at.file_name().is_some_and(|n| n != "src") {
        parts.push(at.file_name().and_then(|s| s.to_str()).expect("a folder name").to_string());
        at = at.parent().expect("a parent");
    }
    parts.reverse();
    parts.join("::")
}

/// Whether `code`, a module of the folder at `path`, names its sibling `other`.
fn names_sibling(code: &str, path: &str, other: &str) -> bool {
    let absolute = if path.is_empty() { format!("crate::{other}") } else { format!("crate::{path}::{other}") };
    let word = |text: &str, at: usize, len: usize| {
        let next = text[at + len..].chars().next();
        !next.is_some_and(|c| c.is_alphanumeric() || c == '_')
    };
    for pat in [format!("super::{other}"), absolute] {
        if code.match_indices(&pat).any(|(i, _)| word(code, i, pat.len())) {
            return true;
        }
    }
    // `use super::{a, b::C}` and `use crate::path::{a, b}`
    let braces = if path.is_empty() {
        vec!["super::{".to_string(), "crate::{".to_string()]
    } else {
        vec!["super::{".to_string(), format!("crate::{path}::{{")]
    };
    braces.iter().any(|b| {
        code.match_indices(b.as_str()).any(|(i, _)| {
            let rest = &code[i + b.len()..];
            let list = &rest[..rest.find('}').unwrap_or(rest.len())];
            list.split(',').any(|item| item.trim().split("::").next() == Some(other))
        })
    })
}

/// A circle among `edges` (module -> the siblings it names), if there is one.
fn a_circle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        at: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        path: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(start) = path.iter().position(|p| p == at) {
            let mut circle = path[start..].to_vec();
            circle.push(at.to_string());
            return Some(circle);
        }
        if done.contains(at) {
            return None;
        }
        path.push(at.to_string());
        for next in edges.get(at).into_iter().flatten() {
            if let Some(c) = visit(next, edges, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(at.to_string());
        None
    }
    let mut done = BTreeSet::new();
    edges.keys().find_map(|k| visit(k, edges, &mut Vec::new(), &mut done))
}

#[test]
fn sibling_modules_import_one_way() {
    let mut circles = Vec::new();
    for (folder, modules) in sibling_groups() {
        let path = module_path(&folder);
        let edges: BTreeMap<String, BTreeSet<String>> = modules
            .iter()
            .map(|(m, code)| {
                let named = modules.keys().filter(|o| *o != m && names_sibling(code, &path, o)).cloned().collect();
                (m.clone(), named)
            })
            .collect();
        if let Some(c) = a_circle(&edges) {
            circles.push(format!("{}: {}", rel(&folder), c.join(" -> ")));
        }
    }
    assert!(
        circles.is_empty(),
        "modules that import each other in a circle (move what both need below them):\n{}",
        circles.join("\n")
    );
}

#[test]
fn the_circle_finder_finds_circles() {
    let edges = |pairs: &[(&str, &str)]| {
        let mut e: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in pairs {
            e.entry(a.to_string()).or_default().insert(b.to_string());
            e.entry(b.to_string()).or_default();
        }
        e
    };
    assert_eq!(a_circle(&edges(&[("a", "b"), ("b", "c")])), None);
    assert!(a_circle(&edges(&[("a", "b"), ("b", "c"), ("c", "a")])).is_some());
    assert!(names_sibling("use super::pilot::{A21Pilot};\n", "control", "pilot"));
    assert!(names_sibling("use super::{a21, k21, p17};\n", "control", "k21"));
    assert!(names_sibling("use crate::sweep_seeds::stats::x;\n", "", "sweep_seeds"));
    assert!(!names_sibling("use crate::sweep_seeds_old::x;\n", "", "sweep_seeds"));
    assert!(!names_sibling("use crate::control::pilot;\n", "", "pilot"), "a nephew is not a sibling");
}
