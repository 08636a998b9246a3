//! P17Params: parameters of the P17 controller (seed 001 chapter 3 (Tables 1 and 2)).

use serde::{Deserialize, Serialize};

/// P17 parameters. Placeholder: filled in by the P17 work.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct P17Params {}
