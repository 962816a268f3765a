//! How many robots does a swarm need? The question the paper's conclusion
//! leaves open, answered from the sweep's own rows.
//!
//! Robots are deployed one at a time and robot k never depends on robots
//! after it, so a run that arrived with robot R would have arrived, the
//! same way, under any robot budget N ≥ R, and would have run out of robots
//! under N < R. Success within budget N is therefore "arrived and
//! robots_used ≤ N" — no re-running. A sweep capped with `--max-robots M`
//! cannot say what budgets above M would have done: those cells are left
//! empty, never guessed.
//!
//! Computed from rows only (like [`super::table`]), so a sweep and the
//! `merge` of its shards write the same files.

use super::plan::Axes;
use super::rows::Row;
use crate::draw::budget::{render, BudgetPlot};
use anyhow::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The robot budgets studied; `None` is no budget (the sweep's own limit).
pub const BUDGETS: [Option<u32>; 8] =
    [Some(1), Some(2), Some(3), Some(5), Some(10), Some(20), Some(50), None];

/// Buckets of the robots-used distribution: (lowest, highest) robots.
pub const BUCKETS: [(u32, u32); 8] =
    [(1, 1), (2, 2), (3, 3), (4, 5), (6, 10), (11, 20), (21, 50), (51, u32::MAX)];

/// Per noise setting: for every (ε, width bin), each run's robots used if
/// it arrived, `None` if it did not.
#[derive(Debug, Clone, PartialEq)]
pub struct BudgetTable {
    pub noise: bool,
    /// `cells[eps][bin]`.
    pub cells: Vec<Vec<Vec<Option<u32>>>>,
    /// The sweep's `--max-robots`, if any.
    pub cap: Option<u32>,
}

impl BudgetTable {
    pub fn label(&self) -> &'static str {
        if self.noise {
            "noise-on"
        } else {
            "noise-off"
        }
    }

    /// Whether budget `b` can be answered from runs capped at `self.cap`.
    fn known(&self, b: Option<u32>) -> bool {
        match (self.cap, b) {
            (None, _) => true,
            (Some(cap), Some(n)) => n <= cap,
            (Some(_), None) => false,
        }
    }

    /// Success rate (0–1) within budget `b` over some runs; `None` when
    /// there are no runs or the budget is beyond the sweep's cap.
    fn rate(&self, runs: &[Option<u32>], b: Option<u32>) -> Option<f64> {
        if runs.is_empty() || !self.known(b) {
            return None;
        }
        let ok = runs.iter().filter(|r| r.is_some_and(|used| b.is_none_or(|n| used <= n))).count();
        Some(ok as f64 / runs.len() as f64)
    }

    /// All runs of radius `e`, every width bin pooled.
    fn pooled(&self, e: usize) -> Vec<Option<u32>> {
        self.cells[e].iter().flatten().copied().collect()
    }
}

/// One table per noise setting of the axes.
pub fn tabulate(axes: &Axes, rows: &[Row], cap: Option<u32>) -> Vec<BudgetTable> {
    axes.noise
        .iter()
        .map(|&noise| {
            let mut cells = vec![vec![Vec::new(); axes.widths.len()]; axes.eps.len()];
            // Cells by the run's index (canonical order), not by comparing floats.
            let mut ordered: Vec<&Row> = rows.iter().filter(|r| r.index < axes.total_runs()).collect();
            ordered.sort_by_key(|r| r.index);
            for r in ordered {
                let spec = axes.spec(r.index);
                if spec.noise == noise {
                    cells[spec.eps][spec.bin].push(r.success.then_some(r.robots_used));
                }
            }
            BudgetTable { noise, cells, cap }
        })
        .collect()
}

fn budget_name(b: Option<u32>) -> String {
    b.map_or_else(|| "unlimited".to_owned(), |n| n.to_string())
}

fn percent(rate: Option<f64>) -> String {
    rate.map(|r| format!("{:.1}", 100.0 * r)).unwrap_or_default()
}

/// The median robots used by the runs that arrived.
fn median_robots(runs: &[Option<u32>]) -> Option<f64> {
    let used: Vec<u32> = runs.iter().flatten().copied().collect();
    bycoms_runtime::stats::median(&used)
}

