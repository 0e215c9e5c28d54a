//! Timed repeats: medians and the timing columns of a row.

use crate::output::Row;

/// Median of `v` (sorted in place).
pub fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Fill `trace_ms_{min,median,max}` and `mrays_per_s` from the times (ms) of the timed runs
/// over `rays` rays.
pub fn fill(row: &mut Row, times: &mut [f64], rays: usize) {
    let med = median(times);
    row.trace_ms_min = times.first().copied();
    row.trace_ms_max = times.last().copied();
    row.trace_ms_median = Some(med);
    row.mrays_per_s = Some(rays as f64 / (med * 1e3).max(1e-12));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_columns() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        let mut row = Row::default();
        fill(&mut row, &mut [2.0, 1.0, 4.0], 1000);
        assert_eq!(row.trace_ms_min, Some(1.0));
        assert_eq!(row.trace_ms_max, Some(4.0));
        assert_eq!(row.mrays_per_s, Some(0.5));
    }
}
