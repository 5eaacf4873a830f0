//! What a bank generation reports as it goes: the library calls an observer, the command line
//! attaches a progress bar or log lines to it (the physics never sees it).

/// Progress reports; the CLI attaches a progress bar or log lines.
pub trait GenerateObserver: Sync {
    /// Work is about to start: `to_simulate` instances in files still missing, `already_done`
    /// instances found complete on disk.
    fn started(&self, to_simulate: usize, already_done: usize);
    /// One instance finished (called from worker threads).
    fn instance_done(&self);
    /// A shard file was written.
    fn file_written(&self, name: &str);
    /// A table derived from the bank (`bank::derived`) was built: what it is, its file, the
    /// seconds it took.
    fn table_built(&self, _what: &str, _file: &str, _seconds: f64) {}
}

/// An observer that reports nothing.
pub struct Quiet;

impl GenerateObserver for Quiet {
    fn started(&self, _: usize, _: usize) {}
    fn instance_done(&self) {}
    fn file_written(&self, _: &str) {}
}
