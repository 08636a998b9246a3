//! UvdarParams: parameters of the onboard relative sensing of seed 003 (UVDAR).

use serde::{Deserialize, Serialize};

/// Placeholder: filled in by the work on the onboard relative sensing of seed 003 (UVDAR).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UvdarParams {}
