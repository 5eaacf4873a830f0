//! A consist file: the ids of a train's bogies in running order, so that a train pass's
//! wheels join their histories. CSV with the header `bogie_id` and one id a line; `#` lines
//! are comments.
//!
//! ```text
//! # train 4711, 2026-11-26
//! bogie_id
//! 4711-1
//! 4711-2
//! ```

use crate::identify::input::measurement::check_bogie_id;
use crate::identify::IdentifyError;
use std::path::Path;

/// The bogie ids of a consist file, checked against the pass's `bogies`.
pub(crate) fn read_consist(
    path: &Path,
    text: &str,
    bogies: usize,
) -> Result<Vec<String>, IdentifyError> {
    let bad = |line: usize, message: String| IdentifyError::Measurement {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut header = false;
    let mut ids: Vec<String> = Vec::new();
    let mut last_line = 0;
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        last_line = i + 1;
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if !header {
            if line != "bogie_id" {
                return Err(bad(
                    i + 1,
                    format!("the header must be `bogie_id`, found `{line}`"),
                ));
            }
            header = true;
            continue;
        }
        let id = check_bogie_id(line).map_err(|e| bad(i + 1, e))?;
        if ids.iter().any(|x| x == id) {
            return Err(bad(
                i + 1,
                format!("bogie id `{id}` is named twice: a bogie is measured once a pass"),
            ));
        }
        if ids.len() == bogies {
            return Err(bad(
                i + 1,
                format!("more bogie ids than the {bogies} bogies the triggers give"),
            ));
        }
        ids.push(id.to_string());
    }
    if !header {
        return Err(bad(last_line.max(1), "no `bogie_id` header".into()));
    }
    if ids.len() != bogies {
        return Err(bad(
            last_line,
            format!(
                "{} bogie ids for the {bogies} bogies the triggers give",
                ids.len()
            ),
        ));
    }
    Ok(ids)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_consist_names_every_bogie_once() {
        let p = Path::new("c.csv");
        let ok = read_consist(p, "# t\nbogie_id\nA-1\nA-2\n", 2).unwrap();
        assert_eq!(ok, vec!["A-1", "A-2"]);
        let e = |t: &str, n| read_consist(p, t, n).unwrap_err().to_string();
        assert!(e("bogie_id\nA-1\n", 2).contains("1 bogie ids for the 2 bogies"));
        assert!(e("bogie_id\nA-1\nA-1\n", 2).contains("named twice"));
        assert!(e("bogie\nA-1\n", 1).contains("the header must be `bogie_id`"));
        assert!(e("bogie_id\nA/1\n", 1).contains("holds `/`"));
        assert!(e("bogie_id\nA\nB\nC\n", 2).contains("more bogie ids than the 2"));
        assert!(e("bogie_id\nA\nB\nC\n", 2).contains("line 4"));
    }
}
