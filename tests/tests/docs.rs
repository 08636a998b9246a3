//! Docs tests, beside the tidy checks: the README, ARCHITECTURE.md and the guide under `docs/`
//! are read back and checked against the repository and the command line, so a moved file, a
//! renamed heading or a renamed subcommand fails here, naming the page, the line and the fix:
//! - every relative Markdown link, `[text](path)`, `[text](path#anchor)` or `[text](#anchor)`
//!   (images too), names a file or folder of the repository, and an anchor into a Markdown file
//!   names one of its headings by GitHub's slug;
//! - every `swarm SUBCOMMAND` the README and the guide write as code (in backticks or in a fenced
//!   block) names a subcommand that `swarm --help` lists (not ARCHITECTURE.md, whose pictures name
//!   the crate `swarm`);
//! - every `swarm` command line of a code block parses (`SWARM_PARSE_ONLY`), and those for a
//!   running run (tap, keys, netem, credentials, record, recover) work as written against a real
//!   forest-5 run, with the login the docs give.
//!
//! File reading, `swarm --help` and the parse of the binary under test; one real run.

mod common;

use common::{files_with_extension, output_within, read, rel, root, SWARM, TOOL_LIMIT};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Component, Path, PathBuf};
use std::process::Command;

/// Every `.md` file under `dir`, recursively, sorted.
fn markdown_files(dir: &Path) -> Vec<PathBuf> {
    files_with_extension(dir, "md")
}

/// The README and the guide: README.md and `docs/**/*.md`.
fn guide_pages() -> Vec<PathBuf> {
    let mut guide = markdown_files(&root().join("docs"));
    guide.sort();
    guide.insert(0, root().join("README.md"));
    guide
}

/// The pages whose links are checked: the README, the guide and ARCHITECTURE.md.
fn linked_pages() -> Vec<PathBuf> {
    let mut out = guide_pages();
    out.push(root().join("ARCHITECTURE.md"));
    out
}

/// A page cut into what the checks read: its prose paragraphs (with the line each starts on) and
/// its fenced code lines (with their line numbers).
struct Page {
    paragraphs: Vec<(usize, String)>,
    code_lines: Vec<(usize, String)>,
}

impl Page {
    fn parse(text: &str) -> Page {
        let mut page = Page { paragraphs: Vec::new(), code_lines: Vec::new() };
        let mut fence: Option<String> = None;
        let mut paragraph: Option<(usize, String)> = None;
        for (i, line) in text.lines().enumerate() {
            let n = i + 1;
            let trimmed = line.trim_start();
            if let Some(open) = &fence {
                if trimmed.starts_with(open.as_str())
                    && trimmed.trim_start_matches(open.chars().next().unwrap_or('`')).trim().is_empty()
                {
                    fence = None;
                } else {
                    page.code_lines.push((n, line.to_string()));
                }
                continue;
            }
            let marker: String = trimmed.chars().take_while(|&c| c == '`' || c == '~').collect();
            if marker.len() >= 3 && marker.chars().all(|c| c == marker.chars().next().unwrap_or('`')) {
                page.paragraphs.extend(paragraph.take());
                fence = Some(marker);
                continue;
            }
            if trimmed.is_empty() {
                page.paragraphs.extend(paragraph.take());
                continue;
            }
            match &mut paragraph {
                Some((_, p)) => {
                    p.push('\n');
                    p.push_str(line);
                }
                None => paragraph = Some((n, line.to_string())),
            }
        }
        page.paragraphs.extend(paragraph.take());
        page
    }

    /// The headings outside code, as `(level, text)`.
    fn headings(&self) -> Vec<String> {
        self.paragraphs
            .iter()
            .flat_map(|(_, p)| p.lines())
            .filter_map(|l| {
                let hashes = l.chars().take_while(|&c| c == '#').count();
                (1..=6)
                    .contains(&hashes)
                    .then(|| l[hashes..].strip_prefix(' '))
                    .flatten()
                    .map(|t| t.trim_end_matches('#').trim().to_string())
            })
            .collect()
    }
}

