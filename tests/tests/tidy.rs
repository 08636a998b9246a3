//! Tidy tests, after rust-analyzer's `xtask/src/tidy.rs`: the docs that can drift from the code are
//! read back and checked against it, so a change that makes them false fails here, naming the file
//! and what to add.
//!
//! The checks walk the workspace as it is (its `Cargo.toml` members, their `src/` and `benches/`),
//! so moving or adding a module or a crate needs no change here:
//! - every `.rs` file under a crate's `src/` and `benches/` opens with a `//!` module doc;
//! - every file that declares modules (`lib.rs`, `main.rs`, a folder module) names each of them in
//!   that doc, as `` `x` `` or [`x`];
//! - ARCHITECTURE.md's key-expression table lists exactly the keys `swarm_wire::Keys` builds, and
//!   every wildcard it builds matches some row of the table;
//! - ARCHITECTURE.md's codemap has a section per crate, naming each of the crate's top-level
//!   modules;
//! - ARCHITECTURE.md's crate-dependency list says what each member's `Cargo.toml` depends on,
//!   and its picture draws every member above each member it depends on, naming each once;
//! - the `swarm-node` binary links none of the upper floors' heavy packages (MCAP, Foxglove,
//!   plotters), asked of `cargo tree`;
//! - no function in the agent's node, the hub's node or the launcher is over 60 lines;
//! - in `uav-agent`, only the modules under `src/net/` name `zenoh`: the onboard stages stay pure;
//! - every member declares the workspace's `rust-version`, the `Dockerfile` builds with that
//!   Rust, and it is at least the highest `rust-version` any package of the locked dependency
//!   graph declares.
//!
//! Pure file reading, but for the last check, which asks `cargo metadata --locked` for the locked
//! graph (nothing is built).

mod common;

use common::{files_with_extension, member_dirs, read, rel, root};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One workspace member: its folder (relative to the root) and its package name.
struct Member {
    dir: String,
    package: String,
}

/// The members of the root `Cargo.toml`, with their package names.
fn members() -> Vec<Member> {
    member_dirs()
        .into_iter()
        .map(|dir| {
            let own: toml::Table =
                read(&root().join(&dir).join("Cargo.toml")).parse().expect("member Cargo.toml parses");
            let package = own["package"]["name"].as_str().expect("package.name").to_string();
            Member { dir, package }
        })
        .collect()
}

/// Every `.rs` file under `dir`, recursively, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    files_with_extension(dir, "rs")
}

/// The source files the checks cover: each member's `src/` and `benches/`.
fn source_files() -> Vec<PathBuf> {
    members()
        .iter()
        .flat_map(|m| ["src", "benches"].map(|sub| root().join(&m.dir).join(sub)))
        .flat_map(|d| rust_files(&d))
        .collect()
}

