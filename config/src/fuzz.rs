//! Property tests of the scenario and experiment parsers over bad input: never a panic, and a
//! refused file is answered with the file, the field and what is wrong.
//!
//! Inputs: arbitrary text; the built-in scenarios with bytes edited; the built-in scenarios
//! parsed as TOML and changed one field at a time (a value of the wrong type, an out-of-range
//! number such as NaN, infinities, negatives and huge values, a field removed, an unknown key
//! added to a table); an experiment file (the example scenario's `[[netem]]` and `[[failures]]`)
//! changed the same ways, and its JSON form (what `netem/rules` and `netem/add` carry) edited.
//! What parses must be whole: no NaN or infinite number reaches a validated scenario. Each
//! property prints how many inputs it tried; `PROPTEST_CASES=N` sets the count (default
//! [`DEFAULT_CASES`]).

use super::*;
use crate::parse::parse_toml;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use std::sync::atomic::{AtomicU64, Ordering};
use toml::Value;

/// Inputs per property when `PROPTEST_CASES` is not set: a parse takes tens of microseconds.
const DEFAULT_CASES: u32 = 1024;

/// The name every fuzzed file is parsed under; errors must carry it.
const FILE: &str = "fuzz.toml";

/// Runs `check` on inputs drawn from `strategy`, fails on the first failure or panic (after
/// shrinking), and prints the number of inputs tried.
fn fuzz<S: Strategy>(name: &str, strategy: S, check: impl Fn(S::Value) -> Result<(), TestCaseError>) {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(DEFAULT_CASES);
    let mut runner = TestRunner::new(Config { cases, failure_persistence: None, ..Config::default() });
    let tried = AtomicU64::new(0);
    let result = runner.run(&strategy, |v| {
        tried.fetch_add(1, Ordering::Relaxed);
        check(v)
    });
    if let Err(e) = result {
        panic!("fuzz {name}: {e}");
    }
    println!("fuzz {name}: {} inputs, no panic", tried.load(Ordering::Relaxed));
}

/// One step of a path into a TOML document.
#[derive(Debug, Clone, PartialEq)]
enum Seg {
    Key(String),
    Index(usize),
}

/// A path as the parser's errors print it, with indices as `.i` so paths compare by segment.
fn dotted(path: &[Seg]) -> String {
    path.iter()
        .map(|s| match s {
            Seg::Key(k) => k.clone(),
            Seg::Index(i) => i.to_string(),
        })
        .collect::<Vec<_>>()
        .join(".")
}

/// An error's field in the same form (`a.b[0].c` -> `a.b.0.c`).
fn normalized(field: &str) -> String {
    field.replace('[', ".").replace(']', "")
}

/// Whether the error's field is the path, or lies on it (an enclosing table, or a value within).
fn on_path(field: &str, path: &[Seg]) -> bool {
    let (f, p) = (normalized(field), dotted(path));
    f == p || p.starts_with(&format!("{f}.")) || f.starts_with(&format!("{p}."))
}

/// Every path in `v`, with whether it is a table.
fn paths(v: &Value, at: &mut Vec<Seg>, out: &mut Vec<(Vec<Seg>, bool)>) {
    match v {
        Value::Table(t) => {
            out.push((at.clone(), true));
            for (k, child) in t {
                at.push(Seg::Key(k.clone()));
                paths(child, at, out);
                at.pop();
            }
        }
        Value::Array(a) => {
            out.push((at.clone(), false));
            for (i, child) in a.iter().enumerate() {
                at.push(Seg::Index(i));
                paths(child, at, out);
                at.pop();
            }
        }
        _ => out.push((at.clone(), false)),
    }
}

fn get_mut<'a>(v: &'a mut Value, path: &[Seg]) -> Option<&'a mut Value> {
    path.iter().try_fold(v, |v, s| match (s, v) {
        (Seg::Key(k), Value::Table(t)) => t.get_mut(k),
        (Seg::Index(i), Value::Array(a)) => a.get_mut(*i),
        _ => None,
    })
}

/// One change to a parsed document.
#[derive(Debug, Clone)]
enum Change {
    /// A leaf of another type: a number or bool becomes a string, a string a number.
    WrongType,
    /// A number out of any sane range (integers stay integers).
    OutOfRange(usize),
    /// The key removed from its table.
    Remove,
    /// An unknown key added to a table.
    Unknown,
}

const BAD_FLOATS: [f64; 8] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1.0, 0.0, -1e9, 1e300, -0.0];
const BAD_INTS: [i64; 6] = [-1, 0, i64::MAX, i64::MIN, 1 << 32, 1 << 40];

fn change() -> impl Strategy<Value = Change> {
    prop_oneof![
        Just(Change::WrongType),
        any::<usize>().prop_map(Change::OutOfRange),
        Just(Change::Remove),
        Just(Change::Unknown)
    ]
}

