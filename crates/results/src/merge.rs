//! `trace-bench merge DIR... --out DIR`: one results folder from the shards of a run
//! (`run --shard K/N`, `tb_harness::cluster::shard`).
//!
//! The shards must come from the same effective config (`meta.config_hash`), the same binary
//! (`meta.build.commit` and `features`) and the same partition (`meta.shard.plan`); anything
//! else is refused with one line naming both folders and their values. Rows keep their `host`;
//! they are put in the order an unsharded run writes them (the plan's unit order; within a
//! unit, the shard's order, which `--resume` keeps). Every work unit no shard completed is
//! listed. `convergence.csv`, `images/` (with `images/index.csv`) are merged the same way and
//! `params.csv` is rewritten for the merged rows, so `check`, `table.py` and `plot.py` read
//! the merged folder like any run's.

use crate::output::{read_csv_resume, Row, RowKey};
use crate::Error;
use serde_json::{json, Value};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

/// What a merge did.
#[derive(Debug, Default)]
pub struct MergeReport {
    /// Rows in the merged results.
    pub rows: usize,
    /// Work units no shard completed: `shard K/N: scene structure [params]: R of E rows`.
    pub missing: Vec<String>,
    /// Duplicate rows dropped, torn lines, hosts.
    pub notes: Vec<String>,
}

/// One shard folder, read.
struct ShardDir {
    dir: PathBuf,
    meta: Value,
    k: u64,
    rows: Vec<Row>,
    /// A torn last line of `results.csv` (the shard was interrupted), left out.
    torn: bool,
}

fn refuse(msg: String) -> Error {
    Error::Other(format!("refusing to merge: {msg}"))
}

fn read_shard(dir: &Path) -> Result<ShardDir, Error> {
    let jp = dir.join("results.json");
    let text = std::fs::read_to_string(&jp).map_err(|e| Error::io(&jp, e))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| Error::io(&jp, e.to_string()))?;
    let meta = doc["meta"].clone();
    let k = meta["shard"]["k"].as_u64().ok_or_else(|| {
        Error::io(
            &jp,
            "not a shard (no meta.shard): only the folders of `run --shard K/N` can be merged",
        )
    })?;
    let cp = dir.join("results.csv");
    let (rows, torn) = read_csv_resume(&cp)?;
    Ok(ShardDir {
        dir: dir.to_path_buf(),
        meta,
        k,
        rows,
        torn: torn > 0,
    })
}

/// A value of the metadata as text for messages (`null` when absent).
fn shown(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        Value::Null => "none".into(),
        v => v.to_string(),
    }
}

/// A work unit of the shard plan: scene, structure, params, rows expected, shard.
type PlanUnit = (String, String, String, u64, u64);

/// Where a plan's units and scenes first appear: (scene, structure, params) -> unit, scene ->
/// its first unit.
struct PlanIndex<'a> {
    unit_of: HashMap<(&'a str, &'a str, &'a str), usize>,
    scene_first: HashMap<&'a str, usize>,
}

/// Merge the shard folders `dirs` into `out` (which must not hold results yet).
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<MergeReport, Error> {
    if dirs.is_empty() {
        return Err(Error::Other("merge: no shard folder given".into()));
    }
    if out.join("results.csv").exists() {
        return Err(Error::io(
            out.join("results.csv"),
            "already exists: choose another --out",
        ));
    }
    let shards = dirs
        .iter()
        .map(|d| read_shard(d))
        .collect::<Result<Vec<_>, _>>()?;
    let first = &shards[0];
    let by_k = check_same_run(&shards)?;
    let n = first.meta["shard"]["n"].as_u64().unwrap_or(0);
    let plan = plan_of(&first.meta);
    let index = index_plan(&plan);
    let mut report = MergeReport::default();
    for s in shards.iter().filter(|s| s.torn) {
        report.notes.push(format!(
            "{}: left out a torn last line of results.csv (an interrupted shard: rerun it with \
             --resume)",
            s.dir.display()
        ));
    }
    let rows = ordered_rows(&shards, &index, &mut report);
    report.missing = missing_units(&plan, &rows, &by_k, n);
    let rows: Vec<Row> = rows.into_iter().map(|(_, _, r)| r).collect();
    report.rows = rows.len();
    note_hosts(&rows, &mut report);
    let meta = merged_meta(&shards, &report, n);
    crate::output::write_all(out, meta, &rows)?;
    merge_companions(&shards, out, &index)?;
    Ok(report)
}

