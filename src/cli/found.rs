//! `wheelflat found`: what the workshop measured on a pulled wheelset, into the fleet store;
//! with `--table`, how the passes before every finding fared (docs/fleet.md, "Findings").

use super::fleet::FleetArgs;
use anyhow::{Context, Result};
use clap::Args;
use std::path::PathBuf;
use wheelflat::fleet::{findings, words, Finding, FleetReader};

// `found`.
#[derive(Debug, Args)]
pub(super) struct FoundArgs {
    #[command(flatten)]
    pub fleet: FleetArgs,
    /// The wheel, as the sites name it (`<bogie_id>/leading` or `…/trailing`).
    #[arg(long, requires_all = ["length_mm", "depth_mm", "date"], conflicts_with = "csv")]
    pub wheel: Option<String>,
    /// The flat's length L measured (mm; 0 with depth 0: no flat found).
    #[arg(long, allow_hyphen_values = true)]
    pub length_mm: Option<String>,
    /// Its depth d (mm).
    #[arg(long, allow_hyphen_values = true)]
    pub depth_mm: Option<String>,
    /// The day it was measured (YYYY-MM-DD).
    #[arg(long)]
    pub date: Option<String>,
    /// The workshop's words.
    #[arg(long, default_value = "")]
    pub note: String,
    /// Many findings: a CSV with the header `wheel_id,date,length_mm,depth_mm[,note]`.
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Print the validation table: every finding against the passes before it, per site and
    /// for the fleet (a reader's login).
    #[arg(long)]
    pub table: bool,
    /// With --table: the days before a finding whose passes are judged (1–365).
    #[arg(long, default_value_t = 30.0, value_parser = parse_days)]
    pub days: f64,
    /// With --table: φ and the class limits from this calibration's `[maintenance]`.
    #[arg(long)]
    pub calibration: Option<PathBuf>,
    /// With --table: also write the table and every judged pass as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
}

// Err(String): a clap value parser: clap names the argument and prints the message.
fn parse_days(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .parse()
        .map_err(|_| format!("`{s}` is not a number of days"))?;
    if (1.0..=365.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} days: must lie in [1, 365]"))
    }
}

/// `wheelflat found`.
pub(super) fn run(a: &FoundArgs) -> Result<()> {
    let target = a.fleet.required()?;
    let entered: Vec<Finding> = match (&a.wheel, &a.csv) {
        (Some(w), None) => vec![Finding::new(
            "the command line",
            w,
            a.date.as_deref().unwrap_or(""),
            a.length_mm.as_deref().unwrap_or(""),
            a.depth_mm.as_deref().unwrap_or(""),
            &a.note,
        )?],
        (None, Some(csv)) => findings::read_csv(csv)?,
        _ if a.table => Vec::new(),
        _ => anyhow::bail!("give a finding (--wheel, --length-mm, --depth-mm, --date), a --csv of them, or --table"),
    };
    if !entered.is_empty() {
        let mut client = target.connect()?;
        wheelflat::fleet::schema::check(&mut client, &target)?;
        let (new, known) = findings::insert(&mut client, &target, &entered)?;
        println!(
            "{new} findings stored, {known} already there (same wheel and day) on {}",
            target.shown()
        );
    }
    if a.table {
        let cal = super::load_calibration(a.calibration.as_deref())?;
        let rules = &cal.identification;
        let mut reader = FleetReader::connect(&target)?;
        let all: Vec<Finding> = reader
            .findings(100_000)?
            .into_iter()
            .map(|r| r.finding)
            .collect();
        let v = findings::validate(
            &mut reader,
            &all,
            a.days,
            rules.phi,
            [rules.inspect_l0_mm, rules.urgent_l0_mm],
        )?;
        println!("{} findings in {}", all.len(), target.shown());
        print!("{}", words::validation_table(&v));
        if let Some(path) = &a.json {
            let text = serde_json::to_string_pretty(&v).context("the table as JSON")?;
            super::write_file(path, text.as_bytes())?;
            println!("wrote {}", path.display());
        }
    }
    Ok(())
}