/// The file's module doc: its `//!` lines in the leading block of comments and inner attributes
/// (empty when it has none).
fn module_doc(text: &str) -> String {
    text.lines()
        .map(str::trim)
        .take_while(|l| l.is_empty() || l.starts_with("//") || l.starts_with("#!["))
        .filter_map(|l| l.strip_prefix("//!"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The modules a file declares with `mod x;` (any visibility), leaving out `#[cfg(test)]` ones.
fn declared_modules(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut test_only = false;
    for line in text.lines().map(str::trim) {
        if line.starts_with("#[cfg(test)]") {
            test_only = true;
            continue;
        }
        let item = line
            .strip_prefix("pub ")
            .or_else(|| line.split_once(") ").filter(|(v, _)| v.starts_with("pub(")).map(|(_, r)| r));
        let item = item.unwrap_or(line);
        if let Some(name) = item.strip_prefix("mod ").and_then(|r| r.strip_suffix(';')) {
            if !test_only {
                out.push(name.trim().to_string());
            }
        }
        if !line.starts_with("#[") && !line.is_empty() {
            test_only = false;
        }
    }
    out
}

/// `text` names module `name`: as `` `name` ``, [`name`], or a path starting with it
/// (`` `name::Item` ``, `` `name/` ``).
fn names_module(text: &str, name: &str) -> bool {
    ["`", "::", "/"].iter().any(|end| text.contains(&format!("`{name}{end}")))
}

#[test]
fn every_source_file_has_a_module_doc() {
    let missing: Vec<String> = source_files()
        .iter()
        .filter(|f| module_doc(&read(f)).trim().is_empty())
        .map(|f| format!("{}: add a `//!` module doc at the top saying what the module is for", rel(f)))
        .collect();
    assert!(missing.is_empty(), "files without a module doc:\n{}", missing.join("\n"));
}

#[test]
fn every_module_is_named_in_its_parents_doc() {
    let mut missing = Vec::new();
    for file in source_files() {
        let text = read(&file);
        let doc = module_doc(&text);
        for m in declared_modules(&text).iter().filter(|m| !names_module(&doc, m)) {
            missing.push(format!(
                "{}: name module `{m}` in the `//!` doc (e.g. \"- [`{m}`]: what it is for\")",
                rel(&file)
            ));
        }
    }
    assert!(missing.is_empty(), "modules their parent's doc does not name:\n{}", missing.join("\n"));
}

/// ARCHITECTURE.md.
fn architecture() -> String {
    read(&root().join("ARCHITECTURE.md"))
}

/// The lines of section `## title` of `text` (up to the next `## `).
fn section<'a>(text: &'a str, title: &str) -> Vec<&'a str> {
    let heading = format!("## {title}");
    let mut lines = text.lines().skip_while(|l| l.trim() != heading);
    assert!(lines.next().is_some(), "ARCHITECTURE.md: add a `{heading}` section");
    lines.take_while(|l| !l.starts_with("## ")).collect()
}

/// The keys in the first column of ARCHITECTURE.md's key-expression table.
fn table_keys() -> BTreeSet<String> {
    let text = architecture();
    section(&text, "Key expressions")
        .iter()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split_once('`').map(|(key, _)| key.to_string()))
        .collect()
}

/// The names of the `pub fn`s of `wire/src/keys.rs`.
fn keys_rs_functions() -> BTreeSet<String> {
    let path = root().join("wire/src/keys.rs");
    read(&path)
        .lines()
        .filter_map(|l| l.trim().strip_prefix("pub fn "))
        .map(|l| l.split(['(', '<']).next().expect("a name").to_string())
        .collect()
}

/// What a `pub fn` of `wire/src/keys.rs` is to the table.
enum KeyFn {
    /// Builds one key: a row of the table.
    Key(fn(&swarm_wire::Keys, swarm_types::UavId) -> String),
    /// Builds a wildcard subscription: it must match some row.
    Wildcard(fn(&swarm_wire::Keys, swarm_types::UavId) -> String),
    /// Not a key (constructor, parser, prefix).
    Other,
}