/// Check that the shards are of the same run (config, binary, partition) and of different
/// shards; their folders by shard number.
fn check_same_run(shards: &[ShardDir]) -> Result<BTreeMap<u64, &Path>, Error> {
    let first = &shards[0];
    // Same run: config, binary, partition.
    type Field = fn(&Value) -> Value;
    let same: [(&str, Field); 5] = [
        ("config hash", |m| m["config_hash"].clone()),
        ("commit", |m| m["build"]["commit"].clone()),
        ("features", |m| m["build"]["features"].clone()),
        ("shard count", |m| m["shard"]["n"].clone()),
        ("shard plan", |m| m["shard"]["plan"].clone()),
    ];
    for s in &shards[1..] {
        for (what, get) in &same {
            let (a, b) = (get(&first.meta), get(&s.meta));
            if a != b {
                let (a, b) = if *what == "shard plan" {
                    (
                        "one partition".to_string(),
                        "another (different scene files or a different binary)".to_string(),
                    )
                } else {
                    (shown(&a), shown(&b))
                };
                return Err(refuse(format!(
                    "{} has {what} {a}, {} has {what} {b}",
                    first.dir.display(),
                    s.dir.display()
                )));
            }
        }
    }
    let mut by_k: BTreeMap<u64, &Path> = BTreeMap::new();
    for s in shards {
        if let Some(other) = by_k.insert(s.k, &s.dir) {
            return Err(refuse(format!(
                "{} and {} are both shard {}/{}",
                other.display(),
                s.dir.display(),
                s.k,
                shown(&first.meta["shard"]["n"])
            )));
        }
    }
    Ok(by_k)
}

/// The plan of a shard's metadata: units in run order.
fn plan_of(meta: &Value) -> Vec<PlanUnit> {
    meta["shard"]["plan"]
        .as_array()
        .map(|a| {
            a.iter()
                .map(|u| {
                    (
                        shown(&u["scene"]),
                        shown(&u["structure"]),
                        u["params"].as_str().unwrap_or("").to_string(),
                        u["rows"].as_u64().unwrap_or(0),
                        u["shard"].as_u64().unwrap_or(0),
                    )
                })
                .collect()
        })
        .unwrap_or_default()
}

/// The first unit of each (scene, structure, params) and of each scene of the plan.
fn index_plan(plan: &[PlanUnit]) -> PlanIndex<'_> {
    let mut unit_of: HashMap<(&str, &str, &str), usize> = HashMap::new();
    let mut scene_first: HashMap<&str, usize> = HashMap::new();
    for (i, (sc, st, p, _, _)) in plan.iter().enumerate() {
        unit_of.entry((sc, st, p)).or_insert(i);
        scene_first.entry(sc).or_insert(i);
    }
    PlanIndex {
        unit_of,
        scene_first,
    }
}

/// The shards' rows without duplicates, as (unit, arrival, row) in plan order; rows outside
/// the plan (none, from a shard of this plan) last.
fn ordered_rows(
    shards: &[ShardDir],
    index: &PlanIndex,
    report: &mut MergeReport,
) -> Vec<(usize, usize, Row)> {
    let mut seen: HashSet<RowKey> = HashSet::new();
    let mut rows: Vec<(usize, usize, Row)> = Vec::new();
    let mut dropped = 0;
    for s in shards {
        for r in &s.rows {
            if !seen.insert(r.key()) {
                dropped += 1;
                continue;
            }
            // A view's row (`TABLE@VIEW`) belongs to its table's unit.
            let table = match r.scene.rsplit_once('@') {
                Some((t, _)) if !index.scene_first.contains_key(r.scene.as_str()) => t,
                _ => r.scene.as_str(),
            };
            let u = index
                .unit_of
                .get(&(table, r.structure.as_str(), r.params.as_str()))
                .copied()
                .unwrap_or(usize::MAX);
            rows.push((u, rows.len(), r.clone()));
        }
    }
    if dropped > 0 {
        report
            .notes
            .push(format!("{dropped} duplicate rows dropped (kept the first)"));
    }
    rows.sort_by_key(|(u, i, _)| (*u, *i));
    rows
}

