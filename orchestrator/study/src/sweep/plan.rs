//! The sweep's axes and the canonical order of its runs.
//!
//! Run `index` enumerates noise setting, then width bin, then terrain, then
//! ε (innermost). A shard `i/n` takes the runs with `index % n == i`: round
//! robin rather than blocks, so every shard gets the same mix of easy and
//! slow cells.

use super::terrains::BIN_SIZE;
use anyhow::{bail, Context, Result};
use bycoms_sim::terrain::width::MAX_CLEARANCE;
use serde::{Deserialize, Serialize};
use std::str::FromStr;

/// Axes of the study. The paper's: ε and width bins 1, 1.5, …, 5; 100 terrains per bin; noise off and on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Axes {
    pub eps: Vec<f64>,
    pub widths: Vec<f64>,
    pub terrains_per_bin: usize,
    pub noise: Vec<bool>,
}

impl Axes {
    pub fn paper() -> Self {
        let grid: Vec<f64> = (0..9).map(|i| 1.0 + 0.5 * f64::from(i)).collect();
        Self { eps: grid.clone(), widths: grid, terrains_per_bin: 100, noise: vec![false, true] }
    }

    /// Checks every axis; errors name the option.
    pub fn validate(&self) -> Result<()> {
        if self.eps.is_empty() {
            bail!("--eps is empty: give at least one radius");
        }
        for &e in &self.eps {
            crate::runs::check_eps(e)?;
        }
        if self.widths.is_empty() {
            bail!("--widths is empty: give at least one width bin");
        }
        // Feasible terrains measure at least 1, and widths are capped.
        let top = 2.0 * MAX_CLEARANCE - BIN_SIZE;
        if let Some(w) = self.widths.iter().find(|w| !(w.is_finite() && (1.0..=top).contains(*w))) {
            bail!("width bins (--widths) must lie in [1, {top}] (a feasible terrain measures ≥ 1; widths are measured up to {}), got {w:?}", 2.0 * MAX_CLEARANCE);
        }
        for (i, a) in self.widths.iter().enumerate() {
            if let Some(b) = self.widths[i + 1..].iter().find(|b| (*b - a).abs() < BIN_SIZE) {
                bail!("width bins {a} and {b} overlap (each bin is {BIN_SIZE} wide)");
            }
        }
        for (i, a) in self.eps.iter().enumerate() {
            if self.eps[i + 1..].contains(a) {
                bail!("--eps lists {a} twice");
            }
        }
        if self.terrains_per_bin == 0 {
            bail!("--terrains-per-bin must be at least 1");
        }
        if self.noise.is_empty() {
            bail!("--noise selects no setting");
        }
        Ok(())
    }

    pub fn total_runs(&self) -> usize {
        self.noise.len() * self.widths.len() * self.terrains_per_bin * self.eps.len()
    }
}

/// One run of the plan, by its position on every axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunSpec {
    pub index: usize,
    pub noise: bool,
    pub bin: usize,
    pub terrain: usize,
    pub eps: usize,
}

impl Axes {
    /// The run at canonical `index`.
    pub fn spec(&self, index: usize) -> RunSpec {
        let ne = self.eps.len();
        let nt = self.terrains_per_bin;
        let nb = self.widths.len();
        RunSpec {
            index,
            eps: index % ne,
            terrain: (index / ne) % nt,
            bin: (index / (ne * nt)) % nb,
            noise: self.noise[index / (ne * nt * nb)],
        }
    }
}

/// `i/n`: this process runs shard i (0-based) of n.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    /// Canonical indices of the runs in this shard.
    pub fn runs(&self, total: usize) -> impl Iterator<Item = usize> + '_ {
        (self.index..total).step_by(self.count)
    }

    pub fn is_whole(&self) -> bool {
        self.count == 1
    }
}

impl FromStr for Shard {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> Result<Self> {
        let (i, n) = s.split_once('/').context("a shard is written i/n, e.g. 0/4")?;
        let index: usize = i.trim().parse().with_context(|| format!("bad shard index {i:?}"))?;
        let count: usize = n.trim().parse().with_context(|| format!("bad shard count {n:?}"))?;
        if count == 0 || index >= count {
            bail!("shard {index}/{count}: need 0 ≤ i < n");
        }
        Ok(Shard { index, count })
    }
}

