//! What `bank info` shows beyond the metadata: the bank's size on disk and the range of every
//! stored flat parameter.

use super::{Bank, BankError};

/// A bank's size on disk.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BankSize {
    /// Instances in the bank.
    pub instances: usize,
    /// Shard files.
    pub files: usize,
    /// Bytes of all shard files together.
    pub bytes: u64,
}

impl BankSize {
    /// Of an open bank, from its manifest (reads no data).
    pub fn of(bank: &Bank) -> BankSize {
        BankSize {
            instances: bank.instances(),
            files: bank.manifest().files.len(),
            bytes: bank.manifest().files.iter().map(|f| f.bytes).sum(),
        }
    }

    /// Megabytes (10⁶ bytes) on disk.
    pub fn megabytes(&self) -> f64 {
        self.bytes as f64 / 1e6
    }

    /// Kilobytes (10³ bytes) per instance (per one instance when the bank is empty).
    pub fn kilobytes_per_instance(&self) -> f64 {
        self.bytes as f64 / 1e3 / self.instances.max(1) as f64
    }
}

/// The smallest and largest stored value of one parameter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterRange {
    /// The parameter's column name (`length_mm`, `depth_mm`, `curvature_mm`,
    /// `impact_position_m`, `l0_mm`).
    pub name: &'static str,
    /// Smallest value (`f64::MAX` when the bank is empty).
    pub min: f64,
    /// Largest value (`f64::MIN` when the bank is empty).
    pub max: f64,
}

/// The ranges of the flat parameters over the whole bank (reads the parameter columns).
pub fn parameter_ranges(bank: &Bank) -> Result<Vec<ParameterRange>, BankError> {
    let p = bank.read_parameters()?;
    Ok([
        ("length_mm", &p.length_mm),
        ("depth_mm", &p.depth_mm),
        ("curvature_mm", &p.curvature_mm),
        ("impact_position_m", &p.impact_position_m),
        ("l0_mm", &p.l0_mm),
    ]
    .into_iter()
    .map(|(name, v)| {
        let (min, max) = range(v);
        ParameterRange { name, min, max }
    })
    .collect())
}

/// `(min, max)` of `v`; `(f64::MAX, f64::MIN)` when empty.
fn range(v: &[f64]) -> (f64, f64) {
    v.iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_cover_the_values() {
        assert_eq!(range(&[2.0, -1.0, 3.5]), (-1.0, 3.5));
        assert_eq!(range(&[]), (f64::MAX, f64::MIN));
    }
}