/// The plan's units with fewer rows than expected, one line each.
fn missing_units(
    plan: &[PlanUnit],
    rows: &[(usize, usize, Row)],
    by_k: &BTreeMap<u64, &Path>,
    n: u64,
) -> Vec<String> {
    let mut missing = Vec::new();
    let mut count = vec![0u64; plan.len()];
    for (u, _, _) in rows {
        if let Some(c) = count.get_mut(*u) {
            *c += 1;
        }
    }
    for (i, (sc, st, p, want, k)) in plan.iter().enumerate() {
        if count[i] < *want {
            let given = if by_k.contains_key(k) {
                ""
            } else {
                " (shard folder not given)"
            };
            missing.push(format!(
                "shard {k}/{n}: {sc} {st} [{p}]: {} of {want} rows{given}",
                count[i]
            ));
        }
    }
    missing
}

/// Note the hosts of the rows when there are several.
fn note_hosts(rows: &[Row], report: &mut MergeReport) {
    let mut hosts: Vec<String> = Vec::new();
    for r in rows {
        if !hosts.contains(&r.host) {
            hosts.push(r.host.clone());
        }
    }
    if hosts.len() > 1 {
        report.notes.push(format!(
            "rows from {} hosts ({}): compare timings within one host (column host)",
            hosts.len(),
            hosts.join(", ")
        ));
    }
}

/// Merge the companions: convergence.csv and images/ (with index.csv).
fn merge_companions(shards: &[ShardDir], out: &Path, index: &PlanIndex) -> Result<(), Error> {
    let order = |r: &csv::StringRecord, head: &csv::StringRecord| -> (usize, u8) {
        let col = |name: &str| {
            head.iter()
                .position(|h| h == name)
                .and_then(|i| r.get(i))
                .unwrap_or("")
        };
        let (sc, st, p) = (col("scene"), col("structure"), col("params"));
        match index.unit_of.get(&(sc, st, p)) {
            Some(&u) => (u, 1),
            None => (index.scene_first.get(sc).copied().unwrap_or(usize::MAX), 0),
        }
    };
    let dirs: Vec<&Path> = shards.iter().map(|s| s.dir.as_path()).collect();
    merge_csv(&dirs, Path::new("convergence.csv"), out, &order)?;
    for d in &dirs {
        copy_images(&d.join("images"), &out.join("images"))?;
    }
    merge_csv(&dirs, Path::new("images/index.csv"), out, &order)?;
    Ok(())
}

