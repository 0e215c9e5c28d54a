//! Result rows and their exporters: `results.csv` (one flat row per combination, flushed as
//! each finishes) and `results.json` (the same rows plus run metadata, rewritten atomically
//! after a row at most every [`JSON_EVERY`] and at the end, so an interrupted run leaves a
//! valid file at most that far behind its CSV; each row is serialised once).
//!
//! Column names are stable and carry units; README.md documents each ("Results columns").

use crate::Error;
use serde::{Deserialize, Serialize};
use std::fs::{File, OpenOptions};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tb_core::{CounterSet, StatsSummary};

/// The most processes a run is made in (`run --processes K`): a row's `process` is below it.
pub const MAX_PROCESSES: usize = 64;

/// How often a run rewrites `results.json` at most while rows come (it is always rewritten
/// when the sink opens and when the run finishes). Rewriting it after every row made a run of
/// 2016 rows (configs/ci.toml) spend about a third of its time serialising JSON: the whole
/// file each time, quadratic in the rows.
pub const JSON_EVERY: Duration = Duration::from_secs(1);

/// A float cell of a row: empty (`None`) or a finite number. A NaN or infinite figure is no
/// measurement a run writes (rates are guarded, `timing`), and a NaN compares false with every
/// bound, so `check`, `claims` and `merge` would pass it: reading refuses it,
/// naming the row.
fn finite<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = Option::<f64>::deserialize(d)?;
    match v {
        Some(x) if !x.is_finite() => Err(serde::de::Error::custom(format!(
            "{x} is not a finite number"
        ))),
        v => Ok(v),
    }
}

