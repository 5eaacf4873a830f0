//! A site's good-wheel passes made ready for calibration: each CSV read and checked, put on
//! the calibration's speed, aligned by its laser trigger and cut to the bank's sensor windows.
//! A pass that cannot be used is set aside with the reason (never silently).

use crate::bank::schema::{sensor_axes, SensorAxis};
use crate::identify::Measurement;
use crate::model::CheckedCalibration;
use std::path::{Path, PathBuf};

/// The most passes one calibration reads (a night of traffic at a busy site).
pub const MAX_PASSES: usize = 20_000;

/// One pass on the calibration's windows.
#[derive(Debug, Clone)]
pub struct SitePass {
    /// Where it was read from.
    pub path: PathBuf,
    /// Per sensor (the calibration's order), the series in kN on its window.
    pub series_kn: Vec<Vec<f64>>,
    /// The wheel's static load known from elsewhere (kN), if its record gives one.
    pub reference_wheel_load_kn: Option<f64>,
}

/// The passes read, and those set aside with why.
#[derive(Debug, Clone, Default)]
pub struct Passes {
    /// Usable passes, in file-name order.
    pub passes: Vec<SitePass>,
    /// `(file, reason)` of each pass set aside.
    pub skipped: Vec<(String, String)>,
}

/// Errors reading a site's passes.
#[derive(Debug, thiserror::Error)]
pub enum PassesError {
    /// The folder could not be listed.
    #[error("listing {path}")]
    Folder {
        /// The folder.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// More passes than [`MAX_PASSES`].
    #[error("{path} holds {count} CSV files, more than the {MAX_PASSES} one calibration reads; give a folder of one night's passes")]
    TooMany {
        /// The folder.
        path: PathBuf,
        /// How many.
        count: usize,
    },
}

/// Reads every `*.csv` in `dir` (file-name order) for calibration `cal`.
pub fn read_folder(dir: &Path, cal: &CheckedCalibration) -> Result<Passes, PassesError> {
    let folder = |source| PassesError::Folder {
        path: dir.to_path_buf(),
        source,
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(folder)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    if files.len() > MAX_PASSES {
        return Err(PassesError::TooMany {
            path: dir.to_path_buf(),
            count: files.len(),
        });
    }
    Ok(read_files(&files, cal))
}

/// Reads `files` (at most [`MAX_PASSES`] are read; the rest set aside, named) for
/// calibration `cal`.
pub fn read_files(files: &[PathBuf], cal: &CheckedCalibration) -> Passes {
    let axes = sensor_axes(cal);
    let mut out = Passes::default();
    for (i, f) in files.iter().enumerate() {
        let read = if i < MAX_PASSES {
            read_pass(f, cal, &axes)
        } else {
            Err(format!(
                "beyond the {MAX_PASSES} passes one calibration reads"
            ))
        };
        match read {
            Ok(p) => out.passes.push(p),
            Err(why) => out.skipped.push((f.display().to_string(), why)),
        }
    }
    out
}

/// Where the record of a pass stored as `stored` is now: there, or in the `done/` folder
/// beside it where `watch` moves each pass it answered.
pub fn record_now(stored: &Path) -> PathBuf {
    let moved = match (stored.parent(), stored.file_name()) {
        (Some(dir), Some(name)) => dir.join("done").join(name),
        _ => return stored.to_path_buf(),
    };
    if !stored.exists() && moved.exists() {
        moved
    } else {
        stored.to_path_buf()
    }
}

/// One pass on `axes`, or why it cannot be used.
// Err(String): why the pass is skipped, listed beside its path in the report (never fatal).
pub fn read_pass(
    path: &Path,
    cal: &CheckedCalibration,
    axes: &[SensorAxis],
) -> Result<SitePass, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("reading it: {e}"))?;
    let m =
        Measurement::from_csv(path, &text, cal.output.sample_rate_hz).map_err(|e| e.to_string())?;
    SitePass::of(&m, cal, axes)
}

impl SitePass {
    /// The pass `m` on `axes` (its path, its reference load if it gives one), or why it
    /// cannot be used.
    // Err(String): why the pass is skipped, listed beside its path in the report (never fatal).
    pub fn of(
        m: &Measurement,
        cal: &CheckedCalibration,
        axes: &[SensorAxis],
    ) -> Result<SitePass, String> {
        Ok(SitePass {
            path: m.path.clone(),
            series_kn: on_windows(m, cal, axes)?,
            reference_wheel_load_kn: m.reference_wheel_load_kn,
        })
    }
}

/// The series of `m` on `axes` (every sensor of the calibration must be in the record).
// Err(String): why the pass is skipped, listed beside its path in the report (never fatal).
pub fn on_windows(
    m: &Measurement,
    cal: &CheckedCalibration,
    axes: &[SensorAxis],
) -> Result<Vec<Vec<f64>>, String> {
    let m = m
        .at_bank_speed(cal.run.speed_km_per_h)
        .map_err(|e| e.to_string())?;
    let Some(trigger) = m.laser_trigger_s else {
        return Err("no `# laser_trigger_s` line: calibration aligns passes by the trigger (a shape fitted by cross-correlation would align on the very track it calibrates)".into());
    };
    let t_bank =
        (cal.sensors.laser_trigger_m - cal.run.leading_wheel_start_m) / cal.speed_m_per_s();
    let shift = t_bank - trigger;
    axes.iter()
        .map(|a| {
            let mi = m
                .sensors
                .iter()
                .position(|n| *n == a.name)
                .ok_or_else(|| format!("no `{}_kn` column", a.name))?;
            m.on_window(mi, a, shift).map_err(|e| e.to_string())
        })
        .collect()
}
