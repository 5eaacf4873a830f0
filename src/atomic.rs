//! Writing files so that a reader never sees a half-written one: every writer of the crate
//! (data files, reports, figures) goes through [`temporary_sibling`] and a rename.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The temporary sibling a file is written to before the rename:
/// `.<name>.tmp-<process id>-<call number>[.<extension>]` in the same folder, so that the
/// rename stays on one filesystem and is atomic, two writers of one file (threads or
/// processes) never share a temporary, and the extension is kept (the PNG encoder picks the
/// format from it). [`is_temporary`] recognises the name.
pub fn temporary_sibling(path: &Path) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let mut tmp = format!(".{name}.tmp-{}-{n}", std::process::id());
    if let Some(ext) = path.extension() {
        tmp.push('.');
        tmp.push_str(&ext.to_string_lossy());
    }
    path.with_file_name(tmp)
}

/// Whether the file name `name` is a temporary left by an interrupted writer: a
/// [`temporary_sibling`] name, or the older `.<name>.tmp` form.
pub fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && (name.ends_with(".tmp") || name.contains(".tmp-"))
}

/// Writes `bytes` to `path` through [`temporary_sibling`], synced to disk, then renamed into
/// place. On error the temporary is removed and `path` is untouched.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let tmp = temporary_sibling(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_whole_files_and_leaves_nothing_on_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        write_atomically(&p, b"x,y\n").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"x,y\n");
        let missing = dir.path().join("no/such/dir/b.csv");
        assert!(write_atomically(&missing, b"z").is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names.len(), 1, "{names:?}");
    }

    #[test]
    fn temporaries_are_unique_hidden_siblings_that_keep_the_extension() {
        let p = Path::new("out/figure.png");
        let (a, b) = (temporary_sibling(p), temporary_sibling(p));
        assert_ne!(a, b, "two calls share a temporary");
        for t in [&a, &b] {
            assert_eq!(t.parent(), p.parent());
            assert_eq!(t.extension().and_then(|e| e.to_str()), Some("png"));
            let name = t.file_name().unwrap().to_str().unwrap();
            assert!(name.starts_with(".figure.png.tmp-"), "{name}");
            assert!(is_temporary(name), "{name}");
        }
        let bare = temporary_sibling(Path::new("CURRENT"));
        let name = bare.file_name().unwrap().to_str().unwrap();
        assert!(
            name.starts_with(".CURRENT.tmp-") && !name.ends_with('.'),
            "{name}"
        );
        assert!(is_temporary(".shard-00001-of-00003.parquet.tmp"));
        assert!(!is_temporary("manifest.json") && !is_temporary(".hidden"));
    }
}
