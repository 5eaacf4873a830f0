//! One simulated pass for people: the CSV of `simulate` (and the demo), its printed summary,
//! its figure and the title naming the flat.

use super::{draw_pad_forces, PadForcePlot, PlotError, Series};
use crate::model::{CheckedCalibration, Flat, Response};
use std::path::Path;

/// The CSV text of a response: `time_s`, one `<sensor>_kn` column per sensor, and the contact
/// forces when recorded.
pub fn response_csv(cal: &CheckedCalibration, r: &Response) -> String {
    let mut s = String::from("time_s");
    for p in &cal.sensors.pad {
        s += &format!(",{}_kn", p.name);
    }
    if r.contact_force_n.is_some() {
        s += ",contact_leading_kn,contact_trailing_kn";
    }
    s.push('\n');
    for j in 0..r.len() {
        s += &format!("{:.6}", r.time_s(j));
        for series in &r.pad_force_n {
            s += &format!(",{:.4}", series[j] / 1e3);
        }
        if let Some(c) = &r.contact_force_n {
            s += &format!(",{:.4},{:.4}", c[0][j] / 1e3, c[1][j] / 1e3);
        }
        s.push('\n');
    }
    s
}

/// Human summary of a run: per-sensor peaks, contact peaks and loss of contact.
pub fn response_summary(cal: &CheckedCalibration, r: &Response) -> String {
    let mut s = String::new();
    s += "sensor  position_m  peak_kn  at_time_s\n";
    for (i, p) in cal.sensors.pad.iter().enumerate() {
        let (j, peak) =
            r.pad_force_n[i]
                .iter()
                .copied()
                .enumerate()
                .fold(
                    (0, f64::MIN),
                    |acc, (j, v)| if v > acc.1 { (j, v) } else { acc },
                );
        s += &format!(
            "{:<6}  {:>10.2}  {:>7.2}  {:>9.4}\n",
            p.name,
            cal.sensor_position_m(i),
            peak / 1e3,
            r.time_s(j)
        );
    }
    s += &format!(
        "peak contact force: leading {:.1} kN, trailing {:.1} kN (static {:.1} kN)\n",
        r.peak_contact_force_n[0] / 1e3,
        r.peak_contact_force_n[1] / 1e3,
        cal.static_wheel_load_n() / 1e3
    );
    for (w, name) in ["leading", "trailing"].iter().enumerate() {
        if r.contact_loss_s[w] > 0.0 {
            s += &format!(
                "loss of contact: {name} wheel off the rail for {:.2} ms in total\n",
                r.contact_loss_s[w] * 1e3
            );
        }
    }
    if !r.strike_times_s.is_empty() {
        let t: Vec<String> = r.strike_times_s.iter().map(|t| format!("{t:.4}")).collect();
        s += &format!("flat strikes at t = {} s\n", t.join(", "));
    }
    s
}

/// Draws a response with all sensors, the strikes marked, and the contact forces if recorded
/// (PNG or SVG by the extension of `path`).
pub fn plot_response(
    cal: &CheckedCalibration,
    r: &Response,
    title: &str,
    path: &Path,
) -> Result<(), PlotError> {
    let time: Vec<f64> = (0..r.len()).map(|j| r.time_s(j)).collect();
    let kn: Vec<Vec<f64>> = r
        .pad_force_n
        .iter()
        .map(|s| s.iter().map(|v| v / 1e3).collect())
        .collect();
    let contact: Option<[Vec<f64>; 2]> = r
        .contact_force_n
        .as_ref()
        .map(|c| [0, 1].map(|w| c[w].iter().map(|v| v / 1e3).collect()));
    let series = cal
        .sensors
        .pad
        .iter()
        .zip(&kn)
        .map(|(p, v)| Series {
            label: &p.name,
            values_kn: v,
        })
        .collect();
    let plot = PadForcePlot {
        title,
        time_s: &time,
        series,
        strike_times_s: &r.strike_times_s,
        contact_kn: contact.as_ref().map(|c| [c[0].as_slice(), c[1].as_slice()]),
    };
    draw_pad_forces(&plot, path)
}

/// The title naming a simulated flat (or the good wheel), as figures and summaries print it.
pub fn flat_title(flat: Option<&Flat>) -> String {
    match flat {
        None => "good wheel (no flat)".to_string(),
        Some(f) => format!(
            "flat L = {:.1} mm, d = {:.3} mm, c = {:.3} mm, X_p = {:.3} m",
            f.length_m() * 1e3,
            f.depth_m() * 1e3,
            f.curvature_m() * 1e3,
            f.impact_position_m()
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Calibration, Record, Simulator};

    #[test]
    fn titles_name_the_flat() {
        assert_eq!(flat_title(None), "good wheel (no flat)");
        let f = Flat::from_mm(60.0, 0.5, 0.1, 12.4).unwrap();
        assert_eq!(
            flat_title(Some(&f)),
            "flat L = 60.0 mm, d = 0.500 mm, c = 0.100 mm, X_p = 12.400 m"
        );
    }

    #[test]
    fn csv_has_a_row_per_sample_and_a_column_per_sensor() {
        let cal = Calibration::narrow_profile().check().unwrap();
        let r = Simulator::new(&cal)
            .unwrap()
            .run(None, Record { contact: true })
            .unwrap();
        let csv = response_csv(&cal, &r);
        let mut lines = csv.lines();
        let header = lines.next().unwrap();
        assert_eq!(header.split(',').count(), 1 + cal.sensors.pad.len() + 2);
        assert!(header.ends_with(",contact_leading_kn,contact_trailing_kn"));
        assert_eq!(lines.count(), r.len());
        let summary = response_summary(&cal, &r);
        assert!(summary.starts_with("sensor  position_m  peak_kn  at_time_s\n"));
        assert!(!summary.contains("flat strikes"));
    }
}