/// The merged folder's metadata: the first shard's, without `shard`, with `merged` (each
/// shard's folder, host, start, duration and status, the units missing), the earliest start,
/// the latest end, `duration_s` the sum of the shards' and the status of the whole.
fn merged_meta(shards: &[ShardDir], report: &MergeReport, n: u64) -> Value {
    let mut meta = shards[0].meta.clone();
    let mut hosts: Vec<Value> = Vec::new();
    for s in shards {
        if !hosts.iter().any(|h| h["name"] == s.meta["host"]["name"]) {
            hosts.push(s.meta["host"].clone());
        }
    }
    let failed = shards.iter().any(|s| s.meta["status"] != "complete");
    let status = match (report.missing.is_empty(), failed) {
        (false, _) => "incomplete",
        (true, true) => "complete-with-failures",
        (true, false) => "complete",
    };
    let start = shards
        .iter()
        .filter_map(|s| s.meta["start"].as_str())
        .min()
        .map(Value::from);
    let end = shards
        .iter()
        .filter_map(|s| s.meta["end"].as_str())
        .max()
        .map(Value::from);
    let duration: f64 = shards
        .iter()
        .filter_map(|s| s.meta["duration_s"].as_f64())
        .sum();
    if let Some(m) = meta.as_object_mut() {
        m.remove("shard");
        m.remove("resumed");
        if hosts.len() > 1 {
            m.insert("host".into(), Value::Array(hosts));
        }
        m.insert("start".into(), start.unwrap_or(Value::Null));
        m.insert("end".into(), end.unwrap_or(Value::Null));
        m.insert(
            "duration_s".into(),
            Value::from((duration * 1e3).round() / 1e3),
        );
        m.insert("status".into(), Value::from(status));
        m.insert(
            "merged".into(),
            json!({
                "n": n,
                "shards": shards.iter().map(|s| json!({
                    "dir": s.dir.display().to_string(),
                    "k": s.k,
                    "host": s.meta["host"]["name"],
                    "start": s.meta["start"],
                    "end": s.meta["end"],
                    "duration_s": s.meta["duration_s"],
                    "status": s.meta["status"],
                    "resumed": s.meta["resumed"],
                    "cost_est_s": s.meta["shard"]["cost_est_s"],
                    "rows": s.rows.len(),
                })).collect::<Vec<_>>(),
                "missing": report.missing,
            }),
        );
    }
    meta
}

/// Merge the CSV `name` of the shard folders into `out/name`: one header, the records in unit
/// order (`order`), identical records once (scene images appear in every shard of the scene).
fn merge_csv(
    dirs: &[&Path],
    name: &Path,
    out: &Path,
    order: &dyn Fn(&csv::StringRecord, &csv::StringRecord) -> (usize, u8),
) -> Result<(), Error> {
    let mut head: Option<csv::StringRecord> = None;
    let mut records: Vec<((usize, u8), usize, csv::StringRecord)> = Vec::new();
    let mut seen = HashSet::new();
    for d in dirs {
        let p = d.join(name);
        if !p.is_file() {
            continue;
        }
        let mut r = csv::Reader::from_path(&p).map_err(|e| Error::io(&p, e))?;
        let h = r.headers().map_err(|e| Error::io(&p, e))?.clone();
        match &head {
            None => head = Some(h.clone()),
            Some(first) if *first != h => {
                return Err(Error::io(&p, "columns differ from the first shard's"))
            }
            Some(_) => {}
        }
        for rec in r.records() {
            // A torn last line of an interrupted shard is left out.
            let Ok(rec) = rec else { continue };
            if seen.insert(rec.iter().map(str::to_string).collect::<Vec<_>>()) {
                records.push((order(&rec, &h), records.len(), rec));
            }
        }
    }
    let Some(head) = head else { return Ok(()) };
    records.sort_by_key(|(o, i, _)| (*o, *i));
    let p = out.join(name);
    if let Some(parent) = p.parent() {
        std::fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
    }
    let mut w = csv::Writer::from_path(&p).map_err(|e| Error::io(&p, e))?;
    w.write_record(&head).map_err(|e| Error::io(&p, e))?;
    for (_, _, rec) in &records {
        w.write_record(rec).map_err(|e| Error::io(&p, e))?;
    }
    w.flush().map_err(|e| Error::io(&p, e))
}

/// Copy the image files under `from` into `to` (not `index.csv`, merged apart); a file that is
/// already there (a scene's render, written by every shard of the scene) is kept.
pub fn copy_images(from: &Path, to: &Path) -> Result<(), Error> {
    if !from.is_dir() {
        return Ok(());
    }
    std::fs::create_dir_all(to).map_err(|e| Error::io(to, e))?;
    for e in std::fs::read_dir(from).map_err(|e| Error::io(from, e))? {
        let e = e.map_err(|e| Error::io(from, e))?;
        let (src, dst) = (e.path(), to.join(e.file_name()));
        if src.is_dir() {
            copy_images(&src, &dst)?;
        } else if e.file_name() != "index.csv" && !dst.exists() {
            std::fs::copy(&src, &dst).map_err(|e| Error::io(&src, e))?;
        }
    }
    Ok(())
}
