//! Passes that are not good wheels on this track, set aside (docs/calibration.md, "Which
//! passes"). A night's passes are taken as good wheels by what the site answered
//! (`calibrate --db`: no flat, or one below the population) or by the folder they were put
//! in; a flat among them leaves impacts the track's fit would bend to. After the fit, each
//! pass's misfit ([`super::fit::TrackFit::misfits`]: the share of its sum of squares the good
//! wheel leaves, and its largest residual over the residual's RMS) is compared with the other
//! passes': a pass above the median by more than [`OUTLIER_MADS`] scaled median absolute
//! deviations by **both** measures is set aside, named, and the fit run again without it. The
//! share alone also picks the roughest treads at a site with hanging sleepers (measured: 8
//! cast-iron treads of 150 at docs/calibration.md's site 2, 4.5–5.8× the median, where flats
//! sit at 4.1–6.3×); a flat's impacts are concentrated in a few samples (largest residual
//! 14–19× the RMS, against at most 8.5× for those treads). Relative, so that a heavy pass is
//! not set aside for its load; against the passes' own spread, so that a track the
//! calibration does not yet know (every pass fitting it badly alike) sets none aside.

use serde::{Deserialize, Serialize};

/// How many scaled median absolute deviations (1.4826 × MAD: one standard deviation of a
/// normal sample) above the median a pass's relative misfit may be.
pub const OUTLIER_MADS: f64 = 6.0;

/// A pass set aside, and why.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetAside {
    /// The pass's file.
    pub path: String,
    /// Its relative misfit over the passes' median.
    pub misfit_over_median: f64,
}

/// The passes whose misfit (`[share, peak over RMS]`, [`super::fit::TrackFit::misfits`]) is
/// an outlier by both measures.
pub fn outliers(misfits: &[[f64; 2]]) -> Vec<usize> {
    let by = |k: usize| above(&misfits.iter().map(|m| m[k]).collect::<Vec<_>>());
    let (share, peak) = (by(0), by(1));
    share.into_iter().filter(|i| peak.contains(i)).collect()
}

/// The indices of `misfits` above the median by more than [`OUTLIER_MADS`] scaled MADs.
fn above(misfits: &[f64]) -> Vec<usize> {
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            f64::NAN
        } else if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        }
    };
    let m = median(&mut misfits.to_vec());
    let mad = median(&mut misfits.iter().map(|x| (x - m).abs()).collect());
    let limit = m + OUTLIER_MADS * 1.4826 * mad;
    (0..misfits.len()).filter(|&i| misfits[i] > limit).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pass_far_above_the_others_is_an_outlier_and_a_common_misfit_is_not() {
        // Twenty passes spread 1.0–1.19, one at 3: the 3 alone (median 1.1, scaled MAD
        // 0.074: the limit 1.54).
        let mut m: Vec<f64> = (0..20).map(|i| 1.0 + 0.01 * i as f64).collect();
        m.push(3.0);
        assert_eq!(above(&m), vec![20]);
        // Every pass misfitting alike (a track the calibration does not know yet): none.
        let scaled: Vec<f64> = m[..20].iter().map(|x| 50.0 * x).collect();
        assert!(above(&scaled).is_empty());
        assert!(above(&[]).is_empty());
        // An outlier by both measures is one; by one alone (a rough tread: a larger share,
        // spread over the pass) is not.
        let both: Vec<[f64; 2]> = m.iter().map(|&x| [x, x]).collect();
        assert_eq!(outliers(&both), vec![20]);
        let one: Vec<[f64; 2]> = m.iter().map(|&x| [x, 4.0]).collect();
        assert!(outliers(&one).is_empty());
    }
}