/// A paragraph split into its prose (code spans blanked out, so a link written as code is not a
/// link) and its code spans, each with the byte offset it starts at.
fn split_code_spans(paragraph: &str) -> (String, Vec<(usize, String)>) {
    let bytes = paragraph.as_bytes();
    let mut prose = String::with_capacity(paragraph.len());
    let mut spans = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] != b'`' {
            let c = paragraph[i..].chars().next().expect("a char");
            prose.push(c);
            i += c.len_utf8();
            continue;
        }
        let run = bytes[i..].iter().take_while(|&&b| b == b'`').count();
        let ticks = "`".repeat(run);
        // The span closes at the next run of exactly as many backticks.
        let mut j = i + run;
        let mut close = None;
        while let Some(k) = paragraph[j..].find(&ticks) {
            let at = j + k;
            let len = bytes[at..].iter().take_while(|&&b| b == b'`').count();
            if len == run {
                close = Some(at);
                break;
            }
            j = at + len;
        }
        match close {
            Some(at) => {
                spans.push((i, paragraph[i + run..at].to_string()));
                prose.push_str(&" ".repeat(at + run - i));
                i = at + run;
            }
            None => {
                prose.push_str(&ticks);
                i += run;
            }
        }
    }
    (prose, spans)
}

/// The line of `paragraph` (starting on line `first`) that byte `offset` falls on.
fn line_at(first: usize, paragraph: &str, offset: usize) -> usize {
    first + paragraph[..offset].matches('\n').count()
}

/// GitHub's anchor for a heading: its text as shown (no backticks), lower case, spaces to
/// hyphens, every other character but letters, digits, `-` and `_` dropped.
fn slug(heading: &str) -> String {
    heading
        .replace('`', "")
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a page's headings, with GitHub's `-1`, `-2` for repeated ones.
fn anchors(page: &Page) -> BTreeSet<String> {
    let mut seen: BTreeMap<String, usize> = BTreeMap::new();
    let mut out = BTreeSet::new();
    for h in page.headings() {
        let s = slug(&h);
        let n = seen.entry(s.clone()).or_insert(0);
        out.insert(if *n == 0 { s.clone() } else { format!("{s}-{n}") });
        *n += 1;
    }
    out
}

/// The targets of the inline links and images in a paragraph's prose, with their byte offsets.
fn link_targets(prose: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = prose[from..].find("](") {
        let start = from + k + 2;
        let Some(len) = prose[start..].find(')') else { break };
        let inside = prose[start..start + len].trim();
        // `(path "title")` and `(<path>)` name the same path.
        let target = inside.split_whitespace().next().unwrap_or("").trim_start_matches('<').trim_end_matches('>');
        out.push((from + k, target.to_string()));
        from = start + len;
    }
    out
}

/// `path` with `.` and `..` folded, without touching the file system.
fn normalise(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in path.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            other => out.push(other),
        }
    }
    out
}

/// What is wrong with one link target of `page` (None when it resolves).
fn check_link(page: &Path, target: &str, cache: &mut BTreeMap<PathBuf, BTreeSet<String>>) -> Option<String> {
    if target.is_empty() {
        return Some("an empty link target".into());
    }
    if target.contains("://") || target.starts_with("mailto:") {
        return None;
    }
    let (path, anchor) = match target.split_once('#') {
        Some((p, a)) => (p, Some(a)),
        None => (target, None),
    };
    let file = if path.is_empty() {
        page.to_path_buf()
    } else if let Some(from_root) = path.strip_prefix('/') {
        normalise(&root().join(from_root))
    } else {
        normalise(&page.parent().expect("a page lives in a folder").join(path))
    };
    if !file.starts_with(root()) {
        return Some(format!("`{target}` leads out of the repository"));
    }
    if !file.exists() {
        return Some(format!("`{target}`: no file {} (fix the path, or the file was moved)", rel(&file)));
    }
    let anchor = anchor.filter(|_| file.extension().is_some_and(|e| e == "md"))?;
    let known = cache.entry(file.clone()).or_insert_with(|| anchors(&Page::parse(&read(&file))));
    (!known.contains(anchor)).then(|| format!("`{target}`: {} has no heading whose anchor is `#{anchor}`", rel(&file)))
}

