//! What a claim is ([`ClaimKind`]) and whether it can be decided at all: a claim whose time
//! band is narrower than the floor between runs can never agree while its intervals are the
//! floor's, a time band of no width never, and a claim may say why it cannot be decided
//! (`undecidable = "…"`). The evaluator then shows `undecidable` where it would show
//! `inconclusive`.

use super::measure::{fmt, Measure};
use super::schema::{Claim, Test};

/// Why `c` cannot be decided: its own `undecidable` reason (known before measuring), or its
/// time band. While a time's interval is the floor's (`measured` false: fewer than
/// [`super::eval::MIN_PROCESSES`] processes), it is at least `v / (1 + floor) ..
/// v · (1 + floor)`, so a band `[min, max]` with `max / min < (1 + floor)²` can never hold the
/// whole interval: the claim can come out outside its band, never inside. Where every group's
/// interval was measured between processes (`measured`), its width is what the processes'
/// spread gives, which no rule known before the rows bounds from below: a band is then
/// undecidable only when it has no width (`min = max`, a tolerance of 0), which no interval of
/// a time can lie in.
pub(crate) fn undecidable(c: &Claim, floor: f64, measured: bool) -> Option<String> {
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
    if measured {
        return (lo > 0.0 && hi <= lo).then(|| {
            format!(
                "the band {shown} has no width: a time's interval, measured between processes, \
                 has some"
            )
        });
    }
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
