//! The files: the JSON ([`write_json`]) and the `--out` directory ([`write_out_dir`]), each
//! file written atomically.

use super::markdown::markdown;
use super::names::{GROWTH_FIGURE, MODEL_FILE, REPORT_FILE, RESIDUALS_FIGURE};
use super::tables::added_effect;
use crate::diagnose::baseline::BaselineError;
use crate::diagnose::calibration::Calibration;
use crate::diagnose::cv;
use crate::diagnose::features::TurnRow;
use crate::diagnose::model_file::ModelFileError;
use crate::diagnose::{figures, model_file, Diagnosis};
use crate::log::AtomicWriteError;
use crate::log::{write_atomically, Existing};
use crate::plan::ModelError;
use crate::plot::render_figure;
use crate::plot::PlotError;
use model_core::Rover;
use std::fmt::Write as _;
use std::io::{self, Write as _};
use std::path::{Path, PathBuf};

/// Why an output was not written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// Recomputing the held-out residuals for the figures failed.
    #[error(transparent)]
    Baseline(#[from] BaselineError),
    /// The scheme of the diagnosis has fewer than 2 groups (cannot happen for a diagnosis).
    #[error("no held-out residuals to draw")]
    NothingToHoldOut,
    /// A figure could not be drawn or written.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// The plan model could not be made.
    #[error("model file: {0}")]
    ModelFile(#[from] ModelFileError),
    /// The plan model could not be written as TOML.
    #[error("model file: {0}")]
    Model(#[from] ModelError),
    /// The output directory could not be created.
    #[error("{}: {source}", path.display())]
    Dir {
        /// The directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: io::Error,
    },
    /// A file could not be written (a previous file of that name is untouched).
    #[error(transparent)]
    Write(#[from] AtomicWriteError<io::Error>),
}

/// Writes `d.to_json()` (pretty) to `path`.
pub fn write_json(path: &Path, d: &Diagnosis) -> Result<(), ReportError> {
    write_atomically(path, Existing::Replace, |w| {
        serde_json::to_writer_pretty(&mut *w, &d.to_json()).map_err(io::Error::from)?;
        writeln!(w)
    })?;
    Ok(())
}

/// Writes the figures, `model.toml` and `diagnosis.md` into `dir` (created if missing) and
/// returns the files written. `rows` and `calibration` must be the diagnosis' inputs.
pub fn write_out_dir(
    dir: &Path,
    rover: &Rover,
    d: &Diagnosis,
    rows: &[TurnRow],
    calibration: Calibration<'_>,
) -> Result<Vec<PathBuf>, ReportError> {
    let calibration = d.fitted_with(calibration);
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Dir {
        path: dir.to_owned(),
        source,
    })?;
    let mut files = Vec::new();
    let mut captions = Vec::new();
    let mut draw = |name: &str, caption: String, figure: &crate::plot::Figure| {
        for ext in ["png", "svg"] {
            let path = dir.join(format!("{name}.{ext}"));
            render_figure(figure, &path)?;
            files.push(path);
        }
        captions.push((caption, format!("{name}.png")));
        Ok::<(), ReportError>(())
    };
    if let Some(effect) = added_effect(d) {
        // "After" is the diagnosed model: the named effect and its stepwise secondaries (or the
        // best candidate when none is named).
        let mut effects = d.model_effects();
        if effects.is_empty() {
            effects.push(effect);
        }
        let label = effects
            .iter()
            .map(|e| e.id())
            .collect::<Vec<_>>()
            .join(" + ");
        // The figure names the baseline the residuals are against.
        let baseline = if d.baseline.structure.copper_loss {
            "hard-ground model + copper loss"
        } else {
            "hard-ground model"
        };
        let before = cv::heldout_residuals(rover, rows, d.scheme, &[], calibration)?
            .ok_or(ReportError::NothingToHoldOut)?;
        let after = cv::heldout_residuals(rover, rows, d.scheme, &effects, calibration)?
            .ok_or(ReportError::NothingToHoldOut)?;
        draw(
            RESIDUALS_FIGURE,
            format!(
                "Held-out residual of every turn vs R/R′ ({}), before and after adding {label}; \
                 bars: each regime's mean gap with its 95 % interval",
                d.scheme.id()
            ),
            &figures::residuals_vs_radius(rover, rows, &before, &after, baseline, &label, &d.gaps),
        )?;
    }
    draw(
        GROWTH_FIGURE,
        "Power growth through each turn (second half − first half) vs R/R′; bars: each regime's \
         mean with its 95 % interval"
            .to_owned(),
        &figures::growth_vs_radius(rover, rows, &d.where_.phase_by_regime_side),
    )?;
    // A fitted base the planner cannot use (e.g. G < 0 when the plain split misfits a rover
    // with large motor losses) costs the model file, not the report.
    let (model, no_model) = match model_file::energy_model(rover, d, rows, calibration) {
        Ok(model) => (Some(model), None),
        Err(e) => (None, Some(e)),
    };
    if let Some(model) = &model {
        let text = model.to_toml()?;
        let path = dir.join(MODEL_FILE);
        write_atomically(&path, Existing::Replace, |w| w.write_all(text.as_bytes()))?;
        files.push(path);
    }
    let path = dir.join(REPORT_FILE);
    let mut md = markdown(d, &captions, model.as_ref());
    if let Some(e) = no_model {
        let _ = writeln!(
            md,
            "## Model file for `plan --model`\n\nNot written: the diagnosed model is not a valid \
             plan model ({e})."
        );
    }
    write_atomically(&path, Existing::Replace, |w| w.write_all(md.as_bytes()))?;
    files.push(path);
    Ok(files)
}