#[test]
fn every_relative_link_in_the_docs_resolves() {
    let mut cache = BTreeMap::new();
    let mut broken = Vec::new();
    let mut checked = 0;
    for page in linked_pages() {
        let parsed = Page::parse(&read(&page));
        for (first, paragraph) in &parsed.paragraphs {
            let (prose, _) = split_code_spans(paragraph);
            for (offset, target) in link_targets(&prose) {
                checked += 1;
                if let Some(why) = check_link(&page, &target, &mut cache) {
                    broken.push(format!("{}:{}: {why}", rel(&page), line_at(*first, paragraph, offset)));
                }
            }
        }
    }
    assert!(broken.is_empty(), "links that do not resolve:\n{}", broken.join("\n"));
    assert!(checked > 20, "only {checked} links found: the link reader is broken");
}

/// The subcommands `swarm --help` lists.
fn subcommands() -> BTreeSet<String> {
    let out = output_within(Command::new(SWARM).arg("--help"), TOOL_LIMIT);
    assert!(out.status.success(), "swarm --help failed: {}", String::from_utf8_lossy(&out.stderr));
    let help = String::from_utf8(out.stdout).expect("help is UTF-8");
    let names: BTreeSet<String> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect();
    assert!(names.contains("run") && names.len() > 10, "cannot read the subcommands from swarm --help:\n{help}");
    names
}

/// The word after each `swarm` that stands as a command in `code`: `swarm` as a word of its own
/// (after nothing, a space, `(`, `/` or `$`), then spaces, then a lower-case word.
fn commands_named(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(k) = code[from..].find("swarm") {
        let at = from + k;
        from = at + "swarm".len();
        let before = code[..at].chars().next_back();
        if !before.is_none_or(|c| c.is_whitespace() || matches!(c, '(' | '/' | '$')) {
            continue;
        }
        let rest = &code[from..];
        let word_at = rest.len() - rest.trim_start_matches([' ', '\t']).len();
        if word_at == 0 {
            continue;
        }
        let word: String =
            rest[word_at..].chars().take_while(|&c| c.is_ascii_alphanumeric() || c == '-' || c == '_').collect();
        if word.starts_with(|c: char| c.is_ascii_lowercase()) {
            out.push(word);
        }
    }
    out
}

/// A fenced code line without its shell comment (`#` at the start or after a space).
fn without_comment(line: &str) -> &str {
    let cut = line
        .char_indices()
        .find(|&(i, c)| c == '#' && (i == 0 || line[..i].ends_with(char::is_whitespace)))
        .map(|(i, _)| i);
    &line[..cut.unwrap_or(line.len())]
}

#[test]
fn every_swarm_subcommand_the_docs_name_exists() {
    let known = subcommands();
    let mut unknown = Vec::new();
    let mut named = BTreeSet::new();
    for page in guide_pages() {
        let parsed = Page::parse(&read(&page));
        let mut code: Vec<(usize, String)> = Vec::new();
        for (first, paragraph) in &parsed.paragraphs {
            let (_, spans) = split_code_spans(paragraph);
            code.extend(
                spans.into_iter().map(|(offset, span)| (line_at(*first, paragraph, offset), span.replace('\n', " "))),
            );
        }
        code.extend(parsed.code_lines.iter().map(|(n, l)| (*n, without_comment(l).to_string())));
        for (line, text) in code {
            for word in commands_named(&text) {
                if !known.contains(&word) {
                    unknown.push(format!(
                        "{}:{line}: `swarm {word}` is no subcommand of swarm (it has: {})",
                        rel(&page),
                        known.iter().cloned().collect::<Vec<_>>().join(", ")
                    ));
                }
                named.insert(word);
            }
        }
    }
    assert!(unknown.is_empty(), "the docs name subcommands that do not exist:\n{}", unknown.join("\n"));
    assert!(named.len() > 10, "only {named:?} found: the code reader is broken");
}

