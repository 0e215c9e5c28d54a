//! What a claim is ([`ClaimKind`]) and whether it can be decided at all: a claim whose time
//! band is narrower than the floor between runs can never agree, whatever is measured, and a
//! claim may say why it cannot be decided (`undecidable = "…"`). Both are known before any row
//! is read; the evaluator then shows `undecidable` where it would show `inconclusive`.

use super::measure::{fmt, Measure};
use super::schema::{Claim, Test};

/// Why `c` cannot be decided, before measuring: its own `undecidable` reason, or a time band
/// narrower than the floor `floor` (a time's interval is at least `v / (1 + floor) ..
/// v · (1 + floor)`, so a band `[min, max]` with `max / min < (1 + floor)²` can never hold the
/// whole interval: the claim can come out outside its band, never inside).
pub(crate) fn undecidable(c: &Claim, floor: f64) -> Option<String> {
    if let Some(r) = &c.undecidable {
        return Some(r.clone());
    }
    let timed = c
        .measures()
        .any(|x| Measure::parse(x).is_ok_and(|m| m.floored()));
    if !timed || floor <= 0.0 {
        return None;
    }
    let (lo, hi, shown) = ratio_band(&c.test)?;
    let need = (1.0 + floor) * (1.0 + floor);
    (lo > 0.0 && hi / lo < need).then(|| {
        format!(
            "the band {shown} spans a factor {} in the compared ratio, less than a time's \
             interval at the ±{} % floor between runs ({}): it can fall outside the band, \
             never inside",
            fmt(hi / lo),
            fmt(100.0 * floor),
            fmt(need)
        )
    })
}

/// A two-sided band test's band as a band on the compared ratio of times (a value, a ratio,
/// a speedup; a gain's `1 − ratio`; equality's `1 ± tolerance`), and the band as written.
fn ratio_band(t: &Test) -> Option<(f64, f64, String)> {
    match t {
        Test::Value {
            min: Some(a),
            max: Some(b),
            ..
        }
        | Test::Ratio {
            min: Some(a),
            max: Some(b),
            ..
        }
        | Test::Speedup {
            min: Some(a),
            max: Some(b),
            ..
        } => Some((*a, *b, format!("[{}, {}]", fmt(*a), fmt(*b)))),
        Test::Gain {
            min: Some(a),
            max: Some(b),
            ..
        } => Some((
            1.0 - b / 100.0,
            1.0 - a / 100.0,
            format!("[{}, {}] %", fmt(*a), fmt(*b)),
        )),
        Test::Equal { tolerance, .. } if *tolerance < 1.0 => Some((
            1.0 - tolerance,
            1.0 + tolerance,
            format!("±{} %", fmt(100.0 * tolerance)),
        )),
        _ => None,
    }
}