/// Every `pub fn` of `wire/src/keys.rs`, called. A function added there and not here fails
/// [`key_table_matches_wire_keys`]: add it here, and its row to ARCHITECTURE.md if it is a key.
fn key_fns() -> Vec<(&'static str, KeyFn)> {
    use swarm_types::mode::{LocalizationMode, ShareKind};
    use swarm_wire::Keys;
    use KeyFn::{Key, Other, Wildcard};
    vec![
        ("check_component", Other),
        ("new", Other),
        ("prefix", Other),
        ("uav_id_of", Other),
        ("host_ids_of", Other),
        ("all", Wildcard(|k: &Keys, _| k.all())),
        ("clock", Key(|k: &Keys, _| k.clock())),
        ("scenario", Key(|k: &Keys, _| k.scenario())),
        ("sense", Key(|k: &Keys, id| k.sense(id))),
        ("sense_any", Wildcard(|k: &Keys, _| k.sense_any())),
        ("cmd", Key(|k: &Keys, id| k.cmd(id))),
        ("cmd_any", Wildcard(|k: &Keys, _| k.cmd_any())),
        ("share_pose", Key(|k: &Keys, id| k.share_pose(id))),
        ("share_obstacles", Key(|k: &Keys, id| k.share_obstacles(id))),
        ("share", Key(|k: &Keys, id| k.share(id, ShareKind::Obstacles))),
        ("share_of", Key(|k: &Keys, id| k.share_of(LocalizationMode::Broadcast, id).expect("broadcast shares"))),
        ("shares_of", Wildcard(|k: &Keys, id| k.shares_of(id))),
        ("shares_any", Wildcard(|k: &Keys, _| k.shares_any())),
        ("share_pose_any", Wildcard(|k: &Keys, _| k.share_pose_any())),
        ("share_obstacles_any", Wildcard(|k: &Keys, _| k.share_obstacles_any())),
        ("state", Key(|k: &Keys, id| k.state(id))),
        ("state_any", Wildcard(|k: &Keys, _| k.state_any())),
        ("netem_rules", Key(|k: &Keys, _| k.netem_rules())),
        ("netem_add", Key(|k: &Keys, _| k.netem_add())),
        ("netem_ack", Key(|k: &Keys, _| k.netem_ack())),
        ("truth_world", Key(|k: &Keys, _| k.truth_world())),
        ("truth_step", Key(|k: &Keys, _| k.truth_step())),
        ("truth_all", Wildcard(|k: &Keys, _| k.truth_all())),
        ("alive_hub", Key(|k: &Keys, _| k.alive_hub())),
        ("alive_uav", Key(|k: &Keys, id| k.alive_uav(id))),
        ("alive_recorder", Key(|k: &Keys, _| k.alive_recorder())),
        ("alive_ext", Key(|k: &Keys, id| k.alive_ext(id))),
        ("ext_view", Key(|k: &Keys, id| k.ext_view(id))),
        ("ext_cmd", Key(|k: &Keys, id| k.ext_cmd(id))),
        ("alive_uav_any", Wildcard(|k: &Keys, _| k.alive_uav_any())),
        ("ext_view_any", Wildcard(|k: &Keys, _| k.ext_view_any())),
        ("ext_cmd_any", Wildcard(|k: &Keys, _| k.ext_cmd_any())),
        ("alive_ext_any", Wildcard(|k: &Keys, _| k.alive_ext_any())),
        ("host_sense", Key(|k: &Keys, id| k.host_sense(&[id, swarm_types::UavId::new(id.get() + 1)]))),
        ("host_sense_any", Wildcard(|k: &Keys, _| k.host_sense_any())),
        ("host_cmd", Key(|k: &Keys, id| k.host_cmd(&[id, swarm_types::UavId::new(id.get() + 1)]))),
        ("host_cmd_any", Wildcard(|k: &Keys, _| k.host_cmd_any())),
        ("host_state", Key(|k: &Keys, id| k.host_state(&[id, swarm_types::UavId::new(id.get() + 1)]))),
        ("host_state_any", Wildcard(|k: &Keys, _| k.host_state_any())),
        ("alive_host", Key(|k: &Keys, id| k.alive_host(&[id, swarm_types::UavId::new(id.get() + 1)]))),
        ("alive_host_any", Wildcard(|k: &Keys, _| k.alive_host_any())),
    ]
}

/// A key of run `RUNID` and UAV 4242 (or UAVs 4242 and 4243, an agent host's) written as the
/// table writes it (`{run}`, `{id}`, `{ids}`).
fn as_pattern(key: &str) -> String {
    key.replace("RUNID", "{run}").replace("4242-4243", "{ids}").replace("4242", "{id}")
}

