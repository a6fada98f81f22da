//! The names of the `--out` directory's files.

/// The Markdown report's file name in the output directory.
pub const REPORT_FILE: &str = "diagnosis.md";
/// The model file's name in the output directory.
pub const MODEL_FILE: &str = "model.toml";
/// Figure of held-out residuals vs R/R′ (without extension).
pub const RESIDUALS_FIGURE: &str = "residuals-vs-radius";
/// Figure of growth through the turn vs R/R′ (without extension).
pub const GROWTH_FIGURE: &str = "growth-vs-radius";
