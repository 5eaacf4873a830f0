//! Why the alarms' configuration is refused, naming the file, the key or the webhook.

use std::path::PathBuf;

/// A configuration refused at start; no variant carries a secret.
#[derive(Debug, thiserror::Error)]
pub enum AlarmError {
    /// The configuration cannot be read.
    #[error("cannot read the alarms configuration {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Not UTF-8 text.
    #[error("alarms configuration {}: not UTF-8 text", path.display())]
    NotUtf8 {
        /// The file.
        path: PathBuf,
    },
    /// Not TOML, or a key this wheelflat does not know.
    #[error("alarms configuration {}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The TOML reader's words (the line and key).
        #[source]
        source: Box<toml::de::Error>,
    },
    /// A rule this wheelflat does not know.
    #[error("alarms configuration {}: unknown rule `{rule}` (the rules: urgent, class-rose, flat-grew, refusals, calibration-drift)", path.display())]
    UnknownRule {
        /// The file.
        path: PathBuf,
        /// The name given.
        rule: String,
    },
    /// A value out of its range.
    #[error("alarms configuration {}: {key} = {why}", path.display())]
    Value {
        /// The file.
        path: PathBuf,
        /// The key.
        key: &'static str,
        /// The value and its range.
        why: String,
    },
    /// No `[[webhook]]`.
    #[error("alarms configuration {}: no [[webhook]]: alarms would go nowhere", path.display())]
    NoDestination {
        /// The file.
        path: PathBuf,
    },
    /// Two webhooks of one name.
    #[error("alarms configuration {}: two webhooks named `{name}`", path.display())]
    DuplicateName {
        /// The file.
        path: PathBuf,
        /// The name.
        name: String,
    },
    /// A URL that may not receive alarms.
    #[error("alarms configuration {}: webhook `{name}`: url `{url}`: {why}", path.display())]
    Url {
        /// The file.
        path: PathBuf,
        /// The webhook.
        name: String,
        /// Its URL.
        url: String,
        /// Why not.
        why: String,
    },
    /// A secret file that cannot be read.
    #[error("webhook `{name}`: cannot read its secret_file {}", path.display())]
    Secret {
        /// The webhook.
        name: String,
        /// The secret file.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A secret too short to sign with.
    #[error("webhook `{name}`: its secret_file {} holds {bytes} bytes; at least {needed} are needed", path.display())]
    ShortSecret {
        /// The webhook.
        name: String,
        /// The secret file.
        path: PathBuf,
        /// Its length after trimming.
        bytes: usize,
        /// The shortest accepted.
        needed: usize,
    },
}
