//! Reading a scenario or an experiment file: TOML text into the schema's structs, every error
//! naming the file and the dotted path of the field (`serde_path_to_error`), with the line and
//! column of a syntax error. Every way in (a file, a `swarm run` argument, a built-in, text) ends
//! in [`Scenario::from_toml_str`], so each is parsed and then validated the same way.

use crate::{Scenario, Timeline, BUILTIN};
use std::path::Path;

/// A scenario could not be read or is invalid. Always names the source, the field and the problem.
#[derive(Debug, thiserror::Error)]
#[error("{source_name}: field `{field}`: {message}")]
pub struct ScenarioError {
    /// The file (or built-in name) the scenario came from.
    pub source_name: String,
    /// Dotted path of the offending field, or `(file)` when the file itself is the problem.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

impl ScenarioError {
    pub(crate) fn new(source_name: &str, field: impl Into<String>, message: impl Into<String>) -> Self {
        ScenarioError { source_name: source_name.to_string(), field: field.into(), message: message.into() }
    }
}

/// Deserializes TOML, naming the dotted path of the field that fails.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str, source_name: &str) -> Result<T, ScenarioError> {
    let de = toml::Deserializer::new(text);
    serde_path_to_error::deserialize(de).map_err(|e| {
        let field = e.path().to_string();
        let field = if field == "." { "(top level)".to_string() } else { field };
        let inner = e.into_inner();
        // A syntax error has no field and, for some inputs, no message of its own: the full text
        // then says where (line, column) and what.
        let message = match inner.message().trim() {
            "" => inner.to_string().trim().to_string(),
            m => m.to_string(),
        };
        let message = match inner.span() {
            Some(span) => {
                let (line, column) = line_column(text, span.start);
                format!("{message} (line {line}, column {column})")
            }
            None => message,
        };
        ScenarioError::new(source_name, field, message)
    })
}

/// The 1-based line and column (in characters) of byte `at` of `text`.
fn line_column(text: &str, at: usize) -> (usize, usize) {
    let mut end = at.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let before = &text[..end];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

impl Timeline {
    /// Reads an experiment file: a TOML timeline of `[[netem]]` and `[[failures]]` tables. Errors
    /// name the file and the field; ids are checked against a scenario by
    /// [`Scenario::check_timeline`].
    pub fn from_file(path: &Path) -> Result<Timeline, ScenarioError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ScenarioError::new(&name, "(file)", format!("cannot read: {e}")))?;
        parse_toml(&text, &name)
    }
}

impl Scenario {
    /// Reads an experiment file (see [`Timeline::from_file`]) and checks it against this
    /// scenario. Errors name the file and the field.
    pub fn timeline_from_file(&self, path: &Path) -> Result<Timeline, ScenarioError> {
        let t = Timeline::from_file(path)?;
        let name = path.display().to_string();
        self.check_timeline(&t, false).map_err(|e| ScenarioError::new(&name, "(timeline)", e))?;
        Ok(t)
    }

    /// Reads and validates a scenario file.
    pub fn from_file(path: &Path) -> Result<Scenario, ScenarioError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path)
            .map_err(|e| ScenarioError::new(&name, "(file)", format!("cannot read: {e}")))?;
        Scenario::from_toml_str(&text, &name)
    }

    /// Resolves a `swarm run` argument: a path to a TOML file, or the name of a built-in.
    pub fn from_arg(arg: &str) -> Result<(Scenario, String), ScenarioError> {
        let path = Path::new(arg);
        if path.exists() {
            let text = std::fs::read_to_string(path)
                .map_err(|e| ScenarioError::new(arg, "(file)", format!("cannot read: {e}")))?;
            let sc = Scenario::from_toml_str(&text, arg)?;
            return Ok((sc, text));
        }
        match BUILTIN.iter().find(|(n, _)| *n == arg) {
            Some((_, text)) => Ok((Scenario::from_toml_str(text, &format!("builtin:{arg}"))?, text.to_string())),
            None => Err(ScenarioError::new(
                arg,
                "(file)",
                format!(
                    "no such file, and no built-in scenario of that name (built-ins: {})",
                    BUILTIN.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
                ),
            )),
        }
    }

    /// Parses and validates scenario TOML; `source_name` is used in error messages.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Scenario, ScenarioError> {
        let sc: Scenario = parse_toml(text, source_name)?;
        sc.validate().map_err(|(field, msg)| ScenarioError::new(source_name, field, msg))?;
        Ok(sc)
    }
}
