//! Error of an image against a reference, over all pixels (`n` of them, `x` the image, `r` the
//! reference, per pixel):
//!
//! - RMSE: `sqrt( (1/n) · Σ (x − r)² )`, in the image's units;
//! - relative MSE: `(1/n) · Σ (x − r)² / (r² + ε)` with `ε = 0.01` ([`REL_MSE_EPSILON`]), the
//!   error measure of Rousselle, Knaus and Zwicker (2011, "Adaptive sampling and reconstruction
//!   using greedy error minimization"), scale-free and insensitive to the few bright pixels;
//!   `ε` keeps black reference pixels from dominating.
//!
//! For a Monte Carlo estimator both fall as `1/spp` in MSE (RMSE as `1/sqrt(spp)`) until the
//! reference's own noise is reached.

/// The `ε` of the relative MSE.
pub const REL_MSE_EPSILON: f64 = 0.01;

/// The mean over pixels of `err(x_i, r_i)` (in `f64`; images of one size).
fn mean_error(x: &[f32], r: &[f32], err: impl Fn(f64, f64) -> f64) -> f64 {
    assert_eq!(x.len(), r.len(), "images of one size");
    let n = x.len().max(1) as f64;
    let s: f64 = x
        .iter()
        .zip(r)
        .map(|(&a, &b)| err(a as f64, b as f64))
        .sum();
    s / n
}

/// Root-mean-square error of `x` against `r` (same length; a NaN sample makes it NaN).
pub fn rmse(x: &[f32], r: &[f32]) -> f64 {
    mean_error(x, r, |a, b| (a - b) * (a - b)).sqrt()
}

/// Relative mean squared error of `x` against `r`: `mean((x − r)² / (r² + ε))`, `ε` =
/// [`REL_MSE_EPSILON`].
pub fn rel_mse(x: &[f32], r: &[f32]) -> f64 {
    mean_error(x, r, |a, b| (a - b) * (a - b) / (b * b + REL_MSE_EPSILON))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formulas() {
        assert_eq!(rmse(&[1.0, 1.0], &[1.0, 1.0]), 0.0);
        assert!((rmse(&[0.0, 2.0], &[1.0, 1.0]) - 1.0).abs() < 1e-12);
        assert!((rmse(&[0.0, 0.0, 0.0, 4.0], &[0.0; 4]) - 2.0).abs() < 1e-12);
        // (0.5² / (1 + 0.01) + 0) / 2
        let e = rel_mse(&[1.5, 0.0], &[1.0, 0.0]);
        assert!((e - 0.25 / 1.01 / 2.0).abs() < 1e-12);
    }
}
