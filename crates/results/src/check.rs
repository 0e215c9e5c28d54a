//! `trace-bench check`: compare the deterministic columns of a results file with a committed
//! baseline. Timings are never compared. A row fails when a counter (mean or maximum per ray)
//! grows by more than the relative tolerance, when its mismatches or capped rays grow at all,
//! when a column that cannot change without a change of rays or answers changes at all (rays,
//! validated rays, hit rate), when a baseline row is missing, or when the results hold the same
//! row twice (the same scene, structure, parameters, traversal, device, threads, triangle test
//! and ray kind: a file two runs wrote into).
//!
//! Rows are matched on scene, structure, params, traversal, triangle test and ray kind; device
//! and thread count are ignored (counters do not depend on them), so a baseline taken with one
//! thread checks a run with many.

use crate::output::{CountedKey, Row};
use std::collections::BTreeMap;

/// Columns compared, by name: the mean and the maximum per ray of every counter
/// ([`tb_core::COUNTERS`]), then the columns of [`Rule::NoGrowth`] and [`Rule::Exact`].
pub fn counter_columns() -> Vec<&'static str> {
    tb_core::COUNTERS
        .iter()
        .flat_map(|c| [c.per_ray, c.max])
        .chain([
            "mismatches",
            "capped_rays",
            "rays",
            "validated_rays",
            "hit_rate",
        ])
        .collect()
}

/// How a column may change against the baseline.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// Within the relative tolerance (counters: a better structure may lower them).
    Tolerance,
    /// Never up (mismatches with the oracle, rays ended by a step cap).
    NoGrowth,
    /// Never at all (the rays, the rays validated, the share of rays that hit).
    Exact,
}

/// The rule of column `name`.
pub fn rule(name: &str) -> Rule {
    match name {
        "mismatches" | "capped_rays" => Rule::NoGrowth,
        "rays" | "validated_rays" | "hit_rate" => Rule::Exact,
        _ => Rule::Tolerance,
    }
}

fn counter(r: &Row, name: &str) -> Option<f64> {
    match name {
        "mismatches" => r.mismatches.map(|m| m as f64),
        "capped_rays" => r.capped_rays.map(|m| m as f64),
        "rays" => Some(r.rays as f64),
        "validated_rays" => r.validated_rays.map(|m| m as f64),
        "hit_rate" => r.hit_rate,
        column => r.counter(column),
    }
}

/// One finding of a check.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    /// The row compared: scene, structure, `[params]`, traversal, triangle test, ray kind.
    pub row: String,
    /// The counter column, or `(row)` for a baseline row the run lacks.
    pub counter: String,
    /// The baseline's value (`None`: not measured there).
    pub baseline: Option<f64>,
    /// The run's value (`None`: not measured there).
    pub current: Option<f64>,
    /// Relative change (current / baseline − 1), when both exist and baseline > 0.
    pub change: Option<f64>,
    /// Whether this finding fails the check.
    pub failed: bool,
}

/// Whether `t` is a relative tolerance [`compare`] takes: finite and at least 0 (`None`), or
/// why not.
pub fn bad_tolerance(t: f64) -> Option<&'static str> {
    if !t.is_finite() {
        Some("must be a finite number")
    } else if t < 0.0 {
        Some("must be at least 0")
    } else {
        None
    }
}

/// Compare `current` rows with `baseline` rows. `tolerance` is relative (0.01 = 1 %; see
/// [`bad_tolerance`]: a NaN tolerance would let every growth pass).
/// Returns all findings (changes and failures); the check passes when none has `failed`.
pub fn compare(baseline: &[Row], current: &[Row], tolerance: f64) -> Vec<Finding> {
    assert!(
        bad_tolerance(tolerance).is_none(),
        "check::compare: tolerance {tolerance} (callers check it with bad_tolerance)"
    );
    let mut out = duplicates(current);
    let mut cur: BTreeMap<CountedKey, &Row> = BTreeMap::new();
    for r in current {
        cur.entry(r.counted_key()).or_insert(r);
    }
    let mut base: BTreeMap<CountedKey, &Row> = BTreeMap::new();
    for r in baseline {
        base.entry(r.counted_key()).or_insert(r);
    }
    for (k, b) in &base {
        let label = format!("{} {} [{}] {} {} {}", k.0, k.1, k.2, k.3, k.4, k.5);
        let Some(c) = cur.get(k) else {
            out.push(Finding {
                row: label,
                counter: "(row)".into(),
                baseline: None,
                current: None,
                change: None,
                failed: true,
            });
            continue;
        };
        for name in counter_columns() {
            let (bv, cv) = (counter(b, name), counter(c, name));
            match (bv, cv) {
                (None, None) => {}
                (Some(bv), Some(cv)) => {
                    if bv == cv && bv.is_finite() {
                        continue;
                    }
                    // A counter that is not a number (NaN, ±inf) in either file is no figure a
                    // run writes: it fails, whatever the rule (a NaN would pass every
                    // comparison by comparing false).
                    let grew = !bv.is_finite()
                        || !cv.is_finite()
                        || match rule(name) {
                            Rule::NoGrowth => cv > bv,
                            Rule::Exact => (cv - bv).abs() > 1e-9 * bv.abs().max(1.0),
                            Rule::Tolerance => cv > bv * (1.0 + tolerance) + 1e-9,
                        };
                    let change = if bv > 0.0 { Some(cv / bv - 1.0) } else { None };
                    out.push(Finding {
                        row: label.clone(),
                        counter: name.into(),
                        baseline: Some(bv),
                        current: Some(cv),
                        change,
                        failed: grew,
                    });
                }
                (bv, cv) => out.push(Finding {
                    row: label.clone(),
                    counter: name.into(),
                    baseline: bv,
                    current: cv,
                    change: None,
                    // A counter that the baseline had and the run lost is a regression of the
                    // harness; a new counter is not.
                    failed: bv.is_some(),
                }),
            }
        }
    }
    out
}

