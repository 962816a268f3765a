//! Success-rate tables and heatmaps from run rows.
//!
//! Computed only from the rows, so a single sweep and the `merge` of its
//! shards produce the same files byte for byte.

use super::plan::Axes;
use super::rows::Row;
use crate::draw::heatmap::{render, Heatmap};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Successes and runs per (width bin, ε) for one noise setting.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub noise: bool,
    /// `cells[bin][eps] = (successes, runs)`.
    pub cells: Vec<Vec<(usize, usize)>>,
}

impl Table {
    pub fn rates(&self) -> Vec<Vec<Option<f64>>> {
        self.cells
            .iter()
            .map(|row| row.iter().map(|&(s, n)| (n > 0).then(|| s as f64 / n as f64)).collect())
            .collect()
    }

    pub fn label(&self) -> &'static str {
        if self.noise {
            "noise-on"
        } else {
            "noise-off"
        }
    }
}

/// One table per noise setting of the axes.
pub fn tabulate(axes: &Axes, rows: &[Row]) -> Vec<Table> {
    axes.noise
        .iter()
        .map(|&noise| {
            let mut cells = vec![vec![(0, 0); axes.eps.len()]; axes.widths.len()];
            // Cells by the run's index, not by comparing floats.
            for r in rows.iter().filter(|r| r.index < axes.total_runs()) {
                let spec = axes.spec(r.index);
                if spec.noise == noise {
                    cells[spec.bin][spec.eps].1 += 1;
                    cells[spec.bin][spec.eps].0 += usize::from(r.success);
                }
            }
            Table { noise, cells }
        })
        .collect()
}

/// Rows widest bin first (as in the heatmap): (width bin, success rate in % per ε).
fn rows_widest_first<'a>(axes: &'a Axes, t: &Table) -> impl Iterator<Item = (f64, Vec<Option<f64>>)> + 'a {
    let rates = t.rates();
    axes.widths
        .iter()
        .copied()
        .zip(rates)
        .rev()
        .map(|(w, row)| (w, row.iter().map(|r| r.map(|r| 100.0 * r)).collect()))
}

/// The table as CSV: one row per width bin (widest first), one column per
/// ε, success rates in percent (empty where there were no runs).
pub fn to_csv(axes: &Axes, t: &Table) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let header = std::iter::once("width_bin".to_owned()).chain(axes.eps.iter().map(|e| format!("eps_{e}")));
    w.write_record(header.collect::<Vec<_>>())?;
    for (width, row) in rows_widest_first(axes, t) {
        let rates = row.iter().map(|r| r.map(|r| format!("{r:.1}")).unwrap_or_default());
        w.write_record(std::iter::once(width.to_string()).chain(rates).collect::<Vec<_>>())?;
    }
    let bytes = w.into_inner().map_err(|e| anyhow::anyhow!("csv: {e}"))?;
    Ok(String::from_utf8(bytes)?)
}

/// A fixed-width text table for the terminal.
pub fn to_text(axes: &Axes, t: &Table) -> String {
    let mut s = format!("success rate [%], noise {}\nwidth\\ε", if t.noise { "on" } else { "off" });
    for e in &axes.eps {
        let _ = write!(s, " {e:>5}");
    }
    s.push('\n');
    for (w, row) in rows_widest_first(axes, t) {
        let _ = write!(s, "{w:>7}");
        for rate in row {
            match rate {
                Some(r) => {
                    let _ = write!(s, "{r:>6.0}");
                }
                None => s.push_str("     -"),
            }
        }
        s.push('\n');
    }
    s
}

/// Writes `success-<noise>.csv` and `heatmap-<noise>.svg` for every table;
/// returns the files written.
pub fn write_outputs(dir: &Path, axes: &Axes, tables: &[Table]) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for t in tables {
        let csv = dir.join(format!("success-{}.csv", t.label()));
        super::rows::write_atomic(&csv, to_csv(axes, t)?.as_ref())?;
        let title = format!("Success rate [%], noise {}", if t.noise { "on" } else { "off" });
        let runs: usize = t.cells.iter().flatten().map(|&(_, n)| n).sum();
        let subtitle = format!("by ε and minimum path width; n = runs per cell ({runs} in all)");
        let svg = render(&Heatmap {
            title: &title,
            subtitle: &subtitle,
            eps: &axes.eps,
            widths: &axes.widths,
            cells: &t.cells,
        });
        let path = dir.join(format!("heatmap-{}.svg", t.label()));
        super::rows::write_atomic(&path, svg.as_ref())?;
        written.extend([csv, path]);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(index: usize, noise: bool, eps: f64, width_bin: f64, success: bool) -> Row {
        Row {
            index,
            noise,
            eps,
            width_bin,
            terrain: "t".into(),
            width: width_bin,
            seed: 0,
            success,
            outcome: String::new(),
            time_s: 0.0,
            robots_used: 1,
            beacons: 0,
        }
    }

    #[test]
    fn rates_per_cell_widest_first() {
        let axes = Axes {
            eps: vec![1.0, 2.0],
            widths: vec![1.0, 3.0],
            terrains_per_bin: 2,
            noise: vec![false, true],
        };
        // Canonical index: ((noise·bins + bin)·terrains + terrain)·eps + eps.
        let rows = vec![
            row(4, false, 1.0, 3.0, true),
            row(6, false, 1.0, 3.0, false),
            row(1, false, 2.0, 1.0, false),
            row(9, true, 2.0, 1.0, true), // other noise setting: not in this table
        ];
        let t = &tabulate(&axes, &rows)[0];
        assert_eq!(t.cells, vec![vec![(0, 0), (0, 1)], vec![(1, 2), (0, 0)]]);
        assert_eq!(to_csv(&axes, t).unwrap(), "width_bin,eps_1,eps_2\n3,50.0,\n1,,0.0\n");
        assert!(to_text(&axes, t).contains("      3    50     -"));
    }
}
