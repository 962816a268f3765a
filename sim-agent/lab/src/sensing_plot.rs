//! The sensing characterisation as a picture (SVG): the gradient direction
//! error (median and 90th percentile, degrees) and V_ave against distance to
//! a speaker, one line per noise setting.
//!
//! Why hand-written SVG: two line charts need a few polylines and labels,
//! and the orchestrator's picture module lives in a crate that depends on
//! this one (see `orchestrator/study/src/draw/mod.rs` for why no plotting crate).

use super::characterise::SensingRow;
use std::fmt::Write;

const W: f64 = 360.0;
const H: f64 = 260.0;
const PAD: f64 = 48.0;
const COLOURS: [&str; 4] = ["#d62728", "#1f5fd6", "#2ca02c", "#9467bd"];

/// One line of a panel.
struct Series {
    label: String,
    points: Vec<(f64, f64)>,
    dashed: bool,
    /// Index of its colour (one colour per noise setting).
    colour: usize,
}

/// One panel: `series` are (label, points), drawn into the panel at `left`.
fn panel(out: &mut String, left: f64, title: &str, y_label: &str, series: &[Series]) {
    let points = series.iter().flat_map(|s| s.points.iter()).filter(|(_, y)| y.is_finite());
    let (x_max, y_max) = points.fold((0.0_f64, 0.0_f64), |(xm, ym), &(x, y)| (xm.max(x), ym.max(y)));
    let (x_max, y_max) = (x_max.max(1e-9), (y_max * 1.1).max(1e-9));
    let px = |x: f64| left + PAD + x / x_max * (W - 1.5 * PAD);
    let py = |y: f64| H - PAD - y / y_max * (H - 2.0 * PAD);
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="20" font-size="13" text-anchor="middle">{title}</text>"#,
        left + W / 2.0
    );
    let _ = writeln!(
        out,
        r#"<line x1="{0:.1}" y1="{1:.1}" x2="{2:.1}" y2="{1:.1}" stroke="black"/><line x1="{0:.1}" y1="{1:.1}" x2="{0:.1}" y2="{3:.1}" stroke="black"/>"#,
        px(0.0),
        py(0.0),
        px(x_max),
        py(y_max)
    );
    for k in 0..=4 {
        let (x, y) = (x_max * f64::from(k) / 4.0, y_max * f64::from(k) / 4.0);
        let _ = writeln!(
            out,
            r#"<text x="{:.1}" y="{:.1}" font-size="10" text-anchor="middle">{x:.2}</text>"#,
            px(x),
            H - PAD + 14.0
        );
        let _ = writeln!(
            out,
            r#"<text x="{:.1}" y="{:.1}" font-size="10" text-anchor="end">{y:.0}</text>"#,
            px(0.0) - 4.0,
            py(y) + 3.0
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" font-size="11" text-anchor="middle">distance to the speaker, m</text>"#,
        left + W / 2.0,
        H - 12.0
    );
    let _ = writeln!(out, r#"<text x="{:.1}" y="{:.1}" font-size="11">{y_label}</text>"#, left + 4.0, 38.0);
    for (row, s) in series.iter().enumerate() {
        let (label, colour) = (&s.label, COLOURS[s.colour % COLOURS.len()]);
        let dash = if s.dashed { r#" stroke-dasharray="4 3""# } else { "" };
        let line: Vec<String> = s
            .points
            .iter()
            .filter(|(_, y)| y.is_finite())
            .map(|&(x, y)| format!("{:.1},{:.1}", px(x), py(y)))
            .collect();
        let _ = writeln!(
            out,
            r#"<polyline class="series" points="{}" fill="none" stroke="{colour}" stroke-width="1.5"{dash}/>"#,
            line.join(" ")
        );
        let _ = writeln!(
            out,
            r#"<text x="{:.1}" y="{:.1}" font-size="10" fill="{colour}">{label}</text>"#,
            left + W - 130.0,
            40.0 + 13.0 * row as f64
        );
    }
}

/// The picture of `runs`: (noise setting, its rows).
pub fn plot(runs: &[(&str, &[SensingRow])]) -> String {
    let mut out = format!(
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{H}" font-family="sans-serif">"#,
        2.0 * W
    );
    out += "\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
    let mut errors = Vec::new();
    let mut levels = Vec::new();
    for (colour, (name, rows)) in runs.iter().enumerate() {
        let line = |label: String, f: fn(&SensingRow) -> f64, dashed: bool| Series {
            label,
            points: rows.iter().map(|r| (r.distance, f(r))).collect(),
            dashed,
            colour,
        };
        errors.push(line(format!("{name}: median"), |r| r.median_error_deg, false));
        errors.push(line(format!("{name}: p90"), |r| r.p90_error_deg, true));
        levels.push(line((*name).to_string(), |r| r.v_ave, false));
    }
    panel(&mut out, 0.0, "gradient direction error", "degrees", &errors);
    panel(&mut out, W, "V_ave (mean of the six microphones)", "ADC counts", &levels);
    out += "</svg>\n";
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(distance: f64, err: f64, v_ave: f64) -> SensingRow {
        SensingRow {
            distance,
            v_ave,
            median_error_deg: err,
            p90_error_deg: 2.0 * err,
            no_direction: 0.0,
            snr_db: 20.0,
        }
    }

    #[test]
    fn one_line_per_series_and_missing_values_are_left_out() {
        let a = [row(0.5, 1.0, 22000.0), row(1.0, 7.0, 6000.0), row(2.0, f64::NAN, 1500.0)];
        let b = [row(0.5, 0.5, 22000.0), row(1.0, 2.0, 6000.0)];
        let svg = plot(&[("default noise", &a), ("quiet", &b)]);
        // Errors: median + p90 per setting; V_ave: one per setting.
        assert_eq!(svg.matches(r#"class="series""#).count(), 6);
        assert!(svg.contains("default noise: median") && svg.contains("quiet: p90"));
        assert!(!svg.contains("NaN"), "a missing error is left out, not drawn");
        let first = svg.lines().find(|l| l.contains(r#"class="series""#)).expect("a series");
        assert_eq!(first.matches(',').count(), 2, "the NaN point of the first series is skipped: {first}");
    }
}
