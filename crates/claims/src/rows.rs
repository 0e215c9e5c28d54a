//! Rows of any CSV a run writes, for the claims evaluator: named columns as text, each row
//! knowing its file stem (`results`, `dynamic`, `weights`, …).

use crate::Error;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// One CSV row: its file stem, and the cells by column.
#[derive(Clone, Debug)]
pub struct Row {
    /// The stem of the CSV file it was read from (`results`, `dynamic`, `weights`, …).
    pub file: String,
    /// Where it was read from (folder or file), for messages.
    pub origin: Arc<PathBuf>,
    header: Arc<Vec<String>>,
    cells: Vec<String>,
    /// From a CSV with the columns trace-bench writes (results, dynamic, weights, …).
    ours: bool,
    /// The commit that made it (its run's `results.json`, `meta.build.commit`), where known.
    made_by: Option<Arc<str>>,
}

impl Row {
    /// A cell, `None` when the row has no such column (an empty cell is `Some("")`).
    pub fn get(&self, col: &str) -> Option<&str> {
        if col == "file" {
            return Some(&self.file);
        }
        self.header
            .iter()
            .position(|h| h == col)
            .and_then(|i| self.cells.get(i))
            .map(String::as_str)
    }

    /// A numeric cell; `None` when absent, empty or not a number.
    pub fn num(&self, col: &str) -> Option<f64> {
        self.get(col).and_then(|s| s.trim().parse::<f64>().ok())
    }

    /// A `;`-separated list of numbers (`trace_ms_runs`, `build_ms_runs`); empty when absent.
    pub fn nums(&self, col: &str) -> Vec<f64> {
        self.get(col)
            .unwrap_or("")
            .split(';')
            .filter_map(|x| x.trim().parse().ok())
            .collect()
    }

    /// The commit of the binary that made the row (`-dirty` with uncommitted changes), read
    /// from its run's `results.json` beside the CSV; `None` where there is none.
    pub fn made_by(&self) -> Option<&str> {
        self.made_by.as_deref()
    }

    /// Whether the row was made by the current `methods` (see
    /// [`crate::eval::Options::methods`]): every `NAME=VERSION` of its `method` column at
    /// `methods`' version for that name (a name `methods` does not know, such as a family
    /// this binary lacks, is not held against it). A results row without a `method` is of
    /// version 0 of every method, so never current; rows of other CSVs are not checked, nor
    /// any row where `methods` is empty.
    pub fn current(&self, methods: &BTreeMap<String, u32>) -> bool {
        if methods.is_empty() || self.file != "results" {
            return true;
        }
        let cell = self.get("method").unwrap_or("").trim();
        !cell.is_empty()
            && kv(cell).iter().all(|(k, v)| {
                methods
                    .get(*k)
                    .is_none_or(|cur| v.trim().parse::<u32>().ok() == Some(*cur))
            })
    }

    /// The build a row's figures come from: scene table x structure x params.
    pub fn build_key(&self) -> String {
        format!(
            "{}|{}|{}",
            self.table().unwrap_or(""),
            self.get("structure").unwrap_or(""),
            self.get("params").unwrap_or("")
        )
    }

    /// The scene table's label: the `scene` column before `@`.
    pub fn table(&self) -> Option<&str> {
        self.get("scene").map(|s| s.split('@').next().unwrap_or(s))
    }

    /// The `params` column as a map (`k=v;k=v`).
    pub fn params(&self) -> BTreeMap<&str, &str> {
        kv(self.get("params").unwrap_or(""))
    }

    /// One `build_stats` entry.
    pub fn build_stat(&self, key: &str) -> Option<f64> {
        kv(self.get("build_stats").unwrap_or(""))
            .get(key)
            .and_then(|v| v.parse().ok())
    }