#[test]
fn slugs_are_githubs() {
    assert_eq!(
        slug("Watching a run: `run.mcap`, the live page, replay"),
        "watching-a-run-runmcap-the-live-page-replay"
    );
    assert_eq!(slug("`summary.json` (schema `swarm.summary.v1`)"), "summaryjson-schema-swarmsummaryv1");
    assert_eq!(slug("ROS 2 over rmw_zenoh"), "ros-2-over-rmw_zenoh");
    assert_eq!(
        slug("M23's Table 8 (seed 004 section 3.5), over 10 seeds"),
        "m23s-table-8-seed-004-section-35-over-10-seeds"
    );
    let page = Page::parse("# A\n\n```sh\n# not a heading\n```\n\n## A\n");
    assert_eq!(anchors(&page), BTreeSet::from(["a".to_string(), "a-1".to_string()]));
    assert_eq!(commands_named("cargo run -- run && target/release/swarm scale --json"), vec!["scale"]);
    assert_eq!(commands_named("swarm/exp1/** swarm_wire::Keys swarm-e2e (swarm tap)"), vec!["tap"]);
    assert_eq!(
        split_code_spans("a `b` c ``d ` e`` f").1.into_iter().map(|(_, s)| s).collect::<Vec<_>>(),
        vec!["b", "d ` e"]
    );
}

/// The words of a shell command line: split at blanks, quotes ('…', "…") and `<…>` placeholders
/// kept whole, their quotes taken off.
fn shell_words(line: &str) -> Vec<String> {
    let mut words = Vec::new();
    let (mut word, mut quote, mut any) = (String::new(), None::<char>, false);
    for c in line.chars() {
        match (quote, c) {
            (Some(q), c) if c == q => quote = None,
            (Some('<'), '>') => {
                word.push('>');
                quote = None;
            }
            (Some(_), c) => word.push(c),
            (None, '\'' | '"') => {
                quote = Some(c);
                any = true;
            }
            (None, '<') => {
                word.push('<');
                quote = Some('<');
                any = true;
            }
            (None, c) if c.is_whitespace() => {
                if any || !word.is_empty() {
                    words.push(std::mem::take(&mut word));
                }
                any = false;
            }
            (None, c) => word.push(c),
        }
    }
    if any || !word.is_empty() {
        words.push(word);
    }
    words
}

/// A shell assignment `NAME=value` or `NAME="value"` (the value unquoted), if `line` is one.
fn shell_assignment(line: &str) -> Option<(String, String)> {
    let (name, value) = line.split_once('=')?;
    let is_name = !name.is_empty() && name.chars().all(|c| c.is_ascii_uppercase() || c.is_ascii_digit() || c == '_');
    is_name.then(|| (name.to_string(), value.trim_matches(|c| c == '"' || c == '\'').to_string()))
}

/// Every `swarm` command line in the code blocks of the README and the guide, continuation
/// lines joined, comments and a leading `$ ` taken off, up to a pipe or `&&`, with the `$NAME`s
/// a line of the page's code assigned (`LOGIN="--user …"`) put in: `(page, line, words after
/// swarm)`.
fn documented_command_lines() -> Vec<(String, usize, Vec<String>)> {
    let mut out = Vec::new();
    for page in guide_pages() {
        let parsed = Page::parse(&read(&page));
        let mut vars: Vec<(String, String)> = Vec::new();
        let mut lines = parsed.code_lines.iter().peekable();
        while let Some((n, first)) = lines.next() {
            let mut text = without_comment(first).trim().to_string();
            while text.ends_with('\\') {
                text.pop();
                match lines.next() {
                    Some((_, next)) => text.push_str(without_comment(next)),
                    None => break,
                }
            }
            let mut text = text.trim().trim_start_matches("$ ").to_string();
            if let Some(assigned) = shell_assignment(&text) {
                vars.push(assigned);
                vars.sort_by_key(|(name, _)| std::cmp::Reverse(name.len()));
                continue;
            }
            for (name, value) in &vars {
                text = text.replace(&format!("${name}"), value);
            }
            let Some(rest) = text.strip_prefix("swarm ") else { continue };
            let rest = rest.split(['|', ';']).next().unwrap_or_default().split("&&").next().unwrap_or_default();
            out.push((rel(&page), *n, shell_words(rest)));
        }
    }
    out
}

#[test]
fn every_swarm_command_line_the_docs_show_parses() {
    let commands = documented_command_lines();
    assert!(commands.len() > 20, "only {} command lines found: the reader is broken", commands.len());
    let mut refused = Vec::new();
    for (page, line, words) in &commands {
        let o = output_within(Command::new(SWARM).args(words).env("SWARM_PARSE_ONLY", "1"), TOOL_LIMIT);
        if !o.status.success() {
            let said = String::from_utf8_lossy(&o.stderr);
            refused.push(format!(
                "{page}:{line}: `swarm {}`: {}",
                words.join(" "),
                said.lines().next().unwrap_or_default()
            ));
        }
    }
    assert!(refused.is_empty(), "command lines of the docs that swarm refuses:\n{}", refused.join("\n"));
    println!("{} command lines of the docs parse", commands.len());
}

