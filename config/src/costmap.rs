//! CostmapParams: parameters of the costmap of seed 004 (inflation and social layer).

use serde::{Deserialize, Serialize};

/// Placeholder: filled in by the work on the costmap of seed 004 (inflation and social layer).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CostmapParams {}