    /// The identity of a results row (the row is the same measurement in two folders; the
    /// same row of two processes of a run, `process`, is two measurements).
    fn identity(&self) -> String {
        if self.file == "results" {
            [
                "scene",
                "structure",
                "params",
                "traversal",
                "device",
                "threads",
                "triangle_test",
                "ray_kind",
                "process",
            ]
            .iter()
            .map(|c| self.get(c).unwrap_or(""))
            .collect::<Vec<_>>()
            .join("\u{1f}")
        } else {
            format!("{}\u{1f}{}", self.file, self.cells.join("\u{1f}"))
        }
    }
}

/// `k=v;k=v` → map.
pub(crate) fn kv(s: &str) -> BTreeMap<&str, &str> {
    tb_results::pairs::pairs(s).collect()
}

/// The rows of several results folders and CSV files, the later's row replacing the earlier's
/// with the same identity.
#[derive(Clone, Debug, Default)]
pub struct RowSet {
    /// The rows, in read order.
    pub rows: Vec<Row>,
    /// Rows replaced by a later source's row of the same identity.
    pub replaced: usize,
    /// The sources read.
    pub sources: Vec<PathBuf>,
}

/// The CSV files of folder `p` that hold rows: every `*.csv` in it but `params.csv`, sorted.
fn csv_files(p: &Path) -> Result<Vec<PathBuf>, Error> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(p)
        .map_err(|e| Error::io(p, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|f| {
            f.extension().is_some_and(|x| x == "csv")
                && f.file_name().is_some_and(|n| n != "params.csv")
        })
        .collect();
    v.sort();
    Ok(v)
}

/// The CSV files a folder given as a source holds: its own ([`csv_files`]), or where it has
/// none, those of its subfolders, each taken the same way (a reproduce or reference folder as
/// committed: `runs/PAPER/N-RUN/results.csv`). A folder with CSVs of its
/// own is not entered further (a run of several processes: the merged rows, not each
/// process's again).
fn source_files(p: &Path, depth: usize) -> Result<Vec<PathBuf>, Error> {
    let own = csv_files(p)?;
    if !own.is_empty() || depth == 0 {
        return Ok(own);
    }
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(p)
        .map_err(|e| Error::io(p, e))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|d| d.is_dir() && !d.is_symlink())
        .collect();
    dirs.sort();
    let mut out = Vec::new();
    for d in dirs {
        out.extend(source_files(&d, depth - 1)?);
    }
    Ok(out)
}

impl RowSet {
    /// Whether folder `p` holds a CSV that [`RowSet::read`] reads (a run that failed before
    /// writing a row leaves none).
    pub fn holds_rows(p: &Path) -> bool {
        p.is_dir() && csv_files(p).is_ok_and(|v| !v.is_empty())
    }

    /// Read each path: a folder gives every `*.csv` in it but `params.csv` (where it has none,
    /// those of the folders under it: [`source_files`]); a file is one CSV.
    pub fn read(paths: &[PathBuf]) -> Result<RowSet, Error> {
        let mut set = RowSet::default();
        let mut index: HashMap<String, usize> = HashMap::new();
        for p in paths {
            let files = if p.is_dir() {
                let v = source_files(p, 4)?;
                if v.is_empty() {
                    return Err(Error::io(
                        p,
                        "no CSV file in this folder or the folders under it",
                    ));
                }
                v
            } else if p.exists() {
                vec![p.clone()]
            } else {
                return Err(Error::io(p, "no such file or folder"));
            };
            set.sources.push(p.clone());
            let origin = Arc::new(p.clone());
            for f in files {
                for row in read_csv(&f, &origin)? {
                    let id = row.identity();
                    match index.get(&id) {
                        Some(&i) => {
                            set.rows[i] = row;
                            set.replaced += 1;
                        }
                        None => {
                            index.insert(id, set.rows.len());
                            set.rows.push(row);
                        }
                    }
                }
            }
        }
        Ok(set)
    }
}