/// Zenoh key-expression matching, enough for our keys: `*` is one chunk, a final `**` the rest.
fn matches(wildcard: &str, key: &str) -> bool {
    let (w, k): (Vec<_>, Vec<_>) = (wildcard.split('/').collect(), key.split('/').collect());
    if w.last() == Some(&"**") {
        let fixed = &w[..w.len() - 1];
        return k.len() > fixed.len() && fixed.iter().zip(&k).all(|(a, b)| *a == "*" || a == b);
    }
    w.len() == k.len() && w.iter().zip(&k).all(|(a, b)| *a == "*" || a == b)
}

#[test]
fn key_table_matches_wire_keys() {
    let fns = key_fns();
    let listed: BTreeSet<String> = fns.iter().map(|(n, _)| n.to_string()).collect();
    let parsed = keys_rs_functions();
    let new_fns: Vec<_> = parsed.difference(&listed).collect();
    let gone_fns: Vec<_> = listed.difference(&parsed).collect();
    assert!(
        new_fns.is_empty() && gone_fns.is_empty(),
        "wire/src/keys.rs and tests/tests/tidy.rs `key_fns` disagree: add {new_fns:?} to `key_fns` (and a row to \
         ARCHITECTURE.md's key table if it builds a key); remove {gone_fns:?} from `key_fns`"
    );
    let keys = swarm_wire::Keys::new("RUNID").expect("valid run id");
    let table = table_keys();
    let mut problems = Vec::new();
    let mut built = BTreeSet::new();
    for (name, f) in &fns {
        match f {
            KeyFn::Key(make) => {
                let key = as_pattern(&make(&keys, swarm_types::UavId::new(4242)));
                if !table.contains(&key) {
                    problems.push(format!(
                        "ARCHITECTURE.md: add a row for `{key}` (built by `Keys::{name}`) to the key table"
                    ));
                }
                built.insert(key);
            }
            KeyFn::Wildcard(make) => {
                let w = as_pattern(&make(&keys, swarm_types::UavId::new(4242)));
                if !table.iter().any(|row| matches(&w, row)) {
                    problems.push(format!(
                        "ARCHITECTURE.md: `Keys::{name}` subscribes to `{w}`, which matches no row of the key table"
                    ));
                }
            }
            KeyFn::Other => {}
        }
    }
    for row in table.difference(&built) {
        problems.push(format!("ARCHITECTURE.md: the key table lists `{row}`, which `swarm_wire::Keys` does not build: remove the row or add the key to wire/src/keys.rs"));
    }
    assert!(problems.is_empty(), "the key table and the code disagree:\n{}", problems.join("\n"));
}

/// The codemap's sections: each `### ` heading with the text under it.
fn codemap_sections() -> Vec<(String, String)> {
    let text = architecture();
    let mut out: Vec<(String, String)> = Vec::new();
    for line in section(&text, "Codemap") {
        if let Some(heading) = line.strip_prefix("### ") {
            out.push((heading.to_string(), String::new()));
        } else if let Some((_, body)) = out.last_mut() {
            body.push_str(line);
            body.push('\n');
        }
    }
    out
}

/// The crate root of a member: `src/lib.rs`, or `src/main.rs` for a binary-only crate.
fn crate_root(member: &Member) -> PathBuf {
    let src = root().join(&member.dir).join("src");
    let lib = src.join("lib.rs");
    if lib.exists() {
        lib
    } else {
        src.join("main.rs")
    }
}

#[test]
fn codemap_names_every_crate_and_top_level_module() {
    let sections = codemap_sections();
    let mut problems = Vec::new();
    for m in members() {
        let named = |h: &str| names_module(h, &m.dir) || names_module(h, &m.package);
        let Some((_, body)) = sections.iter().find(|(h, _)| named(h)) else {
            problems.push(format!(
                "ARCHITECTURE.md: add a codemap section \"### `{}` (crate `{}`)\" saying what the crate is for",
                m.dir, m.package
            ));
            continue;
        };
        let root_file = crate_root(&m);
        for module in declared_modules(&read(&root_file)).iter().filter(|x| !names_module(body, x)) {
            problems.push(format!(
                "ARCHITECTURE.md: name `{module}` (a module of {}) in the codemap section of `{}`",
                rel(&root_file),
                m.dir
            ));
        }
    }
    assert!(problems.is_empty(), "the codemap and the workspace disagree:\n{}", problems.join("\n"));
}