/// What a change did, for the assertion on the parser's answer.
#[derive(Debug)]
enum Applied {
    /// The document must be refused, with an error on this path.
    MustFailAt(Vec<Seg>),
    /// Either answer is fine; an error must still name the file and a field.
    Either,
}

/// Applies `c` to the `pick`-th eligible path of `doc`.
fn apply(doc: &mut Value, c: &Change, pick: usize) -> Applied {
    let mut all = Vec::new();
    paths(doc, &mut Vec::new(), &mut all);
    let eligible: Vec<Vec<Seg>> = match c {
        Change::Unknown => all.into_iter().filter(|p| p.1).map(|p| p.0).collect(),
        Change::Remove => all.into_iter().filter(|p| matches!(p.0.last(), Some(Seg::Key(_)))).map(|p| p.0).collect(),
        Change::WrongType | Change::OutOfRange(_) => {
            all.into_iter().filter(|p| !p.1 && !p.0.is_empty()).map(|p| p.0).collect()
        }
    };
    let Some(path) = eligible.get(pick % eligible.len().max(1)).cloned() else { return Applied::Either };
    match c {
        Change::Unknown => {
            let Some(Value::Table(t)) = get_mut(doc, &path) else { return Applied::Either };
            t.insert("zz_not_a_field".into(), Value::Integer(1));
            let mut at = path;
            at.push(Seg::Key("zz_not_a_field".into()));
            Applied::MustFailAt(at)
        }
        Change::Remove => {
            let (Some(Seg::Key(k)), parent) = (path.last(), &path[..path.len() - 1]) else { return Applied::Either };
            if let Some(Value::Table(t)) = get_mut(doc, parent) {
                t.remove(k);
            }
            Applied::Either
        }
        Change::WrongType => {
            let Some(v) = get_mut(doc, &path) else { return Applied::Either };
            *v = match v {
                Value::String(_) => Value::Integer(7),
                Value::Array(_) => Value::Boolean(true),
                _ => Value::String("oops".into()),
            };
            Applied::MustFailAt(path)
        }
        Change::OutOfRange(i) => {
            match get_mut(doc, &path) {
                Some(v @ Value::Float(_)) => *v = Value::Float(BAD_FLOATS[i % BAD_FLOATS.len()]),
                Some(v @ Value::Integer(_)) => *v = Value::Integer(BAD_INTS[i % BAD_INTS.len()]),
                _ => {}
            }
            Applied::Either
        }
    }
}

/// Every float in a value (of a parsed scenario, serialized back) is finite.
fn non_finite(v: &Value, at: &mut Vec<Seg>, out: &mut Vec<String>) {
    match v {
        Value::Float(f) if !f.is_finite() => out.push(dotted(at)),
        Value::Table(t) => t.iter().for_each(|(k, c)| {
            at.push(Seg::Key(k.clone()));
            non_finite(c, at, out);
            at.pop();
        }),
        Value::Array(a) => a.iter().enumerate().for_each(|(i, c)| {
            at.push(Seg::Index(i));
            non_finite(c, at, out);
            at.pop();
        }),
        _ => {}
    }
}

/// The parser's answer obeys the contract: an error names [`FILE`], a field and a reason; a
/// parsed scenario holds only finite numbers.
fn check_scenario(r: &Result<Scenario, ScenarioError>) -> Result<(), TestCaseError> {
    match r {
        Err(e) => {
            prop_assert_eq!(&e.source_name, FILE);
            prop_assert!(!e.field.is_empty() && !e.message.is_empty(), "{}", e);
            prop_assert!(e.to_string().starts_with(FILE), "{}", e);
        }
        Ok(sc) => {
            let v = Value::try_from(sc).map_err(|e| TestCaseError::fail(format!("serializes: {e}")))?;
            let mut bad = Vec::new();
            non_finite(&v, &mut Vec::new(), &mut bad);
            prop_assert!(bad.is_empty(), "a validated scenario holds non-finite numbers at {:?}", bad);
        }
    }
    Ok(())
}

fn builtin_docs() -> Vec<(&'static str, Value)> {
    BUILTIN.iter().map(|(n, text)| (*n, text.parse::<Value>().expect("built-ins are TOML"))).collect()
}

/// The example scenario's timeline, as an experiment file's document.
fn experiment_doc() -> Value {
    let example: Value = builtin_text("example").parse().expect("toml");
    let mut t = toml::Table::new();
    for k in ["netem", "failures"] {
        t.insert(k.into(), example.get(k).cloned().expect("example has [[netem]] and [[failures]]"));
    }
    Value::Table(t)
}

