//! The plain-text summary printed after a run: one line per row of `results.csv`, full names,
//! the parameters that vary between rows of a structure, and the timing spread.

use std::collections::{BTreeMap, BTreeSet};
use tb_results::output::Row;
use tb_results::pairs::{join, pairs};

/// For each structure, the parameter names whose values differ between its rows.
fn varying_params(rows: &[Row]) -> BTreeMap<&str, BTreeSet<&str>> {
    let mut values: BTreeMap<(&str, &str), BTreeSet<&str>> = BTreeMap::new();
    for r in rows {
        for (k, v) in pairs(&r.params) {
            values.entry((&r.structure, k)).or_default().insert(v);
        }
    }
    let mut out: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for ((s, k), v) in values {
        let e = out.entry(s).or_default();
        if v.len() > 1 {
            e.insert(k);
        }
    }
    out
}

/// The `k=v` of `r`'s varying parameters, or `-`.
fn shown_params(r: &Row, varying: &BTreeMap<&str, BTreeSet<&str>>) -> String {
    let keys = varying.get(r.structure.as_str());
    let shown: Vec<(&str, &str)> = pairs(&r.params)
        .filter(|(k, _)| keys.is_some_and(|ks| ks.contains(k)))
        .collect();
    if shown.is_empty() {
        "-".into()
    } else {
        join(shown)
    }
}

/// A plain-text summary table of rows. `spread` is `(max − min) / median` of the timed runs.
pub fn table(rows: &[Row]) -> String {
    const HEAD: [&str; 16] = [
        "scene",
        "structure",
        "params",
        "traversal",
        "test",
        "device",
        "threads",
        "ray_kind",
        "rays",
        "MRays/s",
        "spread",
        "noisy",
        "steps/ray",
        "prims/ray",
        "build_ms",
        "mismatches",
    ];
    // Text columns are left-aligned, numbers right-aligned.
    const LEFT: usize = 8;
    let varying = varying_params(rows);
    let f = |x: Option<f64>, p: usize| x.map(|v| format!("{v:.p$}")).unwrap_or_else(|| "-".into());
    let mut cells: Vec<Vec<String>> = vec![HEAD.iter().map(|h| h.to_string()).collect()];
    let mut notes = vec![String::new()];
    for r in rows {
        let spread = match (r.trace_ms_min, r.trace_ms_median, r.trace_ms_max) {
            (Some(lo), Some(med), Some(hi)) if med > 0.0 => {
                format!("{:.0}%", 100.0 * (hi - lo) / med)
            }
            _ => "-".into(),
        };
        cells.push(vec![
            r.scene.clone(),
            r.structure.clone(),
            shown_params(r, &varying),
            r.traversal.clone(),
            match r.triangle_test.as_str() {
                "watertight" => "wt".into(),
                "moller-trumbore" => "mt".into(),
                t => t.into(),
            },
            r.device.clone(),
            // GPU rows: one host thread drives the device; the column counts CPU workers.
            if r.device == "gpu" {
                "-".into()
            } else {
                r.threads.to_string()
            },
            r.ray_kind.clone(),
            r.rays.to_string(),
            f(r.mrays_per_s, 2),
            spread,
            match r.noisy {
                Some(true) => "yes".into(),
                _ => "-".into(),
            },
            f(r.steps_per_ray, 1),
            f(r.prims_per_ray, 1),
            f(r.build_ms, 1),
            r.mismatches
                .map(|m| m.to_string())
                .unwrap_or_else(|| "-".into()),
        ]);
        notes.push(r.note.clone());
    }
    // Layout by comfy-table: no borders, two spaces between columns, text left and numbers
    // right; the notes of rows that have one in a last column.
    let with_notes = notes.iter().any(|n| !n.is_empty());
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::NOTHING)
        .set_content_arrangement(comfy_table::ContentArrangement::Disabled);
    let mut head = cells[0].clone();
    if with_notes {
        head.push("note".into());
    }
    t.set_header(head);
    for (line, note) in cells.iter().zip(&notes).skip(1) {
        let mut line = line.clone();
        if with_notes {
            line.push(note.clone());
        }
        t.add_row(line);
    }
    for (c, col) in t.column_iter_mut().enumerate() {
        col.set_padding((0, 2));
        if (LEFT..HEAD.len()).contains(&c) {
            col.set_cell_alignment(comfy_table::CellAlignment::Right);
        }
    }
    let mut out: String = t.lines().map(|l| l.trim_end().to_string() + "\n").collect();
    if out.is_empty() {
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(params: &str, traversal: &str) -> Row {
        Row {
            scene: "sibenik".into(),
            structure: "rtree".into(),
            params: params.into(),
            traversal: traversal.into(),
            device: "cpu".into(),
            threads: 1,
            triangle_test: "watertight".into(),
            ray_kind: "primary".into(),
            trace_ms_min: Some(9.0),
            trace_ms_median: Some(10.0),
            trace_ms_max: Some(12.0),
            ..Default::default()
        }
    }

    #[test]
    fn rows_can_be_told_apart() {
        let rows = [
            row("m=2;strategy=min-volume;reinsert=true", "stackless"),
            row("m=2;strategy=r-star;reinsert=true", "stackless"),
            row("m=2;strategy=r-star;reinsert=true", "recursive-direction"),
        ];
        let t = table(&rows);
        let lines: Vec<&str> = t.lines().collect();
        assert!(lines[0].contains("params") && lines[0].contains("threads"));
        // Only the varying parameter is shown, and full traversal names.
        assert!(lines[1].contains("strategy=min-volume") && !lines[1].contains("m=2"));
        assert!(lines[3].contains("recursive-direction"));
        assert!(
            lines[1].contains("30%"),
            "spread (12 - 9) / 10: {}",
            lines[1]
        );
        // Every line distinct.
        let set: BTreeSet<&str> = lines.iter().copied().collect();
        assert_eq!(set.len(), lines.len());
    }
}