macro_rules! define_row {
    ($($name:ident, $per:ident, $max:ident, $doc:literal;)*) => {
        /// One result row: one scene x structure x params x traversal x device x threads x
        /// triangle test x ray kind. Empty cells (`None`) mean "not measured", never zero. The
        /// counter columns (`<counter>_per_ray`, `<counter>_max`) come from
        /// [`tb_core::for_each_counter!`].
        #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
        #[serde(default)]
        pub struct Row {
            /// Row label: the scene, or `TABLE@VIEW` for a view of a table with `views`.
            pub scene: String,
            /// The scene's source (`builtin:…` or a file path).
            pub source: String,
            /// Triangles in the scene.
            pub triangles: u64,
            /// The structure's registry name.
            pub structure: String,
            /// The full parameter set, `k=v;k=v`.
            pub params: String,
            /// The methods the row was made by, `NAME=VERSION;…`: its structure family's
            /// method version (and the first stage's family, for a structure built over
            /// another), the harness's (rays, views, timing) and, on a GPU row, the GPU
            /// driver's ([`tb_core::Family::method`]). A claim reads only rows of the current
            /// methods; empty in rows made before the column (version 0 of every method).
            pub method: String,
            /// The traversal algorithm's name.
            pub traversal: String,
            /// `cpu` or `gpu`.
            pub device: String,
            /// GPU rows: adapter name, backend and driver; empty on the CPU.
            pub adapter: String,
            /// GPU rows: the adapter's kind, `discrete`, `integrated`, `virtual`, `other` or
            /// `software` (a CPU rasterizer such as llvmpipe: its times are not GPU figures);
            /// empty on the CPU.
            #[serde(default)]
            pub adapter_type: String,
            /// The machine the row ran on (host name; rows of several machines can be merged).
            #[serde(default)]
            pub host: String,
            /// Which of the run's processes timed the row (`run --processes K`: 0..K-1, the
            /// odd ones with the structure entries in reverse order); empty for a run of one
            /// process. The same row of several processes is one measurement each.
            #[serde(default)]
            pub process: Option<u32>,
            /// Thread count of the timed runs (CPU); 0 on GPU rows.
            pub threads: u32,
            /// `watertight` or `moller-trumbore`.
            pub triangle_test: String,
            /// `primary`, `shadow`, `ao`, `path1`…, `random` or `stress`.
            pub ray_kind: String,
            /// Rays in the batch.
            pub rays: u64,
            /// Median build time, ms (of the `build_ms_runs`).
            #[serde(deserialize_with = "finite")]
            pub build_ms: Option<f64>,
            /// Every build's ms (`run.build_repeat` of them) in the order they ran,
            /// `;`-separated.
            #[serde(default)]
            pub build_ms_runs: String,
            /// Whether the structure was loaded from the build cache (its `build_ms` and heap
            /// figures then those of the build that made the entry, plus the auxiliary arrays
            /// prepared in this run; `tb_harness::experiment::cache`).
            #[serde(default)]
            pub build_cached: Option<bool>,
            /// Whether `build_ms` comes from builds timed fresh in this process, one thread
            /// each (`run.time_builds`, a `build_repeat` above 1 or the table's
            /// `time_builds`); `false`: an untimed build (all cores, or loaded from the
            /// cache), whose time no build-time claim reads. Empty in rows made before the
            /// column (their builds were all timed).
            #[serde(default)]
            pub build_timed: Option<bool>,
            /// Fastest timed pass over the batch, ms, counters compiled out.
            #[serde(deserialize_with = "finite")]
            pub trace_ms_min: Option<f64>,
            /// Median timed pass over the batch, ms, counters compiled out.
            #[serde(deserialize_with = "finite")]
            pub trace_ms_median: Option<f64>,
            /// Slowest timed pass over the batch, ms, counters compiled out.
            #[serde(deserialize_with = "finite")]
            pub trace_ms_max: Option<f64>,
            /// `timed_rays / trace_ms_median`, million rays per second.
            #[serde(deserialize_with = "finite")]
            pub mrays_per_s: Option<f64>,
            /// Timed runs of the row (`repeat`, more with `max_repeat`).
            pub timed_runs: Option<u32>,
            /// Rays of the batch each timed run traced (`run.timed_rays`; the whole batch,
            /// `rays`, by default): `mrays_per_s` is over these. The counters and `hit_rate`
            /// always come from all `rays`.
            #[serde(default)]
            pub timed_rays: Option<u64>,
            /// Half the width of the median's 95 % confidence interval, relative to the
            /// median.
            #[serde(deserialize_with = "finite")]
            pub trace_ms_ci: Option<f64>,
            /// Every timed run's ms in the order they ran, `;`-separated (rows timed together
            /// pair run for run: see `timing_group`).
            #[serde(default)]
            pub trace_ms_runs: String,
            /// Rows timed interleaved (`run.interleave`: run 1 of each, then run 2, …) share
            /// this id; empty for a row timed alone.
            #[serde(default)]
            pub timing_group: String,
            /// `trace_ms_ci` above `run.target_ci`, or the load average above the machine's
            /// idle level during the row.
            pub noisy: Option<bool>,
            /// 1-minute load average when the row finished (Linux).
            #[serde(deserialize_with = "finite")]
            pub load_avg: Option<f64>,
            /// CPU cores other processes kept busy on average while the row was measured
            /// (Linux `/proc/stat` less this process's own time).
            #[serde(default)]
            #[serde(deserialize_with = "finite")]
            pub cpu_others: Option<f64>,
            /// GPU rows: host-to-device copy of the structure and rays (median), not in
            /// `trace_ms_*`.
            #[serde(deserialize_with = "finite")]
            pub upload_ms: Option<f64>,
            /// GPU rows: device-to-host copy of the hits (median), not in `trace_ms_*`.
            #[serde(deserialize_with = "finite")]
            pub readback_ms: Option<f64>,
            /// GPU rows of a program that sorts its rays by key (`tb_core::GpuArrange`): the
            /// sort passes' time over the batch, ms, median over the timed runs; in
            /// `trace_ms_*` when the sort is timed (multi-kd `-sorted`, "inc."), not otherwise
            /// (`-presorted`, "n.inc."). Empty on other rows.
            #[serde(deserialize_with = "finite")]
            pub sort_ms: Option<f64>,
            /// GPU rows: the fixed-work probe's ms per pass (`tb_gpu::Gpu::probe_ms`), the
            /// mean of the probes timed just before and just after the row's timed passes.
            #[serde(default)]
            #[serde(deserialize_with = "finite")]
            pub probe_ms: Option<f64>,
            /// GPU rows: of those two probes, the one farther from the run's first probe,
            /// relative to it (0.03 = 3 % slower); beyond ±5 % the row is `noisy`.
            #[serde(default)]
            #[serde(deserialize_with = "finite")]
            pub probe_drift: Option<f64>,
            /// GPU rows where the driver exposes the clocks (NVIDIA, `nvidia-smi`): the least
            /// and most SM clock, MHz, sampled while the row was timed (between its probes).
            #[serde(default)]
            #[serde(deserialize_with = "finite")]
            pub gpu_sm_mhz_min: Option<f64>,
            /// The most SM clock sampled, MHz (see `gpu_sm_mhz_min`).
            #[serde(default)]
            #[serde(deserialize_with = "finite")]
            pub gpu_sm_mhz_max: Option<f64>,
            /// The memory clock, MHz, the mean of the same samples.
            #[serde(default)]
            #[serde(deserialize_with = "finite")]
            pub gpu_mem_mhz: Option<f64>,
            /// Share of rays that hit (any hit for shadow and AO rays).
            #[serde(deserialize_with = "finite")]
            pub hit_rate: Option<f64>,
            $(
                #[doc = concat!("Mean per ray: ", $doc, ".")]
                #[serde(deserialize_with = "finite")]
                pub $per: Option<f64>,
                #[doc = concat!("Maximum over the rays: ", $doc, ".")]
                pub $max: Option<u32>,
            )*
            /// Rays ended by a traversal's per-ray step cap (restart-family kd-tree
            /// traversals).
            pub capped_rays: Option<u64>,
            /// Bytes of everything the row's traversal reads (`tb_core::MemoryReport::bytes`).
            pub memory_bytes: Option<u64>,
            /// The structure alone, as the papers' memory figures count it: `memory_bytes`
            /// less the triangle array and the copies of scene geometry
            /// (`tb_core::MemoryReport::structure_bytes`).
            #[serde(default)]
            pub structure_bytes: Option<u64>,
            /// Node count (kd-tree treelet layout: slots, empty ones included).
            pub nodes: Option<u64>,
            /// Leaf references to triangles.
            pub prim_refs: Option<u64>,
            /// Bytes per node.
            pub node_bytes: Option<u32>,
            /// SAH cost of the build.
            #[serde(deserialize_with = "finite")]
            pub sah_cost: Option<f64>,
            /// Further build figures, `k=v;…` (leaves, depth, …).
            pub build_stats: String,
            /// The most heap the build held at once above what was live before it, bytes
            /// (measured by the binary's counting allocator, `tb_harness::experiment::heap`; empty where it
            /// is not installed).
            pub build_heap_peak_bytes: Option<u64>,
            /// The heap the build still held when it returned (the structure), bytes.
            pub build_heap_kept_bytes: Option<u64>,
            /// Rays compared with the brute-force oracle (watertight test).
            pub validated_rays: Option<u64>,
            /// How many of the validated rays differ from the oracle.
            pub mismatches: Option<u64>,
            /// Why the row has no measurement, or what it should be read with.
            pub note: String,
        }

        impl Row {
            /// Fill the counter columns of the counters in `set` from `s` (the others stay
            /// empty: the structure does not report them).
            pub fn set_counters(&mut self, s: &StatsSummary, set: CounterSet) {
                let mut i = 0;
                $(
                    if set.contains(i) {
                        self.$per = Some(s.mean[i]);
                        self.$max = Some(s.max[i]);
                    }
                    i += 1;
                )*
                let _ = i;
            }

            /// The counted columns of `from` (`hit_rate`, every counter, `capped_rays`): a row
            /// of the same traversal, test and rays counted in another process (counters are
            /// deterministic).
            pub fn copy_counters(&mut self, from: &Row) {
                self.hit_rate = from.hit_rate;
                $(
                    self.$per = from.$per;
                    self.$max = from.$max;
                )*
                self.capped_rays = from.capped_rays;
            }

            /// The value of counter column `column` (`<counter>_per_ray` or `<counter>_max`).
            pub fn counter(&self, column: &str) -> Option<f64> {
                match column {
                    $(
                        stringify!($per) => self.$per,
                        stringify!($max) => self.$max.map(f64::from),
                    )*
                    _ => None,
                }
            }
        }
    };
}

