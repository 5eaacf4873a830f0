//! The progress observer of long jobs (bank generation, the diagnosis' local bank): it
//! attaches to the library from outside ([`GenerateObserver`]) and never touches the physics.

use std::io::IsTerminal;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;
use wheelflat::bank::GenerateObserver;

/// Progress of a bank generation: an indicatif bar on a terminal, plain periodic log lines
/// otherwise (cron, batch schedulers).
pub(super) struct Progress {
    bar: Option<indicatif::ProgressBar>,
    done: AtomicUsize,
    total: AtomicUsize,
    /// When the current bank (a family's current member) started.
    started: Mutex<Instant>,
    last_log: Mutex<Instant>,
    /// Seconds spent building the tables a pass needs (`bank::derived`), all banks together.
    tables_s: Mutex<f64>,
}

impl Progress {
    /// Log lines only, until [`Progress::with_terminal`] adds a bar.
    pub fn new() -> Progress {
        Progress {
            bar: None,
            done: AtomicUsize::new(0),
            total: AtomicUsize::new(0),
            started: Mutex::new(Instant::now()),
            last_log: Mutex::new(Instant::now()),
            tables_s: Mutex::new(0.0),
        }
    }

    /// Draws a bar instead of log lines when standard error is a terminal.
    pub fn with_terminal(mut self) -> Progress {
        if std::io::stderr().is_terminal() {
            let bar = indicatif::ProgressBar::new(0);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} instances  {per_sec}  ETA {eta}",
                )
                .expect("valid template"),
            );
            self.bar = Some(bar);
        }
        self
    }

    /// Removes the bar, if any, once the job is over.
    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }

    /// Seconds spent building the tables a pass needs so far.
    pub fn tables_seconds(&self) -> f64 {
        *self.tables_s.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn log_line(&self) -> String {
        let done = self.done.load(Ordering::Relaxed);
        let total = self.total.load(Ordering::Relaxed).max(1);
        let secs = self
            .started
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .elapsed()
            .as_secs_f64();
        let rate = done as f64 / secs.max(1e-9);
        let eta = (total - done.min(total)) as f64 / rate.max(1e-9);
        format!(
            "bank: {done}/{total} instances ({:.1} %), {rate:.0} instances/s, ETA {:.0} s",
            100.0 * done as f64 / total as f64,
            eta
        )
    }
}

impl GenerateObserver for Progress {
    fn started(&self, to_simulate: usize, already_done: usize) {
        // Each bank (each member of a family) counts from zero.
        self.total.store(to_simulate, Ordering::Relaxed);
        self.done.store(0, Ordering::Relaxed);
        *self.started.lock().unwrap_or_else(|e| e.into_inner()) = Instant::now();
        if already_done > 0 {
            eprintln!("bank: resuming, {already_done} instances already on disk");
        }
        if let Some(b) = &self.bar {
            b.reset();
            b.set_length(to_simulate as u64);
        } else if to_simulate > 0 {
            eprintln!("bank: simulating {to_simulate} instances");
        }
    }

    fn instance_done(&self) {
        self.done.fetch_add(1, Ordering::Relaxed);
        if let Some(b) = &self.bar {
            b.inc(1);
            return;
        }
        let mut last = self.last_log.lock().unwrap_or_else(|e| e.into_inner());
        if last.elapsed().as_secs_f64() >= 10.0 {
            *last = Instant::now();
            eprintln!("{}", self.log_line());
        }
    }

    fn file_written(&self, name: &str) {
        match &self.bar {
            Some(b) => b.println(format!("wrote {name}")),
            None => eprintln!("bank: wrote {name}"),
        }
    }

    fn table_built(&self, what: &str, file: &str, seconds: f64) {
        *self.tables_s.lock().unwrap_or_else(|e| e.into_inner()) += seconds;
        let line = format!("built {file}: {what} ({seconds:.1} s)");
        match &self.bar {
            Some(b) => b.println(line),
            None => eprintln!("bank: {line}"),
        }
    }
}