impl RowSet {
    /// [`RowSet::read`], refusing a source (folder or file) with no row of a CSV trace-bench
    /// writes: an unrelated CSV, or results without rows.
    pub fn read_results(paths: &[PathBuf]) -> Result<RowSet, Error> {
        for p in paths {
            let one = RowSet::read(std::slice::from_ref(p))?;
            if !one.rows.iter().any(|r| r.ours) {
                return Err(Error::io(
                    p,
                    "holds no trace-bench results: no row of a CSV with the columns trace-bench \
                     writes (results.csv, dynamic.csv, weights.csv)",
                ));
            }
        }
        RowSet::read(paths)
    }
}

/// The cells of a row of a CSV trace-bench writes: each numeric column's cell empty or a
/// finite number, each boolean column's empty, `true` or `false`.
fn check_cells(
    f: &Path,
    line: usize,
    header: &[String],
    rec: &csv::StringRecord,
) -> Result<(), Error> {
    use super::columns::{known, Kind};
    for (col, cell) in header.iter().zip(rec.iter()) {
        let cell = cell.trim();
        if cell.is_empty() {
            continue;
        }
        let want = match known().get(col) {
            Some(Kind::Number) if !cell.parse::<f64>().is_ok_and(f64::is_finite) => {
                "a finite number"
            }
            Some(Kind::Count) if cell.parse::<u64>().is_err() => "a whole number at least 0",
            Some(Kind::Bool) if cell != "true" && cell != "false" => "true or false",
            _ => continue,
        };
        return Err(Error::io(
            f,
            format!("row {line}: column {col}: `{cell}` is not {want}"),
        ));
    }
    Ok(())
}

fn read_csv(f: &Path, origin: &Arc<PathBuf>) -> Result<Vec<Row>, Error> {
    let mut rd = csv::ReaderBuilder::new()
        .flexible(false)
        .from_path(f)
        .map_err(|e| Error::io(f, e))?;
    let header: Arc<Vec<String>> = Arc::new(
        rd.headers()
            .map_err(|e| Error::io(f, e))?
            .iter()
            .map(str::to_owned)
            .collect(),
    );
    // A run's rows are `results` whatever the file is called (a baseline, a copy); other
    // CSVs are known by their stem (`dynamic`, `weights`, …).
    let is_results = ["structure", "traversal", "ray_kind"]
        .iter()
        .all(|c| header.iter().any(|h| h == c));
    let file = if is_results {
        "results".to_owned()
    } else {
        f.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let ours = is_results || super::columns::is_ours(&header);
    if is_results {
        // Every cell of its column's type, as `check` reads it (a counter "abc", rays -7, a
        // NaN: refused naming the row, never read as a missing figure).
        tb_results::output::read_csv(f)?;
    }
    let made_by = made_by(f);
    let mut out = Vec::new();
    for (i, rec) in rd.records().enumerate() {
        let rec = rec.map_err(|e| Error::io(f, format!("row {}: {e}", i + 2)))?;
        if ours {
            check_cells(f, i + 2, &header, &rec)?;
        }
        out.push(Row {
            file: file.clone(),
            origin: origin.clone(),
            header: header.clone(),
            cells: rec.iter().map(str::to_owned).collect(),
            ours,
            made_by: made_by.clone(),
        });
    }
    Ok(out)
}

/// The commit that made the rows of CSV `f`: `meta.build.commit` of the `results.json` beside
/// it (`-dirty` where the tree had uncommitted changes); `None` without one.
fn made_by(f: &Path) -> Option<Arc<str>> {
    let text = std::fs::read_to_string(f.with_file_name("results.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    let b = v.get("meta")?.get("build")?;
    let commit = b.get("commit")?.as_str()?;
    let dirty = b.get("dirty").and_then(|d| d.as_bool()) == Some(true);
    Some(if dirty {
        format!("{commit}-dirty").into()
    } else {
        commit.into()
    })
}