#[test]
fn shell_words_keep_quotes_and_placeholders_whole() {
    assert_eq!(
        shell_words(r#"tap 'swarm/r/**' --password-file <run folder>/x "a b""#),
        ["tap", "swarm/r/**", "--password-file", "<run folder>/x", "a b"]
    );
    assert_eq!(shell_assignment(r#"LOGIN="--user a""#), Some(("LOGIN".into(), "--user a".into())));
    assert_eq!(shell_assignment("swarm tap --cfg a=b"), None);
}

/// A command line of the docs with its placeholders made real: the run ids the examples use
/// (`exp1`, `k1`, `R`, `<run id>`) become `run`, the hubs they connect to (`tcp/10.0.0.5:7447`,
/// `tcp/127.0.0.1:40291`, `E`) `loc`, `creds/` and `runs/{id}/credentials/` the run's own
/// credentials folder, `runs/{id}` (or `runs/<run id>`) `folder`.
struct Placeholders<'a> {
    run: &'a str,
    loc: &'a str,
    creds: &'a Path,
    folder: &'a Path,
}

impl Placeholders<'_> {
    const RUNS: [&'static str; 4] = ["exp1", "k1", "R", "<run id>"];
    const HUBS: [&'static str; 3] = ["tcp/10.0.0.5:7447", "tcp/127.0.0.1:40291", "E"];

    fn fill(&self, words: &[String]) -> Vec<String> {
        let mut out = Vec::with_capacity(words.len());
        for (i, w) in words.iter().enumerate() {
            let after = |flag: &str| i > 0 && words[i - 1] == flag;
            let filled = if after("--run") && Self::RUNS.contains(&w.as_str()) {
                self.run.to_string()
            } else if after("--connect") && Self::HUBS.contains(&w.as_str()) {
                self.loc.to_string()
            } else {
                self.path(w)
            };
            out.push(filled);
        }
        out
    }

    fn path(&self, w: &str) -> String {
        for id in Self::RUNS {
            if let Some(rest) = w.strip_prefix(&format!("swarm/{id}/")) {
                return format!("swarm/{}/{rest}", self.run);
            }
            if let Some(rest) = w.strip_prefix(&format!("runs/{id}/credentials/")) {
                return self.creds.join(rest).to_str().expect("utf8").to_string();
            }
            if w == format!("runs/{id}") {
                return self.folder.to_str().expect("utf8").to_string();
            }
        }
        match w.strip_prefix("creds/") {
            Some(rest) => self.creds.join(rest).to_str().expect("utf8").to_string(),
            None => w.to_string(),
        }
    }
}

/// What a command of the docs did: its exit (`None`: it was still streaming when stopped, after
/// `lines` of output), its standard output lines and its standard error.
struct Ran {
    exit: Option<std::process::ExitStatus>,
    lines: Vec<String>,
    stderr: String,
}

/// Runs `swarm words` until it exits or has printed `enough` lines (a tap with no `--count`
/// streams for as long as the run lasts); stopped after `limit` either way.
fn run_streaming(words: &[String], log: &Path, enough: usize, limit: std::time::Duration) -> Ran {
    use std::io::{BufRead, BufReader};
    let err = std::fs::File::create(log).expect("log");
    let mut child = Command::new(SWARM)
        .args(words)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::piped())
        .stderr(err)
        .spawn()
        .expect("spawn swarm");
    let stdout = child.stdout.take().expect("stdout");
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    let start = std::time::Instant::now();
    let mut lines = Vec::new();
    let exit = loop {
        while let Ok(l) = rx.try_recv() {
            lines.push(l);
        }
        if let Some(status) = child.try_wait().expect("try_wait") {
            std::thread::sleep(std::time::Duration::from_millis(100));
            lines.extend(rx.try_iter());
            break Some(status);
        }
        if lines.len() >= enough || start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    Ran { exit, lines, stderr: std::fs::read_to_string(log).unwrap_or_default() }
}

/// The docs' commands for a running run, run as written against a real one (forest-5 in real
/// time under `swarm run`, with the login the docs give and their placeholders made real, see
/// [`Placeholders`]): every `swarm tap`, `keys`, `netem`, `credentials`, `record` and `recover`
/// line of a code block. A tap must print a message, a bounded command must exit 0; `swarm record`
/// is killed after 8 s (as a crash) and the `swarm recover` line makes its folder whole. The lines
/// that start pieces of another run (`hub`, `agent`, `router`) or whole runs and studies (`run`,
/// `scale`, `fuzz`) are only parsed (`every_swarm_command_line_the_docs_show_parses`): each
/// flies minutes, and the flight tests run them.
#[test]
fn the_docs_commands_for_a_live_run_work_as_written() {
    let dir = tempfile::tempdir().expect("tempdir");
    let folder = dir.path().join("run");
    let run = common::run_id("docslive");
    let folder_s = folder.to_str().expect("utf8").to_string();
    let _swarm = common::Proc::start(
        &["run", "forest-5", "--time-mode", "realtime", "--run", &run, "--out", &folder_s, "--quiet", "--no-mcap"],
        &dir.path().join("run.log"),
    );
    let loc = common::hub_locator(&folder);
    let creds = folder.join("credentials");
    let recorded = dir.path().join("recorded");
    let lines: Vec<_> = documented_command_lines()
        .into_iter()
        .filter(|(_, _, w)| ["tap", "keys", "netem", "credentials", "record", "recover"].contains(&w[0].as_str()))
        .collect();
    // record before recover: the folder recover mends is the one record was killed in.
    let (mut record, rest): (Vec<_>, Vec<_>) = lines.into_iter().partition(|(_, _, w)| w[0] == "record");
    let (recover, others): (Vec<_>, Vec<_>) = rest.into_iter().partition(|(_, _, w)| w[0] == "recover");
    record.extend(recover);
    let mut failed = Vec::new();
    let mut ran = BTreeMap::<String, usize>::new();
    for (i, (page, line, words)) in others.iter().chain(&record).enumerate() {
        let is = |c: &str| words[0] == c;
        let p = Placeholders {
            run: &run,
            loc: &loc,
            creds: &creds,
            folder: if is("record") || is("recover") { &recorded } else { &folder },
        };
        let mut filled = p.fill(words);
        if is("credentials") {
            // Its own folder, not the run's.
            if let Some(at) = filled.iter().position(|w| w == "--out") {
                filled[at + 1] = dir.path().join("made-creds").to_str().expect("utf8").to_string();
            }
        }
        let log = dir.path().join(format!("cmd-{i}.log"));
        let r = if is("record") {
            run_streaming(&filled, &log, usize::MAX, std::time::Duration::from_secs(8))
        } else if is("tap") {
            // A tap with no `--count` streams for as long as the run lasts: its first message will do.
            run_streaming(&filled, &log, 1, std::time::Duration::from_secs(60))
        } else {
            run_streaming(&filled, &log, usize::MAX, std::time::Duration::from_secs(60))
        };
        let ok = match (&r.exit, words[0].as_str()) {
            (Some(status), _) => status.success(),
            (None, "tap") => !r.lines.is_empty(),
            (None, "record") => true,
            (None, _) => false,
        };
        if !ok {
            failed.push(format!(
                "{page}:{line}: `swarm {}` ({:?}, {} lines): {}",
                filled.join(" "),
                r.exit,
                r.lines.len(),
                r.stderr.lines().last().unwrap_or_default()
            ));
        }
        *ran.entry(words[0].clone()).or_default() += 1;
    }
    assert!(failed.is_empty(), "commands of the docs that fail against a live run:\n{}", failed.join("\n"));
    for c in ["tap", "keys", "netem", "credentials", "record", "recover"] {
        assert!(ran.contains_key(c), "no `swarm {c}` line was found in the docs: {ran:?}");
    }
    let s = common::summary(&recorded);
    assert!(s["ticks"].as_u64().unwrap_or(0) > 0, "the recovered recording holds ticks: {s:#}");
    println!("the docs' live-run commands work as written: {ran:?}");
}