tb_core::for_each_counter!(define_row! {});

/// What a row's counters are of: scene (view), structure, params, traversal, triangle test,
/// ray batch; not the device's threads nor the process (counters are the same for all of
/// them: `check` compares by it, and the later processes of a run copy the first's).
pub type CountedKey = (String, String, String, String, String, String);

/// The columns that identify a row (for `--resume` and `check`).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct RowKey {
    /// Row label (the row's `scene`).
    pub scene: String,
    /// The structure's registry name.
    pub structure: String,
    /// The full parameter set, `k=v;k=v`.
    pub params: String,
    /// The traversal algorithm's name.
    pub traversal: String,
    /// `cpu` or `gpu`.
    pub device: String,
    /// Thread count of the timed runs (0 on GPU rows).
    pub threads: u32,
    /// `watertight` or `moller-trumbore`.
    pub triangle_test: String,
    /// The ray batch's kind name.
    pub ray_kind: String,
    /// The run's process (`run --processes K`), `None` for a run of one process.
    pub process: Option<u32>,
}

impl Row {
    /// The row's [`CountedKey`].
    pub fn counted_key(&self) -> CountedKey {
        (
            self.scene.clone(),
            self.structure.clone(),
            self.params.clone(),
            self.traversal.clone(),
            self.triangle_test.clone(),
            self.ray_kind.clone(),
        )
    }

