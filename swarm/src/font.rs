//! The font of the plotters charts (`swarm scale`, `swarm sweep-seeds`): DejaVu Sans embedded in
//! the binary and registered once under one family name, so text draws through ab_glyph the same
//! on every machine with no system font (no fontconfig).

use anyhow::{anyhow, Result};
use plotters::style::FontStyle;

/// The font family every chart text asks for.
pub const FAMILY: &str = "sans-serif";

/// Registers the embedded DejaVu Sans as [`FAMILY`] (once per process).
pub fn register() -> Result<()> {
    static ONCE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *ONCE.get_or_init(|| plotters::style::register_font(FAMILY, FontStyle::Normal, dejavu::sans::regular()).is_ok());
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the embedded font did not load"))
    }
}