fn builtin_text(name: &str) -> &'static str {
    BUILTIN.iter().find(|(n, _)| *n == name).map(|(_, t)| *t).expect("built-in")
}

/// `text` with each `(index, byte, op)` applied: overwrite, cut there, or insert (index mod len).
fn edited(text: &str, edits: &[(usize, u8, u8)]) -> Vec<u8> {
    let mut bytes = text.as_bytes().to_vec();
    for &(at, b, op) in edits {
        if bytes.is_empty() {
            break;
        }
        let at = at % bytes.len();
        match op {
            0 => bytes[at] = b,
            1 => bytes.truncate(at),
            _ => bytes.insert(at, b),
        }
    }
    bytes
}

#[test]
fn arbitrary_text_is_refused_with_the_file_named() {
    let text = prop_oneof![
        ".{0,400}",
        prop::collection::vec(any::<u8>(), 0..400).prop_map(|b| String::from_utf8_lossy(&b).into_owned())
    ];
    fuzz("scenario parser (arbitrary text)", text, |t| check_scenario(&Scenario::from_toml_str(&t, FILE)));
}

#[test]
fn builtins_with_bytes_edited() {
    let edit = (any::<usize>(), any::<u8>(), 0u8..3);
    let strategy = (0..BUILTIN.len(), prop::collection::vec(edit, 1..6));
    fuzz("scenario parser (built-ins, bytes edited)", strategy, |(i, edits)| {
        let bytes = edited(BUILTIN[i].1, &edits);
        check_scenario(&Scenario::from_toml_str(&String::from_utf8_lossy(&bytes), FILE))
    });
}

#[test]
fn builtins_with_one_field_changed() {
    let docs = builtin_docs();
    let strategy = (0..docs.len(), change(), any::<usize>());
    fuzz("scenario parser (built-ins, one field changed)", strategy, |(i, c, pick)| {
        let mut doc = docs[i].1.clone();
        let applied = apply(&mut doc, &c, pick);
        let text = toml::to_string(&doc).map_err(|e| TestCaseError::fail(format!("{e}")))?;
        let r = Scenario::from_toml_str(&text, FILE);
        check_scenario(&r)?;
        if let Applied::MustFailAt(path) = applied {
            let e = r
                .as_ref()
                .err()
                .ok_or_else(|| TestCaseError::fail(format!("{} {c:?} at {} was accepted", docs[i].0, dotted(&path))))?;
            prop_assert!(
                on_path(&e.field, &path),
                "{} {:?} at {}: the error names another field: {}",
                docs[i].0,
                c,
                dotted(&path),
                e
            );
        }
        Ok(())
    });
}

/// An experiment file: what parses is checked against the scenario (as `swarm run --experiment`
/// and `swarm netem apply` do), and neither step panics.
#[test]
fn experiment_files_with_one_field_changed() {
    let base = experiment_doc();
    let sc = builtin("example").expect("example");
    fuzz("experiment parser (one field changed)", (change(), any::<usize>()), |(c, pick)| {
        let mut doc = base.clone();
        let applied = apply(&mut doc, &c, pick);
        let text = toml::to_string(&doc).map_err(|e| TestCaseError::fail(format!("{e}")))?;
        match parse_toml::<Timeline>(&text, FILE) {
            Err(e) => {
                prop_assert_eq!(&e.source_name, FILE);
                prop_assert!(!e.field.is_empty() && !e.message.is_empty(), "{}", e);
                if let Applied::MustFailAt(path) = &applied {
                    prop_assert!(
                        on_path(&e.field, path),
                        "{:?} at {}: the error names another field: {}",
                        c,
                        dotted(path),
                        e
                    );
                }
            }
            Ok(t) => {
                prop_assert!(matches!(applied, Applied::Either), "{:?} was accepted: {:?}", c, applied);
                if let Err(e) = sc.check_timeline(&t, false) {
                    prop_assert!(e.starts_with("field `"), "a refused timeline names the field: {}", e);
                }
            }
        }
        Ok(())
    });
}

/// The JSON of a timeline, as `netem/rules` (agents) and `netem/add` (the hub) carry it, edited.
#[test]
fn timeline_json_edited() {
    let t: Timeline = parse_toml(&toml::to_string(&experiment_doc()).expect("toml"), FILE).expect("experiment parses");
    let json = serde_json::to_string(&t).expect("json");
    let sc = builtin("example").expect("example");
    let edit = (any::<usize>(), any::<u8>(), 0u8..3);
    fuzz("timeline JSON parser (edited)", prop::collection::vec(edit, 1..6), |edits| {
        let bytes = edited(&json, &edits);
        if let Ok(t) = serde_json::from_str::<Timeline>(&String::from_utf8_lossy(&bytes)) {
            let _ = sc.check_timeline(&t, true);
        }
        Ok(())
    });
}