    /// The row's [`RowKey`].
    pub fn key(&self) -> RowKey {
        RowKey {
            scene: self.scene.clone(),
            structure: self.structure.clone(),
            params: self.params.clone(),
            traversal: self.traversal.clone(),
            device: self.device.clone(),
            threads: self.threads,
            triangle_test: self.triangle_test.clone(),
            ray_kind: self.ray_kind.clone(),
            process: self.process,
        }
    }
}

/// Read a results CSV.
pub fn read_csv(path: &Path) -> Result<Vec<Row>, Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_csv(path, &text)
}

fn parse_csv(path: &Path, text: &str) -> Result<Vec<Row>, Error> {
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let header = r.headers().cloned().unwrap_or_default();
    // A file of other columns (a plain text file, another tool's CSV) is no results.csv:
    // reading it as zero rows would let `check` pass on nothing.
    if !header.is_empty()
        && !["scene", "structure"]
            .iter()
            .all(|c| header.iter().any(|h| h == *c))
    {
        return Err(Error::io(
            path,
            "not a trace-bench results.csv: its header has no `scene` and `structure` columns",
        ));
    }
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| Error::io(path, format!("row {line}: {e}")))?;
        let row: Row = rec
            .deserialize(Some(&header))
            .map_err(|e| Error::io(path, row_error(line, &header, &rec, &e)))?;
        rows.push(row);
    }
    Ok(rows)
}

/// `row N: column NAME: the problem` for a cell that does not read as its column's type (a
/// non-finite float, refused by [`finite`], is found by its cell).
fn row_error(
    line: usize,
    header: &csv::StringRecord,
    rec: &csv::StringRecord,
    e: &csv::Error,
) -> String {
    let csv::ErrorKind::Deserialize { err, .. } = e.kind() else {
        return format!("row {line}: {e}");
    };
    let at = err.field().map(|k| k as usize).or_else(|| {
        rec.iter()
            .position(|c| c.trim().parse::<f64>().is_ok_and(|x| !x.is_finite()))
    });
    let col = at
        .and_then(|k| header.get(k))
        .map(|c| format!("column {c}: "))
        .unwrap_or_default();
    format!("row {line}: {col}{}", err.kind())
}

/// Read the results CSV of an interrupted run. Every row is written with its newline in one
/// flush, so an unterminated last line is a row torn by the interruption: it is dropped (and
/// its combination run again), and the number of dropped lines is returned.
pub fn read_csv_resume(path: &Path) -> Result<(Vec<Row>, usize), Error> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    match text.rfind('\n') {
        Some(end) if end + 1 < text.len() => Ok((parse_csv(path, &text[..=end])?, 1)),
        None if !text.is_empty() => Ok((Vec::new(), 1)),
        _ => Ok((parse_csv(path, &text)?, 0)),
    }
}

/// Writes rows to `results.csv` and `results.json` in an output directory.
pub struct Sink {
    dir: PathBuf,
    csv: csv::Writer<File>,
    /// `params.csv`: the rows' parameters and build figures in long form.
    long: csv::Writer<File>,
    rows: Vec<Row>,
    /// Each row of `rows` as `results.json` holds it (pretty JSON, indented for the file).
    row_texts: Vec<String>,
    /// When `results.json` was last written, and how often at most ([`JSON_EVERY`]).
    json_written: Instant,
    json_every: Duration,
    meta: serde_json::Value,
    /// When this session opened the sink (`meta.duration_s` adds to an earlier session's).
    started: std::time::SystemTime,
    /// The earlier sessions' `duration_s` (a resumed run), to which this session's time so
    /// far is added at every write, so a killed session's time is kept too.
    earlier_s: f64,
}

