//! M23Params: parameters of the M23 controller (seed 004 chapter 3).

use serde::{Deserialize, Serialize};

/// M23 parameters. Placeholder: filled in by the M23 work.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct M23Params {}
