//! A21Params: parameters of the A21 controller (seed 003 section III (Table I)).

use serde::{Deserialize, Serialize};

/// A21 parameters. Placeholder: filled in by the A21 work.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct A21Params {}