impl Sink {
    /// Open the sink. With `resume`, existing rows of `results.csv` are kept (and returned by
    /// [`Sink::rows`]); otherwise the directory must not hold results yet.
    /// A resumed run keeps the first session's `start` and accumulated `duration_s` and lists
    /// the sessions' starts in `resumed`.
    pub fn open(dir: &Path, mut meta: serde_json::Value, resume: bool) -> Result<Sink, Error> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let csv_path = dir.join("results.csv");
        if resume {
            carry_meta(&dir.join("results.json"), &mut meta);
        }
        let existing = if csv_path.exists() {
            if !resume {
                return Err(Error::io(
                    &csv_path,
                    "already exists: pass --resume to continue that run, --force to replace it, or choose another --out",
                ));
            }
            let (rows, torn) = read_csv_resume(&csv_path)?;
            if torn > 0 {
                eprintln!(
                    "note: {}: dropped a torn last line; that row runs again",
                    csv_path.display()
                );
            }
            rows
        } else {
            Vec::new()
        };
        // Rewrite the CSV from the parsed rows (drops a torn last line of an interrupted run).
        let file = OpenOptions::new()
            .create(true)
            .write(true)
            .truncate(true)
            .open(&csv_path)
            .map_err(|e| Error::io(&csv_path, e))?;
        let mut csv = csv::WriterBuilder::new()
            .has_headers(true)
            .from_writer(file);
        if existing.is_empty() {
            // Header even for an empty file, so the columns are documented by the file itself.
            csv.write_record(header())
                .map_err(|e| Error::io(&csv_path, e))?;
            csv.flush().map_err(|e| Error::io(&csv_path, e))?;
            csv = csv::WriterBuilder::new().has_headers(false).from_writer(
                OpenOptions::new()
                    .append(true)
                    .open(&csv_path)
                    .map_err(|e| Error::io(&csv_path, e))?,
            );
        } else {
            for r in &existing {
                csv.serialize(r).map_err(|e| Error::io(&csv_path, e))?;
            }
            csv.flush().map_err(|e| Error::io(&csv_path, e))?;
            csv = csv::WriterBuilder::new().has_headers(false).from_writer(
                OpenOptions::new()
                    .append(true)
                    .open(&csv_path)
                    .map_err(|e| Error::io(&csv_path, e))?,
            );
        }
        // The long-form companion, rewritten from the kept rows.
        let long_path = dir.join("params.csv");
        let mut long = csv::Writer::from_path(&long_path).map_err(|e| Error::io(&long_path, e))?;
        long.write_record(["row", "group", "key", "value"])
            .map_err(|e| Error::io(&long_path, e))?;
        for (i, r) in existing.iter().enumerate() {
            for rec in long_records(i, r) {
                long.write_record(&rec)
                    .map_err(|e| Error::io(&long_path, e))?;
            }
        }
        long.flush().map_err(|e| Error::io(&long_path, e))?;
        let earlier_s = meta["duration_s"].as_f64().unwrap_or(0.0);
        let row_texts = existing.iter().map(row_text).collect();
        let mut sink = Sink {
            dir: dir.to_path_buf(),
            csv,
            long,
            rows: existing,
            row_texts,
            json_written: Instant::now(),
            json_every: JSON_EVERY,
            meta,
            started: std::time::SystemTime::now(),
            earlier_s,
        };
        sink.write_json()?;
        Ok(sink)
    }

    /// Rows written so far (including resumed ones).
    pub fn rows(&self) -> &[Row] {
        &self.rows
    }

    /// Append a row to both files and flush.
    pub fn push(&mut self, row: Row) -> Result<(), Error> {
        let p = self.dir.join("results.csv");
        self.csv.serialize(&row).map_err(|e| Error::io(&p, e))?;
        self.csv.flush().map_err(|e| Error::io(&p, e))?;
        let lp = self.dir.join("params.csv");
        for rec in long_records(self.rows.len(), &row) {
            self.long
                .write_record(&rec)
                .map_err(|e| Error::io(&lp, e))?;
        }
        self.long.flush().map_err(|e| Error::io(&lp, e))?;
        self.row_texts.push(row_text(&row));
        self.rows.push(row);
        if self.json_written.elapsed() >= self.json_every {
            self.write_json()?;
        }
        Ok(())
    }

    /// Rewrite `results.json` after every row (tests that read it between rows).
    #[cfg(test)]
    fn json_after_every_row(&mut self) {
        self.json_every = Duration::ZERO;
    }

    /// Set `meta[key]` of `results.json` (written with the next write).
    pub fn set_meta(&mut self, key: &str, value: serde_json::Value) {
        self.meta[key] = value;
    }

    /// Record the end of the run in the JSON metadata.
    pub fn finish(&mut self, status: &str) -> Result<(), Error> {
        self.meta["duration_s"] = serde_json::Value::from(self.earlier_s);
        crate::meta::finish(&mut self.meta, status, self.started);
        self.earlier_s = self.meta["duration_s"].as_f64().unwrap_or(self.earlier_s);
        self.started = std::time::SystemTime::now();
        self.write_json()
    }

    fn write_json(&mut self) -> Result<(), Error> {
        // The run's time so far (earlier sessions and this one), kept if it is killed.
        let now = self
            .started
            .elapsed()
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0);
        self.meta["duration_s"] =
            serde_json::Value::from(((self.earlier_s + now) * 1e3).round() / 1e3);
        let path = self.dir.join("results.json");
        let tmp = self.dir.join("results.json.tmp");
        let text = document(&self.meta, &self.row_texts).map_err(|e| Error::io(&path, e))?;
        std::fs::write(&tmp, text).map_err(|e| Error::io(&tmp, e))?;
        std::fs::rename(&tmp, &path).map_err(|e| Error::io(&path, e))?;
        self.json_written = Instant::now();
        Ok(())
    }
}

