//! Quantiles and medians of measured figures, written once.
//!
//! Why here: every bench and summary of the project reports medians and
//! percentiles (the gateway's relay latency, the lab's control jitter, the
//! launch and study benches, the sweep's budget table), and six copies had
//! three rules for empty input (NaN, a panic, `None`). The runtime is the
//! one crate every binary and bench can reach, and without features this
//! module is all of it (no dependencies, not even the protocol's, so the
//! protocol's own benches use it too). Hand-written rather than
//! a histogram crate (`hdrhistogram`): the inputs are a few thousand exact
//! values kept anyway, and an exact rank needs no bucketing.
//!
//! The rules: [`quantile`] is the value at rank round((n − 1) · q) of the
//! sorted values (nearest rank; q = 0 the least, q = 1 the greatest);
//! [`median`] is the middle value, or the mean of the two middle ones for
//! an even count (a result table's median). Both are `None` for no values.

/// The `q`-quantile (0 ≤ q ≤ 1) of `values`, by nearest rank; `None` when
/// there are none. Values that do not compare (NaN) sort as equal.
pub fn quantile<T: Copy + PartialOrd>(values: &[T], q: f64) -> Option<T> {
    let mut sorted = values.to_vec();
    sorted.sort_by(|a, b| a.partial_cmp(b).unwrap_or(core::cmp::Ordering::Equal));
    let last = sorted.len().checked_sub(1)?;
    let rank = (last as f64 * q.clamp(0.0, 1.0)).round() as usize;
    sorted.get(rank).copied()
}

/// The median of `values` (the mean of the two middle ones for an even
/// count); `None` when there are none.
pub fn median<T: Copy + PartialOrd + Into<f64>>(values: &[T]) -> Option<f64> {
    let mut sorted: Vec<f64> = values.iter().map(|&v| v.into()).collect();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(sorted[n / 2]),
        _ => Some((sorted[n / 2 - 1] + sorted[n / 2]) / 2.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_quantiles_and_two_middle_medians() {
        let v = [5u64, 1, 4, 2, 3];
        assert_eq!(quantile(&v, 0.0), Some(1));
        assert_eq!(quantile(&v, 0.5), Some(3));
        assert_eq!(quantile(&v, 0.99), Some(5));
        assert_eq!(quantile(&v, 1.0), Some(5));
        assert_eq!(quantile(&[1.0, 2.0, 3.0, 4.0], 0.5), Some(3.0), "rank round(1.5) = 2");
        assert_eq!(median(&[1.0, 2.0, 3.0, 4.0]), Some(2.5));
        assert_eq!(median(&[3u32, 1, 2]), Some(2.0));
        let none: [f64; 0] = [];
        assert_eq!(quantile(&none, 0.5), None);
        assert_eq!(median(&none), None);
        assert_eq!(
            quantile(&[std::time::Duration::from_millis(7)], 0.9),
            Some(std::time::Duration::from_millis(7))
        );
    }
}