/// Parses an axis: a comma-separated list ("1,1.5,2") or a range "start:end:step" (inclusive).
pub fn parse_axis(s: &str) -> Result<Vec<f64>> {
    let s = s.trim();
    if s.is_empty() {
        return Ok(Vec::new());
    }
    if let Some((start, rest)) = s.split_once(':') {
        let (end, step) = rest.split_once(':').context("a range is written start:end:step")?;
        let [start, end, step] = [start, end, step].map(|v| v.trim().parse::<f64>());
        let (start, end, step) = (start?, end?, step?);
        if !(step > 0.0 && start.is_finite() && end.is_finite()) || end < start {
            bail!("range {s}: need start ≤ end and a positive step");
        }
        let n = ((end - start) / step + 1e-9).floor();
        if n.is_nan() || n >= MAX_AXIS_LEN as f64 {
            bail!("range {s} has more than {MAX_AXIS_LEN} values");
        }
        return Ok((0..=n as usize).map(|i| start + step * i as f64).collect());
    }
    let values: Vec<f64> = s
        .split(',')
        .map(|v| v.trim().parse::<f64>().with_context(|| format!("{v:?} is not a number")))
        .collect::<Result<_>>()?;
    if values.len() > MAX_AXIS_LEN {
        bail!("more than {MAX_AXIS_LEN} values");
    }
    Ok(values)
}

/// Longest axis accepted (a guard against typos like `1:1e9:1`).
pub const MAX_AXIS_LEN: usize = 10_000;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_axes_make_16200_runs() {
        let a = Axes::paper();
        assert_eq!(a.total_runs(), 16_200);
        assert_eq!(a.eps.last(), Some(&5.0));
        let last = a.spec(16_199);
        assert_eq!((last.noise, last.bin, last.terrain, last.eps), (true, 8, 99, 8));
        let first = a.spec(0);
        assert_eq!((first.noise, first.bin, first.terrain, first.eps), (false, 0, 0, 0));
    }

    #[test]
    fn shards_partition_the_runs() {
        let total = 103;
        let mut seen = vec![0; total];
        for i in 0..4 {
            for r in (Shard { index: i, count: 4 }).runs(total) {
                seen[r] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
        assert!("4/4".parse::<Shard>().is_err());
        assert!("x/4".parse::<Shard>().is_err());
        assert_eq!("1/3".parse::<Shard>().unwrap(), Shard { index: 1, count: 3 });
    }

    #[test]
    fn axes_parse_lists_and_ranges() {
        assert_eq!(parse_axis("1,1.5, 2").unwrap(), vec![1.0, 1.5, 2.0]);
        assert_eq!(parse_axis("1:5:0.5").unwrap().len(), 9);
        assert_eq!(parse_axis("").unwrap(), Vec::<f64>::new());
        assert!(parse_axis("1,x").is_err());
        assert!(parse_axis("5:1:0.5").is_err());
        assert!(parse_axis("1:1e18:1e-9").unwrap_err().to_string().contains("more than"));
        assert!(parse_axis("0:1e300:1e-300").is_err());
        let mut a = Axes::paper();
        a.eps = vec![1.0, 0.0];
        assert!(a.validate().unwrap_err().to_string().contains("positive"));
        a.eps = vec![];
        assert!(a.validate().unwrap_err().to_string().contains("--eps is empty"));
        a.eps = vec![1.0, 1.0];
        assert!(a.validate().unwrap_err().to_string().contains("twice"));
        a.eps = vec![1.0];
        for bad in [vec![0.5], vec![9.0], vec![1.0, 1.2], vec![f64::NAN]] {
            a.widths = bad.clone();
            assert!(a.validate().is_err(), "{bad:?}");
        }
        a.widths = vec![1.0, 7.5];
        assert!(a.validate().is_ok());
    }
}