/// A row as an element of `results.json`'s `rows`: its pretty JSON, indented by four spaces.
fn row_text(r: &Row) -> String {
    let text = serde_json::to_string_pretty(&row_json(r)).unwrap_or_else(|_| "{}".into());
    let mut out = String::with_capacity(text.len() + 256);
    for (i, line) in text.lines().enumerate() {
        if i > 0 {
            out.push('\n');
        }
        out.push_str("    ");
        out.push_str(line);
    }
    out
}

/// `results.json`'s text: `{"meta": …, "rows": […]}` as `serde_json::to_string_pretty`
/// writes it, from the rows' texts ([`row_text`]) made once each.
fn document(meta: &serde_json::Value, rows: &[String]) -> serde_json::Result<String> {
    let meta = serde_json::to_string_pretty(meta)?.replace('\n', "\n  ");
    let size = meta.len() + rows.iter().map(|r| r.len() + 2).sum::<usize>() + 64;
    let mut out = String::with_capacity(size);
    out.push_str("{\n  \"meta\": ");
    out.push_str(&meta);
    if rows.is_empty() {
        out.push_str(",\n  \"rows\": []\n}");
        return Ok(out);
    }
    out.push_str(",\n  \"rows\": [\n");
    for (i, r) in rows.iter().enumerate() {
        if i > 0 {
            out.push_str(",\n");
        }
        out.push_str(r);
    }
    out.push_str("\n  ]\n}");
    Ok(out)
}

/// The files and folders a run writes into its folder (what `run --force` replaces): the rows,
/// their long form and metadata, and the reports' outputs.
pub const RUN_OUTPUTS: &[&str] = &[
    "results.csv",
    "results.json",
    "results.json.tmp",
    "params.csv",
    "convergence.csv",
    "convergence-budget.csv",
    "dynamic.csv",
    "dynamic-choice.csv",
    "images",
];