/// `budget-<noise>.csv`: success rate [%] within each budget for every ε
/// and width bin, and pooled over the bins (`width_bin` = "all").
pub fn to_csv(axes: &Axes, t: &BudgetTable) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header = vec!["eps".to_owned(), "width_bin".to_owned(), "runs".to_owned()];
    header.extend(BUDGETS.iter().map(|&b| format!("within_{}", budget_name(b))));
    header.push("median_robots_of_successes".to_owned());
    w.write_record(&header)?;
    for (e, eps) in axes.eps.iter().enumerate() {
        let groups = axes
            .widths
            .iter()
            .enumerate()
            .map(|(b, width)| (width.to_string(), t.cells[e][b].clone()))
            .chain(std::iter::once(("all".to_owned(), t.pooled(e))));
        for (width, runs) in groups {
            let mut record = vec![eps.to_string(), width, runs.len().to_string()];
            record.extend(BUDGETS.iter().map(|&b| percent(t.rate(&runs, b))));
            record.push(median_robots(&runs).map(|m| m.to_string()).unwrap_or_default());
            w.write_record(&record)?;
        }
    }
    Ok(String::from_utf8(w.into_inner().map_err(|e| anyhow::anyhow!("csv: {e}"))?)?)
}

/// `robots-<noise>.csv`: how many runs used how many robots (runs that
/// arrived, in buckets), and how many never arrived, per ε and width bin.
pub fn robots_csv(axes: &Axes, t: &BudgetTable) -> Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let mut header =
        vec!["eps".to_owned(), "width_bin".to_owned(), "runs".to_owned(), "not_arrived".to_owned()];
    header.extend(BUCKETS.iter().map(|&(lo, hi)| match (lo, hi) {
        (lo, hi) if lo == hi => format!("robots_{lo}"),
        (lo, u32::MAX) => format!("robots_{lo}_or_more"),
        (lo, hi) => format!("robots_{lo}_to_{hi}"),
    }));
    w.write_record(&header)?;
    for (e, eps) in axes.eps.iter().enumerate() {
        for (b, width) in axes.widths.iter().enumerate() {
            let runs = &t.cells[e][b];
            let mut record = vec![
                eps.to_string(),
                width.to_string(),
                runs.len().to_string(),
                runs.iter().filter(|r| r.is_none()).count().to_string(),
            ];
            record.extend(BUCKETS.iter().map(|&(lo, hi)| {
                runs.iter().flatten().filter(|&&used| (lo..=hi).contains(&used)).count().to_string()
            }));
            w.write_record(&record)?;
        }
    }
    Ok(String::from_utf8(w.into_inner().map_err(|e| anyhow::anyhow!("csv: {e}"))?)?)
}

/// A terminal table: success [%] within each budget per ε, width bins pooled.
pub fn to_text(axes: &Axes, t: &BudgetTable) -> String {
    let mut s = format!(
        "success within a robot budget N [%], noise {}, all width bins\n    ε\\N",
        if t.noise { "on" } else { "off" }
    );
    for b in BUDGETS {
        let _ = write!(s, " {:>5}", b.map_or_else(|| "∞".to_owned(), |n| n.to_string()));
    }
    s.push_str("  median robots\n");
    for (e, eps) in axes.eps.iter().enumerate() {
        let runs = t.pooled(e);
        let _ = write!(s, "{eps:>7}");
        for b in BUDGETS {
            match t.rate(&runs, b) {
                Some(r) => {
                    let _ = write!(s, " {:>5.0}", 100.0 * r);
                }
                None => s.push_str("     -"),
            }
        }
        match median_robots(&runs) {
            Some(m) => {
                let _ = writeln!(s, "  {m:>13}");
            }
            None => s.push_str("              -\n"),
        }
    }
    if let Some(cap) = t.cap {
        let _ = writeln!(
            s,
            "(the sweep deployed at most {cap} robots per run: larger budgets are unknown, shown as -)"
        );
    }
    s
}