/// The `name -> a, b` lines of ARCHITECTURE.md's crate-dependency list, as package -> deps.
fn documented_dependencies() -> BTreeMap<String, BTreeSet<String>> {
    let text = architecture();
    section(&text, "Crate dependencies")
        .into_iter()
        .filter_map(|l| l.split_once(" -> "))
        .map(|(name, deps)| {
            let deps =
                deps.split(',').map(str::trim).filter(|d| !d.is_empty() && *d != "(none)").map(String::from).collect();
            (name.trim().to_string(), deps)
        })
        .collect()
}

/// Each member's normal (not dev, not build) dependencies on other members, from its Cargo.toml.
fn manifest_dependencies() -> BTreeMap<String, BTreeSet<String>> {
    let members = members();
    let packages: BTreeSet<&str> = members.iter().map(|m| m.package.as_str()).collect();
    members
        .iter()
        .map(|m| {
            let own: toml::Table =
                read(&root().join(&m.dir).join("Cargo.toml")).parse().expect("member Cargo.toml parses");
            let deps = own
                .get("dependencies")
                .and_then(|d| d.as_table())
                .map(|t| t.keys().cloned().collect::<Vec<_>>())
                .unwrap_or_default();
            (m.package.clone(), deps.into_iter().filter(|d| packages.contains(d.as_str())).collect())
        })
        .collect()
}

#[test]
fn crate_dependency_list_matches_the_manifests() {
    let (documented, actual) = (documented_dependencies(), manifest_dependencies());
    let mut wrong = Vec::new();
    for (package, deps) in &actual {
        match documented.get(package) {
            None => wrong.push(format!("ARCHITECTURE.md: add `{package} -> ...` to `## Crate dependencies`")),
            Some(d) if d != deps => {
                wrong.push(format!("ARCHITECTURE.md: `{package}` depends on {deps:?} (its Cargo.toml), not {d:?}"))
            }
            Some(_) => {}
        }
    }
    for package in documented.keys().filter(|p| !actual.contains_key(*p)) {
        wrong.push(format!("ARCHITECTURE.md: `{package}` in `## Crate dependencies` is not a workspace member"));
    }
    assert!(wrong.is_empty(), "the crate dependencies and ARCHITECTURE.md disagree:\n{}", wrong.join("\n"));
}

/// The picture of `## Crate dependencies` (its first fenced block): the lines each crate's name
/// stands on, as package -> line numbers (each line once). Names are whole words (`swarm` is not
/// found in `swarm-node`); a name on two lines (a description naming another crate) is an error.
fn picture_rows(text: &str, packages: &BTreeSet<String>) -> BTreeMap<String, Vec<usize>> {
    let lines = section(text, "Crate dependencies");
    let block = lines.iter().skip_while(|l| !l.starts_with("```")).skip(1).take_while(|l| !l.starts_with("```"));
    let mut rows: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for (row, line) in block.enumerate() {
        for word in line.split(|c: char| !(c.is_alphanumeric() || c == '-' || c == '_')) {
            if packages.contains(word) {
                let lines = rows.entry(word.to_string()).or_default();
                if lines.last() != Some(&row) {
                    lines.push(row);
                }
            }
        }
    }
    rows
}