/// Rows of `rows` with the identity of an earlier row (two runs' rows in one file).
fn duplicates(rows: &[Row]) -> Vec<Finding> {
    let mut seen = std::collections::BTreeSet::new();
    rows.iter()
        .filter(|r| !seen.insert(r.key()))
        .map(|r| Finding {
            row: format!(
                "{} {} [{}] {} {} {} {} threads {}",
                r.scene,
                r.structure,
                r.params,
                r.traversal,
                r.triangle_test,
                r.ray_kind,
                r.device,
                r.threads
            ),
            counter: "(duplicate row)".into(),
            baseline: None,
            current: None,
            change: None,
            failed: true,
        })
        .collect()
}

/// A table of findings for the terminal.
pub fn report(findings: &[Finding]) -> String {
    let mut s = String::new();
    if findings.is_empty() {
        return s;
    }
    s.push_str(&format!(
        "{:<6} {:<60} {:<17} {:>12} {:>12} {:>9}\n",
        "", "row", "counter", "baseline", "current", "change"
    ));
    let f = |x: Option<f64>| {
        x.map(|v| format!("{v:.4}"))
            .unwrap_or_else(|| "missing".into())
    };
    for x in findings {
        s.push_str(&format!(
            "{:<6} {:<60} {:<17} {:>12} {:>12} {:>9}\n",
            if x.failed { "FAIL" } else { "ok" },
            x.row,
            x.counter,
            f(x.baseline),
            f(x.current),
            x.change
                .map(|c| format!("{:+.2}%", c * 100.0))
                .unwrap_or_default()
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(steps: f64) -> Row {
        Row {
            scene: "s".into(),
            structure: "bvh".into(),
            traversal: "ordered".into(),
            triangle_test: "watertight".into(),
            ray_kind: "primary".into(),
            steps_per_ray: Some(steps),
            mismatches: Some(0),
            ..Default::default()
        }
    }

    #[test]
    fn growth_beyond_tolerance_fails_and_shrinking_passes() {
        let base = vec![row(10.0)];
        assert!(compare(&base, &[row(10.0)], 0.01).is_empty());
        assert!(!compare(&base, &[row(10.05)], 0.01).iter().any(|f| f.failed));
        assert!(compare(&base, &[row(10.2)], 0.01).iter().any(|f| f.failed));
        assert!(!compare(&base, &[row(8.0)], 0.01).iter().any(|f| f.failed));
        // A missing row fails.
        assert!(compare(&base, &[], 0.01).iter().any(|f| f.failed));
        // Any new mismatch fails, whatever the tolerance.
        let mut bad = row(10.0);
        bad.mismatches = Some(1);
        assert!(compare(&base, &[bad], 0.5).iter().any(|f| f.failed));
    }

    /// A counter that is not a number, in the results or in the baseline
    /// (both alike too), fails whatever the tolerance; so does an infinite one.
    #[test]
    fn a_counter_that_is_not_a_number_fails() {
        for (b, c) in [
            (f64::NAN, 10.0),
            (10.0, f64::NAN),
            (f64::NAN, f64::NAN),
            (f64::INFINITY, f64::INFINITY),
            (10.0, f64::INFINITY),
        ] {
            let found = compare(&[row(b)], &[row(c)], 0.5);
            assert!(found.iter().any(|f| f.failed), "{b} -> {c}: {found:?}");
        }
        assert_eq!(bad_tolerance(f64::NAN), Some("must be a finite number"));
        assert_eq!(
            bad_tolerance(f64::INFINITY),
            Some("must be a finite number")
        );
        assert_eq!(bad_tolerance(-1.0), Some("must be at least 0"));
        assert_eq!(bad_tolerance(0.0), None);
    }

    /// The corruptions a hand-edited or twice-written results file shows: each
    /// fails the check whatever the tolerance, and the untouched file passes.
    #[test]
    fn corrupted_rows_fail() {
        let mut b = row(10.0);
        b.rays = 1000;
        b.validated_rays = Some(1000);
        b.capped_rays = Some(0);
        b.interior_max = Some(40);
        b.hit_rate = Some(0.75);
        let base = vec![b.clone()];
        assert!(compare(&base, &[b.clone()], 0.5).is_empty());
        type Edit = (&'static str, fn(&mut Row));
        let edits: [Edit; 6] = [
            ("validated_rays", |r| r.validated_rays = Some(0)),
            ("capped_rays", |r| r.capped_rays = Some(3)),
            ("interior_max", |r| r.interior_max = Some(80)),
            ("hit_rate", |r| r.hit_rate = Some(0.375)),
            ("rays", |r| r.rays = 999),
            ("hit_rate up", |r| r.hit_rate = Some(0.8)),
        ];
        for (what, edit) in edits {
            let mut c = b.clone();
            edit(&mut c);
            assert!(
                compare(&base, &[c], 0.5).iter().any(|f| f.failed),
                "{what} passed"
            );
        }
        // The same row twice (two runs into one file); another thread count is not a duplicate.
        let f = compare(&base, &[b.clone(), b.clone()], 0.5);
        assert!(f.iter().any(|f| f.failed && f.counter == "(duplicate row)"));
        let mut t2 = b.clone();
        t2.threads = 2;
        assert!(compare(&base, &[b, t2], 0.5).is_empty());
    }
}