/// Writes `budget-<noise>.csv`, `robots-<noise>.csv` and `budget-<noise>.svg`;
/// returns the files written.
pub fn write_outputs(dir: &Path, axes: &Axes, tables: &[BudgetTable]) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for t in tables {
        let budget = dir.join(format!("budget-{}.csv", t.label()));
        super::rows::write_atomic(&budget, to_csv(axes, t)?.as_ref())?;
        let robots = dir.join(format!("robots-{}.csv", t.label()));
        super::rows::write_atomic(&robots, robots_csv(axes, t)?.as_ref())?;
        let curves: Vec<Vec<Option<f64>>> = (0..axes.eps.len())
            .map(|e| {
                let runs = t.pooled(e);
                BUDGETS.iter().map(|&b| t.rate(&runs, b)).collect()
            })
            .collect();
        let runs: usize = t.cells.iter().flatten().map(Vec::len).sum();
        let title = format!("Success within a robot budget N, noise {}", if t.noise { "on" } else { "off" });
        let subtitle = format!("one line per ε, all width bins pooled ({runs} runs)");
        let labels: Vec<String> =
            BUDGETS.iter().map(|b| b.map_or_else(|| "∞".to_owned(), |n| n.to_string())).collect();
        let svg = render(&BudgetPlot {
            title: &title,
            subtitle: &subtitle,
            budgets: &labels,
            eps: &axes.eps,
            curves: &curves,
        });
        let plot = dir.join(format!("budget-{}.svg", t.label()));
        super::rows::write_atomic(&plot, svg.as_ref())?;
        written.extend([budget, robots, plot]);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(index: usize, success: bool, robots_used: u32) -> Row {
        Row {
            index,
            noise: false,
            eps: 0.0,
            width_bin: 0.0,
            terrain: "t".into(),
            width: 0.0,
            seed: 0,
            success,
            outcome: String::new(),
            time_s: 0.0,
            robots_used,
            beacons: 0,
        }
    }

    fn axes() -> Axes {
        Axes { eps: vec![1.0, 2.0], widths: vec![2.0], terrains_per_bin: 4, noise: vec![false] }
    }

    #[test]
    fn success_within_a_budget_counts_arrivals_with_at_most_n_robots() {
        // ε = 1 (even indices): arrived with 1, 3 and 12 robots, one failure.
        let rows =
            vec![row(0, true, 1), row(2, true, 3), row(4, true, 12), row(6, false, 80), row(1, false, 5)];
        let t = &tabulate(&axes(), &rows, None)[0];
        let runs = t.pooled(0);
        let rates: Vec<Option<f64>> = BUDGETS.iter().map(|&b| t.rate(&runs, b)).collect();
        assert_eq!(rates, [0.25, 0.25, 0.5, 0.5, 0.5, 0.75, 0.75, 0.75].map(Some).to_vec());
        assert_eq!(median_robots(&runs), Some(3.0));
        assert_eq!(t.rate(&t.pooled(1), None), Some(0.0));
        let csv = to_csv(&axes(), t).unwrap();
        assert!(csv.contains("\n1,2,4,25.0,25.0,50.0,50.0,50.0,75.0,75.0,75.0,3\n"), "{csv}");
        assert!(csv.contains("\n1,all,4,25.0,"), "{csv}");
        let robots = robots_csv(&axes(), t).unwrap();
        assert!(
            robots.starts_with("eps,width_bin,runs,not_arrived,robots_1,robots_2,robots_3,robots_4_to_5,")
        );
        assert!(robots.contains("\n1,2,4,1,1,0,1,0,0,1,0,0\n"), "{robots}");
    }

    #[test]
    fn budgets_beyond_the_sweeps_cap_are_unknown_not_guessed() {
        let rows = vec![row(0, true, 2), row(2, false, 5)];
        let t = &tabulate(&axes(), &rows, Some(5))[0];
        let runs = t.pooled(0);
        assert_eq!(t.rate(&runs, Some(5)), Some(0.5));
        assert_eq!(t.rate(&runs, Some(10)), None);
        assert_eq!(t.rate(&runs, None), None);
        assert!(to_text(&axes(), t).contains("at most 5 robots"));
    }
}
