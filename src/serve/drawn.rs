//! Reports drawn on request: a pass whose command wrote only `identification.json` (`watch`,
//! `identify` without `--report`) gets its figures and `report.html` drawn the first time its
//! page is asked for — into the server's own folder, never into the site's result folders
//! (the server writes nothing of the site's) — and kept for the [`MAX_DRAWN`] passes asked for
//! last.

use crate::identify::Identification;
use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Passes whose drawn reports are kept.
pub(crate) const MAX_DRAWN: usize = 100;

/// The server's folder of drawn reports, removed when the server stops.
pub(crate) struct Drawn {
    root: PathBuf,
    kept: Mutex<VecDeque<i64>>,
}

impl Drawn {
    /// A folder of its own under the system's temporary folder (made on first use).
    pub(crate) fn new() -> Drawn {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos());
        Drawn {
            root: std::env::temp_dir()
                .join(format!("wheelflat-serve-{}-{nanos}", std::process::id())),
            kept: Mutex::new(VecDeque::new()),
        }
    }

    /// The folder of pass `id`'s drawn report.
    pub(crate) fn dir(&self, id: i64) -> PathBuf {
        self.root.join(id.to_string())
    }

    /// Draws pass `id`'s report from `identification` (in its result folder) unless drawn
    /// already; its folder, or why it could not be drawn.
    // Err(String): shown on the pass page in place of the figures.
    pub(crate) fn draw(&self, id: i64, identification: &Path) -> Result<PathBuf, String> {
        let dir = self.dir(id);
        if dir.join("report.html").is_file() {
            return Ok(dir);
        }
        let text = crate::pass::input::read_text(
            identification,
            crate::pass::input::MAX_JSON_BYTES,
            "identification",
        )
        .map_err(|e| e.to_string())?;
        let id_json: Identification = serde_json::from_str(&text).map_err(|e| {
            format!(
                "{} is not an identification.json this wheelflat reads: {e}",
                identification.display()
            )
        })?;
        crate::report::identify::write_figures_and_html(&id_json, &dir)
            .map_err(|e| format!("the report could not be drawn: {e}"))?;
        if let Ok(mut kept) = self.kept.lock() {
            kept.retain(|&k| k != id);
            kept.push_back(id);
            while kept.len() > MAX_DRAWN {
                if let Some(old) = kept.pop_front() {
                    // Best effort: a folder that will not go stays until the server stops.
                    let _ = std::fs::remove_dir_all(self.dir(old));
                }
            }
        }
        Ok(dir)
    }
}

impl Drop for Drawn {
    fn drop(&mut self) {
        // Best effort: the folder is the server's own, under the temporary folder.
        let _ = std::fs::remove_dir_all(&self.root);
    }
}