#[test]
fn crate_dependency_picture_draws_every_crate_above_what_it_uses() {
    let actual = manifest_dependencies();
    let packages: BTreeSet<String> = actual.keys().cloned().collect();
    let drawn = picture_rows(&architecture(), &packages);
    let mut wrong: Vec<String> = packages
        .iter()
        .filter(|p| !drawn.contains_key(*p))
        .map(|p| format!("ARCHITECTURE.md: draw `{p}` in the crate-dependency picture"))
        .collect();
    for (package, lines) in drawn.iter().filter(|(_, lines)| lines.len() > 1) {
        wrong.push(format!(
            "ARCHITECTURE.md: the crate-dependency picture names `{package}` on {} lines; name each crate once",
            lines.len()
        ));
    }
    let rows: BTreeMap<&String, usize> = drawn.iter().map(|(p, lines)| (p, lines[0])).collect();
    for (package, deps) in &actual {
        for dep in deps {
            if let (Some(a), Some(b)) = (rows.get(package), rows.get(dep)) {
                if a >= b {
                    wrong.push(format!(
                        "ARCHITECTURE.md: the picture must draw `{package}` above `{dep}`, which it depends on"
                    ));
                }
            }
        }
    }
    assert!(wrong.is_empty(), "the crate-dependency picture is wrong:\n{}", wrong.join("\n"));
}

#[test]
fn picture_rows_finds_whole_names_on_every_line() {
    let packages: BTreeSet<String> = ["swarm", "swarm-node"].iter().map(|s| s.to_string()).collect();
    let text = "## Crate dependencies\n\n```\n  swarm   the command\n    |\n  swarm-node  (below swarm)\n```\n";
    let rows = picture_rows(text, &packages);
    assert_eq!(rows.get("swarm"), Some(&vec![0, 2]), "`swarm` is drawn, and named again in a description");
    assert_eq!(rows.get("swarm-node"), Some(&vec![2]), "`swarm` inside `swarm-node` is not `swarm`");
}

/// The files whose functions must stay short: the three places where Zenoh plumbing and control
/// flow meet, which grow long loops unless held to it.
const SHORT_FUNCTION_FILES: [&str; 3] = ["uav-agent/src/net/node.rs", "physics-hub/src/node.rs", "swarm/src/launch.rs"];

/// Longest function allowed there, in lines from `fn` to its closing brace.
const MAX_FUNCTION_LINES: usize = 60;

/// `(name, lines)` of every function with a body in `text`: from its `fn` line to the first line
/// after it that closes at the same indentation.
fn function_lengths(text: &str) -> Vec<(String, usize)> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let code = line.trim_start();
        let indent = line.len() - code.len();
        let Some(at) = code.find("fn ").filter(|&at| at == 0 || code[..at].ends_with(' ')) else { continue };
        let is_item = ["pub", "async", "const", "unsafe"].iter().any(|w| code.starts_with(w)) || at == 0;
        if !is_item || code.ends_with(';') || code.starts_with("//") {
            continue;
        }
        let name: String = code[at + 3..].chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let close = format!("{}}}", " ".repeat(indent));
        if let Some(end) =
            lines[i + 1..].iter().position(|l| l.starts_with(&close) && l.len() - l.trim_start().len() == indent)
        {
            out.push((name, end + 2));
        }
    }
    out
}

#[test]
fn functions_in_the_nodes_and_the_launcher_stay_short() {
    let mut long = Vec::new();
    for file in SHORT_FUNCTION_FILES {
        for (name, n) in
            function_lengths(&read(&root().join(file))).into_iter().filter(|(_, n)| *n > MAX_FUNCTION_LINES)
        {
            long.push(format!(
                "{file}: `{name}` is {n} lines; split it into named steps (at most {MAX_FUNCTION_LINES})"
            ));
        }
    }
    assert!(long.is_empty(), "{}", long.join("\n"));
}

/// The lines of `text` that are code: comments and doc comments left out.
fn code_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter(|(_, l)| !l.trim_start().starts_with("//")).map(|(i, l)| (i + 1, l))
}