/// Write a whole results folder at once (`trace-bench merge`): `results.csv`, `params.csv` and
/// `results.json` of `rows` with `meta`, as a run writes them.
pub fn write_all(dir: &Path, meta: serde_json::Value, rows: &[Row]) -> Result<(), Error> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let p = dir.join("results.csv");
    let mut csv = csv::WriterBuilder::new()
        .has_headers(false)
        .from_path(&p)
        .map_err(|e| Error::io(&p, e))?;
    csv.write_record(header()).map_err(|e| Error::io(&p, e))?;
    for r in rows {
        csv.serialize(r).map_err(|e| Error::io(&p, e))?;
    }
    csv.flush().map_err(|e| Error::io(&p, e))?;
    let lp = dir.join("params.csv");
    let mut long = csv::Writer::from_path(&lp).map_err(|e| Error::io(&lp, e))?;
    long.write_record(["row", "group", "key", "value"])
        .map_err(|e| Error::io(&lp, e))?;
    for (i, r) in rows.iter().enumerate() {
        for rec in long_records(i, r) {
            long.write_record(&rec).map_err(|e| Error::io(&lp, e))?;
        }
    }
    long.flush().map_err(|e| Error::io(&lp, e))?;
    let jp = dir.join("results.json");
    let texts: Vec<String> = rows.iter().map(row_text).collect();
    let text = document(&meta, &texts).map_err(|e| Error::io(&jp, e))?;
    std::fs::write(&jp, text).map_err(|e| Error::io(&jp, e))
}

/// A resumed run's metadata: the earlier session's `start` and `duration_s`, and every
/// session's start in `resumed` (nothing when the earlier results.json is unreadable).
fn carry_meta(path: &Path, meta: &mut serde_json::Value) {
    let Some(old) = std::fs::read_to_string(path)
        .ok()
        .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
    else {
        return;
    };
    let old = &old["meta"];
    let now = meta["start"].clone();
    let mut sessions = old["resumed"].as_array().cloned().unwrap_or_default();
    sessions.push(now);
    if old["start"].is_string() {
        meta["start"] = old["start"].clone();
    }
    if old["duration_s"].is_number() {
        meta["duration_s"] = old["duration_s"].clone();
    }
    meta["resumed"] = serde_json::Value::Array(sessions);
}

/// Row `i`'s `params` and `build_stats` in long form: one `[row, group, key, value]` record per
/// pair (`group` is `param` or `build`), `row` the row's 0-based index in `results.csv` and in
/// `results.json`'s `rows`. `pandas.read_csv("params.csv").pivot(index="row", columns="key",
/// values="value")` gives one column per key.
fn long_records(i: usize, r: &Row) -> Vec<[String; 4]> {
    let pairs = |group: &str, s: &str| -> Vec<[String; 4]> {
        crate::pairs::pairs(s)
            .map(|(k, v)| {
                [
                    i.to_string(),
                    group.to_string(),
                    k.to_string(),
                    v.to_string(),
                ]
            })
            .collect()
    };
    let mut out = pairs("param", &r.params);
    out.extend(pairs("build", &r.build_stats));
    out
}

/// `k=v;k=v` as a JSON object, each value typed (integer, number, boolean, else string).
fn pairs_json(s: &str) -> serde_json::Value {
    let mut m = serde_json::Map::new();
    for (k, v) in crate::pairs::pairs(s) {
        let value = if let Ok(i) = v.parse::<i64>() {
            serde_json::Value::from(i)
        } else if let Ok(b) = v.parse::<bool>() {
            serde_json::Value::from(b)
        } else if let Some(x) = v.parse::<f64>().ok().filter(|x| x.is_finite()) {
            serde_json::Value::from(x)
        } else {
            serde_json::Value::from(v)
        };
        m.insert(k.to_string(), value);
    }
    serde_json::Value::Object(m)
}

/// A row of `results.json`: the CSV's columns in the same order, with `params` and
/// `build_stats` as objects (`pandas.json_normalize(doc["rows"])` gives `params.bins`, …).
pub fn row_json(r: &Row) -> serde_json::Value {
    let mut v = serde_json::to_value(r).expect("a row serializes");
    if let Some(m) = v.as_object_mut() {
        m.insert("params".into(), pairs_json(&r.params));
        m.insert("build_stats".into(), pairs_json(&r.build_stats));
    }
    v
}

