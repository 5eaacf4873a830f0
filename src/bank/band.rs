//! What a speed band ([`super::speeds::SpeedBand`]) and a load band
//! ([`super::loads::LoadBand`]) share: `FROM:TO:STEP` read from text, and the members it
//! makes.

/// `FROM:TO:STEP` read as three finite numbers; `unit` follows "not a number" in the message
/// (e.g. " of km/h"), `what` names the form (e.g. "in km/h (e.g. `40:60:2`)").
// Err(String): a clap value parser's message (the argument is named by clap).
pub(crate) fn parse_from_to_step(text: &str, what: &str, unit: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = text.split(':').collect();
    if parts.len() != 3 {
        return Err(format!("`{text}` is not FROM:TO:STEP {what}"));
    }
    let mut v = [0.0; 3];
    for (slot, (part, name)) in v.iter_mut().zip(parts.iter().zip(["FROM", "TO", "STEP"])) {
        *slot = part
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| format!("{name} `{part}` in `{text}` is not a number{unit}"))?;
    }
    Ok(v)
}

/// The members from `from` to `to` every `step` (the last within a rounding of `to`).
pub(crate) fn count(from: f64, to: f64, step: f64) -> usize {
    ((to - from) / step + 1e-9).floor() as usize + 1
}