#[test]
fn only_the_agents_network_layer_touches_zenoh() {
    let src = root().join("uav-agent/src");
    let net = src.join("net");
    let mut found = Vec::new();
    for file in rust_files(&src).into_iter().filter(|f| !f.starts_with(&net)) {
        for (n, line) in code_lines(&read(&file)).filter(|(_, l)| l.contains("zenoh")) {
            found.push(format!("{}:{n}: `{}`", rel(&file), line.trim()));
        }
    }
    assert!(
        found.is_empty(),
        "uav-agent names zenoh outside src/net/ (move the Zenoh side into `net`, keep the stage pure):\n{}",
        found.join("\n")
    );
    let net_files = rust_files(&net);
    assert!(
        net_files.iter().any(|f| code_lines(&read(f)).any(|(_, l)| l.contains("zenoh::"))),
        "the check looks where Zenoh is used"
    );
}

#[test]
fn the_helpers_parse_what_they_should() {
    let code = "fn a() {\n    x();\n}\n\nimpl B {\n    pub async fn b(&self) -> u32 {\n        1\n    }\n    fn c(&self);\n}\n";
    assert_eq!(function_lengths(code), vec![("a".to_string(), 3), ("b".to_string(), 3)]);
    let text = "//! Doc of [`a`] and `b::C`.\n#![allow(x)]\n//! More.\n\npub mod a;\nmod b;\npub(crate) mod c;\n#[cfg(test)]\nmod tests;\n";
    assert_eq!(declared_modules(text), ["a", "b", "c"]);
    let doc = module_doc(text);
    assert!(names_module(&doc, "a") && names_module(&doc, "b") && !names_module(&doc, "c"));
    assert!(doc.contains("More."));
    assert!(module_doc("use x;\n//! late").is_empty());
    assert!(matches("s/r/uav/*/cmd", "s/r/uav/{id}/cmd") && !matches("s/r/uav/*/cmd", "s/r/uav/{id}/state"));
    assert!(matches("s/r/truth/**", "s/r/truth/step") && !matches("s/r/truth/**", "s/r/clock"));
    assert!(
        version("1.90") == version("1.90.0")
            && version("1.88.0") < version("1.90")
            && version("1.100") > version("1.90")
    );
    let dockerfile = "# FROM rust:1.0 in a comment\nFROM rust:1.90-bookworm AS build\nFROM ${BASE} AS runtime\nfrom rust:1.91 as x\n";
    assert_eq!(rust_images(dockerfile), ["1.90", "1.91"]);
}

/// The workspace's `rust-version` (root `Cargo.toml`, `[workspace.package]`).
fn workspace_rust_version() -> String {
    let manifest: toml::Table = read(&root().join("Cargo.toml")).parse().expect("root Cargo.toml parses");
    manifest["workspace"]["package"]
        .get("rust-version")
        .and_then(|v| v.as_str())
        .expect("root Cargo.toml: set `rust-version` in [workspace.package]")
        .to_string()
}

/// A Rust version (`1.90`, `1.88.0`) as numbers to compare, missing parts 0.
fn version(text: &str) -> [u32; 3] {
    let mut out = [0; 3];
    for (slot, part) in out.iter_mut().zip(text.split('.')) {
        *slot = part.parse().unwrap_or_else(|e| panic!("{text:?} is not a Rust version: {e}"));
    }
    out
}

/// The versions of the `rust:` images a Dockerfile builds `FROM` (`rust:1.90-bookworm` -> `1.90`).
fn rust_images(dockerfile: &str) -> Vec<String> {
    dockerfile
        .lines()
        .map(str::trim)
        .filter(|l| l.len() > 5 && l[..5].eq_ignore_ascii_case("FROM "))
        .filter_map(|l| l[5..].trim().strip_prefix("rust:"))
        .map(|tag| tag.split(['-', ' ']).next().expect("a tag").to_string())
        .collect()
}