/// The CSV header (the field names of [`Row`] in order).
pub fn header() -> Vec<String> {
    // Serialize a default row with a header to learn the field names.
    let mut w = csv::WriterBuilder::new()
        .has_headers(true)
        .from_writer(Vec::new());
    w.serialize(Row::default()).expect("serialize default row");
    let bytes = w.into_inner().expect("flush");
    let text = String::from_utf8(bytes).expect("utf8");
    text.lines()
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::to_string)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_rows_keep_the_column_order_and_type_the_params() {
        let r = Row {
            scene: "s".into(),
            params: "bins=16;c_trav=1.5;layout=treelet;reinsert=true".into(),
            build_stats: "leaves=12;depth_max=7".into(),
            ..Default::default()
        };
        let v = row_json(&r);
        let keys: Vec<&String> = v.as_object().unwrap().keys().collect();
        let head = header();
        assert_eq!(keys.len(), head.len());
        assert!(keys.iter().zip(&head).all(|(k, h)| *k == h));
        assert_eq!(v["params"]["bins"], 16);
        assert_eq!(v["params"]["c_trav"], 1.5);
        assert_eq!(v["params"]["layout"], "treelet");
        assert_eq!(v["params"]["reinsert"], true);
        assert_eq!(v["build_stats"]["depth_max"], 7);
        let long = long_records(3, &r);
        assert_eq!(long.len(), 6);
        assert_eq!(long[0], ["3", "param", "bins", "16"].map(String::from));
        assert_eq!(long[5], ["3", "build", "depth_max", "7"].map(String::from));
    }

    #[test]
    fn the_document_is_serde_jsons_pretty_text_and_lags_its_csv_by_at_most_json_every() {
        let a = Row {
            scene: "a".into(),
            params: "x=1;y=two".into(),
            ..Default::default()
        };
        let b = Row {
            scene: "b \"quoted\"\n".into(),
            ..Default::default()
        };
        let meta = serde_json::json!({ "status": "running", "nested": { "k": [1, 2] } });
        for rows in [vec![], vec![a.clone()], vec![a.clone(), b.clone()]] {
            let texts: Vec<String> = rows.iter().map(row_text).collect();
            let doc = serde_json::json!({ "meta": meta, "rows": rows.iter().map(row_json).collect::<Vec<_>>() });
            assert_eq!(
                document(&meta, &texts).unwrap(),
                serde_json::to_string_pretty(&doc).unwrap()
            );
        }
        // Rows pushed within JSON_EVERY of the last write wait for the next one or finish().
        let dir = tempfile::tempdir().unwrap();
        let mut sink = Sink::open(dir.path(), serde_json::json!({}), false).unwrap();
        sink.push(a).unwrap();
        let rows = |d: &Path| -> usize {
            let t = std::fs::read_to_string(d.join("results.json")).unwrap();
            serde_json::from_str::<serde_json::Value>(&t).unwrap()["rows"]
                .as_array()
                .unwrap()
                .len()
        };
        assert_eq!(rows(dir.path()), 0, "written less often than rows come");
        sink.finish("complete").unwrap();
        assert_eq!(rows(dir.path()), 1);
    }

    #[test]
    fn every_write_records_the_time_so_far_so_a_killed_session_keeps_it() {
        let dir = tempfile::tempdir().unwrap();
        let meta = serde_json::json!({ "duration_s": null });
        let mut sink = Sink::open(dir.path(), meta, false).unwrap();
        sink.json_after_every_row();
        std::thread::sleep(std::time::Duration::from_millis(30));
        sink.push(Row::default()).unwrap();
        // Killed here: no finish(). The JSON has this session's time so far.
        let read = || -> serde_json::Value {
            let t = std::fs::read_to_string(dir.path().join("results.json")).unwrap();
            serde_json::from_str(&t).unwrap()
        };
        let d1 = read()["meta"]["duration_s"].as_f64().expect("a number");
        assert!(d1 >= 0.03, "{d1}");
        drop(sink);
        // Resumed: the killed session's time is carried and this one's added.
        let meta = serde_json::json!({ "duration_s": null, "start": "t2" });
        let mut sink = Sink::open(dir.path(), meta, true).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(30));
        sink.finish("complete").unwrap();
        let d2 = read()["meta"]["duration_s"].as_f64().unwrap();
        assert!(d2 >= d1 + 0.03, "{d1} then {d2}");
        // finish twice counts the session once.
        sink.finish("complete").unwrap();
        let d3 = read()["meta"]["duration_s"].as_f64().unwrap();
        assert!(d3 < d2 + 0.02, "{d2} then {d3}");
    }
}
