//! The statistics a row carries of its timed runs and the claims read back: the median
//! (`trace_ms_median`) and the distribution-free interval of the median (`trace_ms_ci`).

/// The distribution-free 95 % confidence interval of the median of `v` (order statistics,
/// normal approximation of the binomial: ranks `n/2 ∓ 0.98·√n`; Conover 1999); the whole range
/// for fewer than 6 values.
pub fn median_ci(v: &[f64]) -> (f64, f64) {
    let mut s = v.to_vec();
    s.sort_by(|a, b| a.total_cmp(b));
    let n = s.len();
    if n == 0 {
        return (f64::NAN, f64::NAN);
    }
    if n < 6 {
        return (s[0], s[n - 1]);
    }
    let h = 0.98 * (n as f64).sqrt();
    let lo = ((n as f64 / 2.0 - h).floor() as usize).clamp(1, n) - 1;
    let hi = ((n as f64 / 2.0 + 1.0 + h).ceil() as usize).clamp(1, n) - 1;
    (s[lo], s[hi])
}

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