#[test]
fn dockerfile_builds_with_the_workspace_rust_version() {
    let want = workspace_rust_version();
    let images = rust_images(&read(&root().join("Dockerfile")));
    assert!(
        !images.is_empty(),
        "Dockerfile: no `FROM rust:<version>-...` build stage; the users' path builds `swarm` in one"
    );
    for got in &images {
        assert_eq!(
            got, &want,
            "Dockerfile builds FROM rust:{got}, but Cargo.toml's workspace rust-version is {want}: make them the same version"
        );
    }
}

#[test]
fn every_member_inherits_the_workspace_rust_version() {
    let mut missing = Vec::new();
    for m in members() {
        let own: toml::Table = read(&root().join(&m.dir).join("Cargo.toml")).parse().expect("member Cargo.toml parses");
        let inherits =
            own["package"].get("rust-version").and_then(|v| v.get("workspace")).and_then(|w| w.as_bool()) == Some(true);
        if !inherits {
            missing.push(format!("{}/Cargo.toml: add `rust-version.workspace = true` under [package]", m.dir));
        }
    }
    assert!(
        missing.is_empty(),
        "members that do not declare the workspace's rust-version (cargo then checks none):\n{}",
        missing.join("\n")
    );
}

#[test]
fn rust_version_covers_every_locked_dependency() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let out = std::process::Command::new(&cargo)
        .args(["metadata", "--format-version", "1", "--locked"])
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{cargo} metadata`: {e}"));
    assert!(out.status.success(), "`cargo metadata --locked` failed: {}", String::from_utf8_lossy(&out.stderr));
    let metadata: serde_json::Value = serde_json::from_slice(&out.stdout).expect("cargo metadata prints JSON");
    let members: BTreeSet<&str> = metadata["workspace_members"]
        .as_array()
        .expect("workspace_members")
        .iter()
        .filter_map(|m| m.as_str())
        .collect();
    let packages = metadata["packages"].as_array().expect("packages");
    let floors: Vec<(String, &str, &str)> = packages
        .iter()
        .filter(|p| !members.contains(p["id"].as_str().unwrap_or_default()))
        .filter_map(|p| Some((p["rust_version"].as_str()?.to_string(), p["name"].as_str()?, p["version"].as_str()?)))
        .collect();
    assert!(
        floors.len() > 10,
        "cargo metadata: only {} locked packages declare a rust-version; is its output read right?",
        floors.len()
    );
    let ours = workspace_rust_version();
    let above: Vec<String> = floors
        .iter()
        .filter(|(needs, _, _)| version(needs) > version(&ours))
        .map(|(needs, name, v)| format!("{name} {v} needs Rust {needs}"))
        .collect();
    assert!(
        above.is_empty(),
        "Cargo.toml's rust-version {ours} is below what the locked graph needs; raise it (and the Dockerfile's rust image) to \
         the highest of:\n{}",
        above.join("\n")
    );
}

/// What only the command's upper floors may link: the MCAP writer and reader, the Foxglove SDK
/// (and its WebSocket server), plotters, the progress bars.
const UPPER_FLOOR_PACKAGES: [&str; 5] = ["mcap", "foxglove", "plotters", "indicatif", "tokio-tungstenite"];

#[test]
fn the_node_binary_links_no_recorder_view_or_figures() {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let out = std::process::Command::new(&cargo)
        .args(["tree", "-p", "swarm-node", "-e", "normal", "--prefix", "none", "--locked", "--offline"])
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("cannot run `{cargo} tree`: {e}"));
    assert!(out.status.success(), "`cargo tree -p swarm-node` failed: {}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    let names: BTreeSet<&str> = text.lines().filter_map(|l| l.split_whitespace().next()).collect();
    assert!(names.contains("zenoh") && names.contains("uav-agent"), "is `cargo tree`'s output read right? {names:?}");
    let linked: Vec<&str> = UPPER_FLOOR_PACKAGES.iter().copied().filter(|p| names.contains(p)).collect();
    assert!(
        linked.is_empty(),
        "swarm-node (the hub, agent and router binary) links {linked:?}; they belong to swarm-record, swarm-view or swarm-plot"
    );
}
