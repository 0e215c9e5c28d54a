//! `trace-bench check`: compare the deterministic counters of a results file with a committed
//! baseline. Timings are never compared. A row fails when a counter grows by more than the
//! relative tolerance, when its mismatch count grows, or when a baseline row is missing.
//!
//! Rows are matched on scene, structure, params, traversal, triangle test and ray kind; device
//! and thread count are ignored (counters do not depend on them), so a baseline taken with one
//! thread checks a run with many.

use crate::results::output::Row;
use std::collections::BTreeMap;

/// Counters compared, by column name: the mean per ray of every counter
/// ([`tb_core::COUNTERS`]), the largest `steps` of a ray, and the oracle mismatches.
pub fn counter_columns() -> Vec<&'static str> {
    tb_core::COUNTERS
        .iter()
        .map(|c| c.per_ray)
        .chain(["steps_max", "mismatches"])
        .collect()
}

fn counter(r: &Row, name: &str) -> Option<f64> {
    match name {
        "mismatches" => r.mismatches.map(|m| m as f64),
        column => r.counter(column),
    }
}

type Key = (String, String, String, String, String, String);

fn key(r: &Row) -> Key {
    (
        r.scene.clone(),
        r.structure.clone(),
        r.params.clone(),
        r.traversal.clone(),
        r.triangle_test.clone(),
        r.ray_kind.clone(),
    )
}

/// One finding of a check.
#[derive(Clone, Debug, PartialEq)]
pub struct Finding {
    pub row: String,
    pub counter: String,
    pub baseline: Option<f64>,
    pub current: Option<f64>,
    /// Relative change (current / baseline − 1), when both exist and baseline > 0.
    pub change: Option<f64>,
    pub failed: bool,
}

/// Compare `current` rows with `baseline` rows. `tolerance` is relative (0.01 = 1 %).
/// Returns all findings (changes and failures); the check passes when none has `failed`.
pub fn compare(baseline: &[Row], current: &[Row], tolerance: f64) -> Vec<Finding> {
    let mut cur: BTreeMap<Key, &Row> = BTreeMap::new();
    for r in current {
        cur.entry(key(r)).or_insert(r);
    }
    let mut base: BTreeMap<Key, &Row> = BTreeMap::new();
    for r in baseline {
        base.entry(key(r)).or_insert(r);
    }
    let mut out = Vec::new();
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
                    if bv == cv {
                        continue;
                    }
                    let grew = if name == "mismatches" {
                        cv > bv
                    } else {
                        cv > bv * (1.0 + tolerance) + 1e-9
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
}
