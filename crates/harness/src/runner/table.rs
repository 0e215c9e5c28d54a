//! The plain-text summary printed after a run.

use crate::output::Row;

/// A plain-text summary table of rows.
pub fn table(rows: &[Row]) -> String {
    let mut out = String::new();
    out.push_str(&format!(
        "{:<22} {:<12} {:<10} {:<9} {:>3} {:<8} {:>9} {:>9} {:>8} {:>8} {:>9} {:>10}\n",
        "scene",
        "structure",
        "traversal",
        "test",
        "dev",
        "rays",
        "count",
        "MRays/s",
        "steps",
        "prims",
        "build_ms",
        "mismatch"
    ));
    for r in rows {
        let f =
            |x: Option<f64>, p: usize| x.map(|v| format!("{v:.p$}")).unwrap_or_else(|| "-".into());
        out.push_str(&format!(
            "{:<22} {:<12} {:<10} {:<9} {:>3} {:<8} {:>9} {:>9} {:>8} {:>8} {:>9} {:>10}{}\n",
            truncate(&r.scene, 22),
            truncate(&r.structure, 12),
            truncate(&r.traversal, 10),
            if r.triangle_test == "watertight" {
                "wt"
            } else {
                "mt"
            },
            // CPU rows: the thread count; GPU rows: `gpu`.
            if r.device == "gpu" {
                "gpu".to_string()
            } else {
                r.threads.to_string()
            },
            truncate(&r.ray_kind, 8),
            r.rays,
            f(r.mrays_per_s, 2),
            f(r.steps_per_ray, 1),
            f(r.prims_per_ray, 1),
            f(r.build_ms, 1),
            r.mismatches
                .map(|m| m.to_string())
                .unwrap_or_else(|| "-".into()),
            if r.note.is_empty() {
                String::new()
            } else {
                format!("  ({})", r.note)
            }
        ));
    }
    out
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(n - 1).collect();
        t.push('…');
        t
    }
}
