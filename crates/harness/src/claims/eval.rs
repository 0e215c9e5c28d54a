//! The generic evaluator: rows → pooled values per group and selector → a test → verdicts.

use super::effect::{self, ClaimEffect, Compared, Effect};
use super::measure::{fmt, Measure, Term};
use super::rows::{Row, RowSet};
use super::schema::{Claim, ClaimKind, ClaimsFile, Direction, Need, Pool, Selector, Test};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};

/// A claim's (or a group's) verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    Agree,
    Disagree,
    Inconclusive,
    /// Cannot be decided by construction (the claim's `undecidable`, or a time band narrower
    /// than the floor between runs): shown instead of `inconclusive`, not tallied with it.
    Undecidable,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Agree => "agree",
            Verdict::Disagree => "disagree",
            Verdict::Inconclusive => "inconclusive",
            Verdict::Undecidable => "undecidable",
        }
    }
}

/// One pooled value: `v` with its 95 % interval `[lo, hi]` (a point for counters).
#[derive(Clone, Debug, Serialize)]
pub struct Value {
    pub v: f64,
    pub lo: f64,
    pub hi: f64,
    /// A timing (interval, noise) rather than a deterministic counter.
    pub timed: bool,
    /// Rows pooled.
    pub rows: usize,
    /// Of them, rows flagged `noisy` (timed measures).
    pub noisy: usize,
    /// Of them, GPU rows from a software adapter (timed measures).
    pub software: usize,
    /// Of them, rows timed fewer than [`MIN_TIMED_RUNS`] times (no interval).
    pub few_runs: usize,
    /// Timed rows timed interleaved (`run.interleave`): the pooled value of each round (the
    /// rows' `trace_ms_runs` summed round by round); empty otherwise.
    #[serde(skip)]
    pub runs: Vec<f64>,
    /// Their `timing_group`s, sorted: two values whose rows were timed together pair round
    /// for round.
    #[serde(skip)]
    pub tgroups: Vec<String>,
    /// The processes of the run the rows come from (`run --processes`; 1 for a run of one).
    pub processes: usize,
    /// `[lo, hi]` is the interval between those processes ([`between_processes`]), not
    /// widened to the floor.
    pub measured: bool,
    /// A timing's value in each process (by the `process` column) where its rows come from
    /// several: each pooled as the rows of one run are.
    #[serde(skip)]
    pub per_process: Vec<(String, Value)>,
}

/// The smallest relative uncertainty of a compared timing (a ratio of two times, or one time):
/// the variation between processes, which the intervals of one run cannot see. Measured here:
/// the same rows of `configs/multikd.toml` in three `reproduce` processes on one 2-core
/// machine moved by up to 31 % (Bunny `-presorted` path rays, 7.8 vs 10.2 ms, each within
/// ±1-3 % in its own run), their ratio to the SAH row by ±13 % around its mean. A time
/// comparison is decided only when its interval, widened to at least ±this, clears the bound.
pub const TIME_FLOOR: f64 = 0.2;

/// How claims are evaluated.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    /// [`TIME_FLOOR`] unless changed (`claims --time-floor`).
    pub time_floor: f64,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            time_floor: TIME_FLOOR,
        }
    }
}

/// `[lo, v, hi]` widened to at least `v / (1 + f) .. v · (1 + f)` (positive values).
fn floor_iv(d: [f64; 3], f: f64) -> [f64; 3] {
    if d[1].is_nan() || d[1] <= 0.0 || f <= 0.0 {
        return d;
    }
    [d[0].min(d[1] / (1.0 + f)), d[1], d[2].max(d[1] * (1.0 + f))]
}

/// Timed runs a row needs for its spread to bound the median (with fewer the interval is
/// unknown, not zero).
pub const MIN_TIMED_RUNS: f64 = 3.0;

/// Processes a compared time needs for its interval to be measured between them
/// ([`between_processes`]) instead of assumed ([`TIME_FLOOR`]). The interval is Student's t on
/// the processes' log values, `exp(m ± t(0.975, n − 1) · s / √n)`, whose quantile falls from
/// 12.7 with two processes (the spread of two values times 9: a 5 % difference between them
/// gives ±32 %, wider than the floor, and a standard deviation from two values is not one to
/// rely on) to 4.30 with three (2.5 times the spread); the distribution-free alternative, the
/// range of `n` values, covers the median with `1 − 2^(1 − n)`, 75 % for three, and needs six
/// processes for 95 %, twice the cost. Three is the fewest that measure; more narrow it.
pub const MIN_PROCESSES: usize = 3;

/// Two-sided 95 % quantiles of Student's t for 1 to 30 degrees of freedom (Fisher and Yates,
/// Statistical Tables, Table III); beyond, `1.96 + 2.5 / df` (within 0.002 of the table's 40,
/// 60 and 120).
fn t975(df: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => T[df - 1],
        _ => 1.96 + 2.5 / df as f64,
    }
}

/// The 95 % interval of a quantity measured once per process (`xs`, one value each, all
/// positive): Student's t on their logarithms, `[exp(m − h), exp(m), exp(m + h)]` with `m` the
/// mean log, `h = t(0.975, n − 1) · s / √n`, `s` the logs' standard deviation. Logarithms,
/// because times vary by factors (a process that runs 20 % slow slows every row by a factor)
/// and a ratio and its inverse then get the same interval, mirrored. Each process's value
/// carries its own noise (its rounds), so the spread holds the variation within processes and
/// between them. `None` with fewer than [`MIN_PROCESSES`] values or a value not above 0.
pub(crate) fn between_processes(xs: &[f64]) -> Option<[f64; 3]> {
    let n = xs.len();
    if n < MIN_PROCESSES || xs.iter().any(|x| !(*x > 0.0 && x.is_finite())) {
        return None;
    }
    let logs: Vec<f64> = xs.iter().map(|x| x.ln()).collect();
    let m = logs.iter().sum::<f64>() / n as f64;
    let var = logs.iter().map(|l| (l - m) * (l - m)).sum::<f64>() / (n - 1) as f64;
    let h = t975(n - 1) * (var / n as f64).sqrt();
    Some([(m - h).exp(), m.exp(), (m + h).exp()])
}

impl Value {
    fn point(v: f64, rows: usize) -> Value {
        Value {
            v,
            lo: v,
            hi: v,
            timed: false,
            rows,
            noisy: 0,
            software: 0,
            few_runs: 0,
            runs: Vec::new(),
            tgroups: Vec::new(),
            processes: 1,
            measured: false,
            per_process: Vec::new(),
        }
    }

    /// Whether `self` and `o` were timed interleaved, round for round (in every process they
    /// share, where they come from several).
    fn paired(&self, o: &Value) -> bool {
        let common = self.common(o);
        if !common.is_empty() {
            return common.iter().all(|(a, b)| a.paired(b));
        }
        !self.runs.is_empty() && self.runs.len() == o.runs.len() && self.tgroups == o.tgroups
    }

    /// The per-process values of `self` and `o` in the processes both come from.
    fn common<'v>(&'v self, o: &'v Value) -> Vec<(&'v Value, &'v Value)> {
        self.per_process
            .iter()
            .filter_map(|(k, a)| {
                o.per_process
                    .iter()
                    .find(|(k2, _)| k2 == k)
                    .map(|(_, b)| (a, b))
            })
            .collect()
    }
}

/// One group's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct GroupResult {
    /// The group key (`per` values joined by ` · `; empty without `per`).
    pub group: String,
    pub verdict: Verdict,
    /// The compared quantity as shown (`0.93`, `+7.2 %`, `a 1.2 <= b 3.4`).
    pub shown: String,
    /// The compared quantity (band tests), with its interval.
    pub derived: Option<[f64; 3]>,
    pub why: String,
    /// A timed comparison's interval: `Some(n)` when it was measured between `n` processes
    /// ([`MIN_PROCESSES`] or more), `None` when the floor gave it (or nothing is timed).
    pub between: Option<usize>,
    /// A timed group's smallest decidable effect ([`effect`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect: Option<Effect>,
    /// Each selector's pooled value.
    pub values: BTreeMap<String, Value>,
}

/// One claim on one device.
#[derive(Clone, Debug, Serialize)]
pub struct ClaimResult {
    pub id: String,
    #[serde(rename = "where")]
    pub place: String,
    pub text: String,
    pub paper: String,
    /// The paper's figure in a few words, where the claims file gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_figure: Option<String>,
    pub device: String,
    /// A claim of the paper (tallied), an observation or an invariant (shown apart).
    pub kind: ClaimKind,
    pub measure: String,
    pub verdict: Verdict,
    /// Why the claim cannot be decided by construction, where it cannot.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub undecidable: Option<String>,
    pub ours: String,
    pub why: String,
    pub note: Option<String>,
    pub test: Test,
    /// A timed claim's smallest decidable effect beside the effect its test asks for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect: Option<ClaimEffect>,
    pub groups: Vec<GroupResult>,
}

/// Columns that are properties of a build (one value per scene table x structure x params).
const BUILD_COLS: &[&str] = &[
    "memory_bytes",
    "structure_bytes",
    "nodes",
    "prim_refs",
    "node_bytes",
    "sah_cost",
    "build_heap_peak_bytes",
    "build_heap_kept_bytes",
];

fn default_pool(t: &Term) -> Pool {
    match t {
        Term::Col(c) if c.ends_with("_per_ray") || c == "hit_rate" => Pool::Rays,
        Term::Col(c) if c.ends_with("_max") => Pool::Max,
        Term::Col(c)
            if matches!(
                c.as_str(),
                "capped_rays" | "mismatches" | "validated_rays" | "rays"
            ) =>
        {
            Pool::Sum
        }
        _ => Pool::Mean,
    }
}

fn per_build(t: &Term) -> bool {
    match t {
        Term::Col(c) => BUILD_COLS.contains(&c.as_str()),
        Term::Build(_) | Term::HeapRatio | Term::BuildTime => true,
        Term::Time | Term::Mrays => false,
    }
}

/// Columns that tell one measurement context (the same rays) from another.
const CONTEXT: &[&str] = &[
    "file",
    "scene",
    "ray_kind",
    "device",
    "triangle_test",
    "threads",
    "budget_ms",
    "frame",
    "table",
    "heuristic",
    "beta",
    "patch",
    "axis",
    "integrator",
    "pass",
];
/// Columns that tell the variants compared (a selector must pick one per context).
const VARIANT: &[&str] = &["structure", "params", "traversal"];

/// A GPU row from a software rasterizer: `adapter_type = software`, or (rows written before
/// that column) an adapter name of one.
fn software_adapter(r: &Row) -> bool {
    const NAMES: [&str; 4] = ["llvmpipe", "lavapipe", "swiftshader", "softpipe"];
    r.get("device") == Some("gpu")
        && (r.get("adapter_type") == Some("software")
            || r.get("adapter").is_some_and(|a| {
                let a = a.to_ascii_lowercase();
                NAMES.iter().any(|s| a.contains(s))
            }))
}

// ---------------------------------------------------------------------------------------
// Matching

pub(crate) fn glob(pat: &str, s: &str) -> bool {
    // `*` matches any run; iterative with backtracking to the last star.
    let (p, t): (Vec<char>, Vec<char>) = (pat.chars().collect(), s.chars().collect());
    let (mut i, mut j, mut star, mut mark) = (0, 0, None, 0);
    while j < t.len() {
        if i < p.len() && p[i] != '*' && p[i] == t[j] {
            i += 1;
            j += 1;
        } else if i < p.len() && p[i] == '*' {
            star = Some(i);
            mark = j;
            i += 1;
        } else if let Some(s) = star {
            i = s + 1;
            mark += 1;
            j = mark;
        } else {
            return false;
        }
    }
    p[i..].iter().all(|&c| c == '*')
}

fn cell_matches(v: &toml::Value, cell: &str) -> bool {
    match v {
        toml::Value::String(p) => glob(p, cell),
        toml::Value::Integer(i) => cell.trim().parse::<f64>().is_ok_and(|x| x == *i as f64),
        toml::Value::Float(f) => cell
            .trim()
            .parse::<f64>()
            .is_ok_and(|x| x == *f || (x - f).abs() <= 1e-9 * f.abs().max(x.abs())),
        toml::Value::Boolean(b) => cell.trim() == if *b { "true" } else { "false" },
        toml::Value::Array(a) => a.iter().any(|x| cell_matches(x, cell)),
        _ => false,
    }
}

fn selector_matches(s: &Selector, r: &Row) -> bool {
    s.0.iter().all(|(k, v)| match k.as_str() {
        super::pick::KEY | super::schema::MEASURE_KEY => true,
        "scene" => r.table().is_some_and(|c| cell_matches(v, c)),
        "view" => r.get("scene").is_some_and(|c| cell_matches(v, c)),
        "params" => {
            let toml::Value::Table(t) = v else {
                return false;
            };
            let p = r.params();
            t.iter()
                .all(|(pk, pv)| p.get(pk.as_str()).is_some_and(|c| cell_matches(pv, c)))
        }
        col => r.get(col).is_some_and(|c| cell_matches(v, c)),
    })
}

/// The claim's filter on `device`, with the defaults: `file = "results"`,
/// `triangle_test = "watertight"` and the device, each unless the filter names it and each
/// only where the row has the column.
fn filter_matches(c: &Claim, device: &str, r: &Row) -> bool {
    let f = &c.filter.0;
    let default =
        |col: &str, want: &str| f.contains_key(col) || r.get(col).is_none_or(|x| x == want);
    default("file", "results")
        && default("triangle_test", "watertight")
        && default("device", device)
        && selector_matches(&c.filter, r)
}

fn group_key(per: &[String], r: &Row) -> String {
    per.iter()
        .map(|k| match k.as_str() {
            "scene" => r.table().unwrap_or("").to_owned(),
            "view" => r.get("scene").unwrap_or("").to_owned(),
            k if k.starts_with("param:") => r.params().get(&k[6..]).copied().unwrap_or("").into(),
            k => r.get(k).unwrap_or("").to_owned(),
        })
        .collect::<Vec<_>>()
        .join(" · ")
}

fn joined(r: &Row, cols: &[&str]) -> String {
    cols.iter()
        .map(|c| r.get(c).unwrap_or(""))
        .collect::<Vec<_>>()
        .join("|")
}

// ---------------------------------------------------------------------------------------
// Pooling

/// Pool one selector's rows in one group, or say why not. A timing whose rows come from
/// several processes of a run (`process`, `run --processes`) is pooled per process, then
/// across them ([`across_processes`]).
fn pool(name: &str, rows: &[&Row], m: &Measure, pool: Option<Pool>) -> Result<Value, String> {
    if m.floored() {
        let mut by: BTreeMap<&str, Vec<&Row>> = BTreeMap::new();
        for r in rows {
            by.entry(r.get("process").unwrap_or(""))
                .or_default()
                .push(r);
        }
        if by.len() > 1 {
            let per = by
                .into_iter()
                .map(|(k, rs)| pool_one(name, &rs, m, pool).map(|v| (k.to_owned(), v)))
                .collect::<Result<Vec<_>, _>>()?;
            return Ok(across_processes(per));
        }
    }
    pool_one(name, rows, m, pool)
}

/// One value from a timing's per-process values: the geometric mean, its interval measured
/// between the processes ([`between_processes`]; `measured`) with [`MIN_PROCESSES`] or
/// more, else the hull of theirs; the caveats summed. A process with fewer of the selector's
/// rows than the others (one interrupted) is left out: its sum is not of the same rows.
fn across_processes(mut per: Vec<(String, Value)>) -> Value {
    let most = per.iter().map(|(_, v)| v.rows).max().unwrap_or(0);
    per.retain(|(_, v)| v.rows == most);
    let xs: Vec<f64> = per.iter().map(|(_, v)| v.v).collect();
    let measured = between_processes(&xs);
    let [lo, v, hi] = measured.unwrap_or_else(|| {
        let gm = (xs.iter().map(|x| x.ln()).sum::<f64>() / xs.len().max(1) as f64).exp();
        let v = if gm.is_finite() {
            gm
        } else {
            xs.iter().sum::<f64>() / xs.len().max(1) as f64
        };
        [
            per.iter().map(|(_, x)| x.lo).fold(f64::INFINITY, f64::min),
            v,
            per.iter()
                .map(|(_, x)| x.hi)
                .fold(f64::NEG_INFINITY, f64::max),
        ]
    });
    let sum = |f: fn(&Value) -> usize| per.iter().map(|(_, x)| f(x)).sum::<usize>();
    Value {
        v,
        lo,
        hi,
        timed: per.iter().any(|(_, x)| x.timed),
        rows: sum(|x| x.rows),
        noisy: sum(|x| x.noisy),
        software: sum(|x| x.software),
        few_runs: sum(|x| x.few_runs),
        runs: Vec::new(),
        tgroups: Vec::new(),
        processes: per.len(),
        measured: measured.is_some(),
        per_process: per,
    }
}

/// [`pool`] on the rows of one process (or of a run of one).
fn pool_one(name: &str, rows: &[&Row], m: &Measure, pool: Option<Pool>) -> Result<Value, String> {
    if let Some((n, d)) = m.sides() {
        return pool_ratio(name, rows, (&n, &d), pool);
    }
    // A batch with no rays (a skipped batch: its `note` says why) measured nothing.
    let rows: Vec<&Row> = rows
        .iter()
        .copied()
        .filter(|r| r.num("rays") != Some(0.0))
        .collect();
    if rows.is_empty() {
        return Err(format!("`{name}`: its rows have no rays"));
    }
    let rows = &rows[..];
    // One variant per context.
    let mut seen: BTreeMap<String, (String, &Row)> = BTreeMap::new();
    for r in rows {
        let (ctx, var) = (joined(r, CONTEXT), joined(r, VARIANT));
        if let Some((v0, r0)) = seen.get(&ctx) {
            if *v0 != var {
                return Err(format!(
                    "ambiguous selector `{name}`: it matches rows that differ in {}; make it more specific",
                    variant_diff(r0, r)
                ));
            }
        } else {
            seen.insert(ctx, (var, r));
        }
    }
    let rows: Vec<&Row> = seen.into_values().map(|(_, r)| r).collect();
    let threads: BTreeSet<&str> = rows.iter().filter_map(|r| r.get("threads")).collect();
    if m.timed() {
        if threads.len() > 1 {
            return Err(format!(
                "`{name}` has rows of several thread counts ({}): a time claim must give threads",
                threads.into_iter().collect::<Vec<_>>().join(", ")
            ));
        }
        if m.num[0] == Term::BuildTime {
            return pool_build_time(name, &rows, pool);
        }
        return pool_time(name, &rows, matches!(m.num[0], Term::Mrays));
    }
    // Counters do not depend on the thread count: one row per context without threads.
    let mut by_ctx: BTreeMap<String, &Row> = BTreeMap::new();
    for r in &rows {
        let ctx: Vec<&str> = CONTEXT
            .iter()
            .filter(|c| **c != "threads")
            .map(|c| r.get(c).unwrap_or(""))
            .collect();
        by_ctx.entry(ctx.join("|")).or_insert(r);
    }
    let rows: Vec<&Row> = by_ctx.into_values().collect();
    let mut total = 0.0;
    for t in &m.num {
        let mut rs = rows.clone();
        if per_build(t) {
            rs = one_per_build(&rs);
        }
        let mut xs = Vec::with_capacity(rs.len());
        for r in &rs {
            let x = match t {
                Term::Col(c) => r.num(c),
                Term::Build(k) => r.build_stat(k),
                Term::HeapRatio => match (
                    r.num("build_heap_peak_bytes"),
                    r.num("build_heap_kept_bytes"),
                ) {
                    (Some(p), Some(k)) if k > 0.0 => Some(p / k),
                    _ => None,
                },
                Term::Time | Term::Mrays | Term::BuildTime => {
                    unreachable!("timed measures pool in pool_time")
                }
            };
            let Some(x) = x else {
                return Err(format!(
                    "`{name}`: {} of {} rows have no {}",
                    rs.iter()
                        .filter(|r| match t {
                            Term::Col(c) => r.num(c).is_none(),
                            _ => true,
                        })
                        .count()
                        .max(1),
                    rs.len(),
                    term_name(t)
                ));
            };
            let w = r.num("rays").unwrap_or(1.0);
            xs.push((x, w));
        }
        total += aggregate(pool.unwrap_or_else(|| default_pool(t)), &xs);
    }
    let mut v = Value::point(total, rows.len());
    v.timed = m.num.iter().any(Term::wall_clock);
    Ok(v)
}

/// A ratio `a / b`: each side pooled over the same rows as it would be alone, then divided
/// ([`super::measure::divide`]); a timing when either side is, with both sides' caveats.
fn pool_ratio(
    name: &str,
    rows: &[&Row],
    (n, d): (&Measure, &Measure),
    p: Option<Pool>,
) -> Result<Value, String> {
    let (n, d) = (pool_one(name, rows, n, p)?, pool_one(name, rows, d, p)?);
    let [lo, v, hi] = super::measure::divide([n.lo, n.v, n.hi], [d.lo, d.v, d.hi])
        .map_err(|e| format!("`{name}`: {e}"))?;
    Ok(Value {
        v,
        lo,
        hi,
        timed: n.timed || d.timed,
        rows: n.rows.max(d.rows),
        noisy: n.noisy + d.noisy,
        software: n.software + d.software,
        few_runs: n.few_runs.max(d.few_runs),
        runs: Vec::new(),
        tgroups: Vec::new(),
        processes: 1,
        measured: false,
        per_process: Vec::new(),
    })
}

/// What tells two rows' variants apart: `traversal a / b`, `param k a / b`, ….
fn variant_diff(a: &Row, b: &Row) -> String {
    let mut d = Vec::new();
    for c in ["structure", "traversal"] {
        if a.get(c) != b.get(c) {
            d.push(format!(
                "{c} {} / {}",
                a.get(c).unwrap_or(""),
                b.get(c).unwrap_or("")
            ));
        }
    }
    let (pa, pb) = (a.params(), b.params());
    let keys: BTreeSet<&str> = pa.keys().chain(pb.keys()).copied().collect();
    for k in keys {
        if pa.get(k) != pb.get(k) {
            d.push(format!(
                "{k} {} / {}",
                pa.get(k).unwrap_or(&"-"),
                pb.get(k).unwrap_or(&"-")
            ));
        }
    }
    d.join(", ")
}

/// One row per build (the first of each), for figures of the build rather than of the rays.
fn one_per_build<'r>(rows: &[&'r Row]) -> Vec<&'r Row> {
    let mut b: BTreeMap<String, &Row> = BTreeMap::new();
    for r in rows {
        b.entry(r.build_key()).or_insert(r);
    }
    b.into_values().collect()
}

/// Pool `(value, weight)` pairs: `rays` is the weighted mean (weights = rays).
fn aggregate(p: Pool, xs: &[(f64, f64)]) -> f64 {
    match p {
        Pool::Rays => {
            let w: f64 = xs.iter().map(|x| x.1).sum();
            xs.iter().map(|(x, w)| x * w).sum::<f64>() / w
        }
        Pool::Sum => xs.iter().map(|x| x.0).sum(),
        Pool::Mean => xs.iter().map(|x| x.0).sum::<f64>() / xs.len() as f64,
        Pool::Max => xs.iter().map(|x| x.0).fold(f64::NEG_INFINITY, f64::max),
        Pool::Min => xs.iter().map(|x| x.0).fold(f64::INFINITY, f64::min),
    }
}

fn term_name(t: &Term) -> String {
    match t {
        Term::Col(c) => c.clone(),
        Term::Build(k) => format!("build_stats {k}"),
        Term::HeapRatio => "build_heap_peak_bytes / build_heap_kept_bytes".into(),
        Term::Time => "trace_ms_median".into(),
        Term::BuildTime => "build_ms".into(),
        Term::Mrays => "mrays_per_s".into(),
    }
}

/// Build time: per distinct build its median and the range of its builds (`build_ms_runs`;
/// fewer than [`MIN_TIMED_RUNS`] builds give no interval), then the mean (or `pool`) over the
/// builds.
fn pool_build_time(name: &str, rows: &[&Row], pool: Option<Pool>) -> Result<Value, String> {
    let b = one_per_build(rows);
    let (mut v, mut lo, mut hi, mut few) = (Vec::new(), Vec::new(), Vec::new(), 0);
    for r in &b {
        let Some(m) = r.num("build_ms") else {
            return Err(format!("`{name}`: a row has no build_ms"));
        };
        let runs = r.nums("build_ms_runs");
        few += usize::from((runs.len() as f64) < MIN_TIMED_RUNS);
        v.push(m);
        lo.push(runs.iter().copied().fold(m, f64::min));
        hi.push(runs.iter().copied().fold(m, f64::max));
    }
    // Builds are weighted alike (`rays` pooling is the mean over them).
    let agg = |x: &[f64]| {
        let w: Vec<(f64, f64)> = x.iter().map(|&v| (v, 1.0)).collect();
        aggregate(pool.unwrap_or(Pool::Mean), &w)
    };
    Ok(Value {
        v: agg(&v),
        lo: agg(&lo),
        hi: agg(&hi),
        timed: true,
        rows: b.len(),
        noisy: 0,
        software: 0,
        few_runs: few,
        runs: Vec::new(),
        tgroups: Vec::new(),
        processes: 1,
        measured: false,
        per_process: Vec::new(),
    })
}

/// Total time over the rows (ms), its 95 % interval from each row's `trace_ms_ci` (relative
/// half-width; where absent, the row's min and max), or million rays per second over them.
fn pool_time(name: &str, rows: &[&Row], mrays: bool) -> Result<Value, String> {
    let (mut t, mut lo, mut hi, mut rays) = (0.0, 0.0, 0.0, 0.0);
    let (mut noisy, mut software, mut few_runs) = (0, 0, 0);
    // Round-by-round sums over the rows, where every row was timed interleaved.
    let mut series: Option<Vec<f64>> = None;
    let mut interleaved = true;
    let mut tgroups = Vec::new();
    for r in rows {
        let tg = r.get("timing_group").unwrap_or("");
        let runs = r.nums("trace_ms_runs");
        if tg.is_empty() || runs.is_empty() {
            interleaved = false;
        } else {
            tgroups.push(tg.to_owned());
            series = Some(match series {
                None => runs,
                Some(s) => s.iter().zip(&runs).map(|(a, b)| a + b).collect(),
            });
        }
        let Some(m) = r.num("trace_ms_median") else {
            return Err(format!("`{name}`: a row has no trace_ms_median"));
        };
        let (l, h) = match r.num("trace_ms_ci") {
            Some(ci) => (m * (1.0 - ci).max(0.0), m * (1.0 + ci)),
            None => (
                r.num("trace_ms_min").unwrap_or(m),
                r.num("trace_ms_max").unwrap_or(m),
            ),
        };
        t += m;
        lo += l;
        hi += h;
        rays += r.num("rays").unwrap_or(0.0);
        noisy += usize::from(r.get("noisy") == Some("true"));
        software += usize::from(software_adapter(r));
        few_runs += usize::from(r.num("timed_runs").unwrap_or(0.0) < MIN_TIMED_RUNS);
    }
    let (v, lo, hi) = if mrays {
        let f = |ms: f64| rays / (ms * 1e3);
        (f(t), f(hi), if lo > 0.0 { f(lo) } else { f64::INFINITY })
    } else {
        (t, lo, hi)
    };
    let mut runs = if interleaved {
        series.unwrap_or_default()
    } else {
        Vec::new()
    };
    if mrays {
        runs = runs.iter().map(|ms| rays / (ms * 1e3)).collect();
    }
    tgroups.sort();
    if runs.is_empty() {
        tgroups.clear();
    }
    Ok(Value {
        v,
        lo,
        hi,
        timed: true,
        rows: rows.len(),
        noisy,
        software,
        few_runs,
        runs,
        tgroups,
        processes: 1,
        measured: false,
        per_process: Vec::new(),
    })
}

// ---------------------------------------------------------------------------------------
// Tests

fn fmt_iv(v: f64, lo: f64, hi: f64, timed: bool) -> String {
    if timed {
        format!("{} [{}, {}]", fmt(v), fmt(lo), fmt(hi))
    } else {
        fmt(v)
    }
}

fn band_text(min: Option<f64>, max: Option<f64>) -> String {
    match (min, max) {
        (Some(a), Some(b)) => format!("[{}, {}]", fmt(a), fmt(b)),
        (Some(a), None) => format!(">= {}", fmt(a)),
        (None, Some(b)) => format!("<= {}", fmt(b)),
        (None, None) => "any".into(),
    }
}

fn band_verdict(lo: f64, hi: f64, min: Option<f64>, max: Option<f64>) -> Verdict {
    let (a, b) = (
        min.unwrap_or(f64::NEG_INFINITY),
        max.unwrap_or(f64::INFINITY),
    );
    if lo >= a && hi <= b {
        Verdict::Agree
    } else if hi < a || lo > b {
        Verdict::Disagree
    } else {
        Verdict::Inconclusive
    }
}

/// The round-by-round ratio `n / d` of values timed together: its median and 95 % interval.
fn paired_ratio(n: &Value, d: &Value) -> [f64; 3] {
    let r: Vec<f64> = n
        .runs
        .iter()
        .zip(&d.runs)
        .map(|(a, b)| a / b.max(1e-300))
        .collect();
    let (lo, hi) = crate::experiment::timing::median_ci(&r);
    [lo, crate::experiment::timing::median(&mut r.clone()), hi]
}

/// How a group's compared times get their intervals: between the processes both sides come
/// from, where they share [`MIN_PROCESSES`] or more ([`between_processes`] of the per-process
/// quantity: the round-by-round ratio of each process where its rows were timed interleaved,
/// else the ratio of its values); otherwise their own intervals (the hull of the shared
/// processes' own) widened to at least the floor between runs ([`TIME_FLOOR`]). It records the fewest processes compared and whether the
/// floor was used, for the group's `why`.
struct Cmp {
    floor: f64,
    /// The group compares timings (else intervals are points and nothing is widened).
    timed: bool,
    /// The fewest processes of a comparison so far (`usize::MAX`: none yet), and whether one
    /// was widened to the floor.
    how: std::cell::Cell<(usize, bool)>,
}

impl Cmp {
    fn new(floor: f64, timed: bool) -> Cmp {
        Cmp {
            floor,
            timed,
            how: std::cell::Cell::new((usize::MAX, false)),
        }
    }

    fn note(&self, processes: usize, floored: bool) {
        let (p, f) = self.how.get();
        self.how.set((p.min(processes), f || floored));
    }

    /// The ratio `n / d` with its interval.
    fn ratio(&self, n: &Value, d: &Value) -> [f64; 3] {
        let common = n.common(d);
        if self.timed && common.len() >= MIN_PROCESSES {
            let rs: Vec<f64> = common
                .iter()
                .map(|(a, b)| {
                    if a.paired(b) {
                        paired_ratio(a, b)[1]
                    } else {
                        a.v / b.v
                    }
                })
                .collect();
            if let Some(iv) = between_processes(&rs) {
                self.note(common.len(), false);
                return iv;
            }
        }
        // Fewer processes: the hull of each shared process's own ratio (round by round where
        // paired), or the values' intervals where they share none.
        let r = if common.is_empty() {
            ratio(n, d)
        } else {
            let ivs: Vec<[f64; 3]> = common.iter().map(|(a, b)| ratio(a, b)).collect();
            let mid = ivs.iter().map(|x| x[1].ln()).sum::<f64>() / ivs.len() as f64;
            [
                ivs.iter().map(|x| x[0]).fold(f64::INFINITY, f64::min),
                mid.exp(),
                ivs.iter().map(|x| x[2]).fold(f64::NEG_INFINITY, f64::max),
            ]
        };
        if self.timed {
            self.note(common.len().max(1), true);
            floor_iv(r, self.floor)
        } else {
            r
        }
    }

    /// `x` with its interval.
    fn value(&self, x: &Value) -> [f64; 3] {
        let d = [x.lo, x.v, x.hi];
        if !self.timed {
            d
        } else if x.measured {
            self.note(x.processes, false);
            d
        } else {
            self.note(x.processes, true);
            floor_iv(d, self.floor)
        }
    }

    /// Whether a comparison so far was widened to the floor.
    fn floored(&self) -> bool {
        self.how.get().1
    }

    /// Where the timed comparisons' intervals came from, in words (`between 3 processes`,
    /// `floor ±20 %, 1 process`), and the processes when measured between them.
    fn said(&self) -> Option<(String, Option<usize>)> {
        let (p, floored) = self.how.get();
        if !self.timed || p == usize::MAX {
            return None;
        }
        let procs = format!("{p} process{}", if p == 1 { "" } else { "es" });
        Some(if floored {
            (
                format!(
                    "interval: floor ±{} % (the variation between runs, not measured), {procs}",
                    fmt(100.0 * self.floor)
                ),
                None,
            )
        } else {
            (format!("interval between {procs}"), Some(p))
        })
    }
}

/// `x` before `y` in an ordering (strict: below `y·(1 − margin)`), with intervals (of the
/// paired ratio where they were timed together; between processes where measured there).
fn before(x: &Value, y: &Value, strict: bool, margin: f64, cmp: &Cmp) -> Verdict {
    if x.timed || y.timed {
        let r = cmp.ratio(x, y);
        let f = if strict { 1.0 - margin } else { 1.0 };
        return if (strict && r[2] < f) || (!strict && r[2] <= f) {
            Verdict::Agree
        } else if (strict && r[0] >= f) || (!strict && r[0] > f) {
            Verdict::Disagree
        } else {
            Verdict::Inconclusive
        };
    }
    if strict {
        let f = 1.0 - margin;
        if x.hi < y.lo * f {
            Verdict::Agree
        } else if x.lo >= y.hi * f {
            Verdict::Disagree
        } else {
            Verdict::Inconclusive
        }
    } else if x.hi <= y.lo {
        Verdict::Agree
    } else if x.lo > y.hi {
        Verdict::Disagree
    } else {
        Verdict::Inconclusive
    }
}

/// `x` above `y` by the margin (strict), with intervals.
fn above(x: &Value, y: &Value, margin: f64, cmp: &Cmp) -> Verdict {
    let f = 1.0 + margin;
    if x.timed || y.timed {
        let r = cmp.ratio(x, y);
        return if r[0] > f {
            Verdict::Agree
        } else if r[2] <= f {
            Verdict::Disagree
        } else {
            Verdict::Inconclusive
        };
    }
    if x.lo > y.hi * f {
        Verdict::Agree
    } else if x.hi <= y.lo * f {
        Verdict::Disagree
    } else {
        Verdict::Inconclusive
    }
}

fn all_of(vs: impl IntoIterator<Item = Verdict>) -> Verdict {
    let mut out = Verdict::Agree;
    for v in vs {
        match v {
            Verdict::Disagree => return Verdict::Disagree,
            Verdict::Inconclusive | Verdict::Undecidable => out = Verdict::Inconclusive,
            Verdict::Agree => {}
        }
    }
    out
}

/// Ratio `n / d` with its interval within one run (paired round by round where they were
/// timed together).
fn ratio(n: &Value, d: &Value) -> [f64; 3] {
    if n.paired(d) && n.per_process.is_empty() {
        return paired_ratio(n, d);
    }
    [
        n.lo / d.hi,
        n.v / d.v,
        if d.lo > 0.0 {
            n.hi / d.lo
        } else {
            f64::INFINITY
        },
    ]
}

/// A test's outcome on one group: verdict, the compared quantity as shown, the compared
/// quantity with its interval (band tests), why.
type Outcome = (Verdict, String, Option<[f64; 3]>, String);

/// Run the test on one group's values; with the processes its time intervals were measured
/// between (`None`: the floor, or no timing).
fn run_test(test: &Test, vals: &BTreeMap<String, Value>, floor: f64) -> (Outcome, Option<usize>) {
    let v = |n: &str| &vals[n];
    let cmp = Cmp::new(floor, vals.values().any(|x| x.timed));
    let ratio = |a: &Value, b: &Value| cmp.ratio(a, b);
    let banded = |d: [f64; 3], min, max, pct: bool| banded(d, min, max, pct, &cmp);
    let (verdict, shown, derived, why) = match test {
        Test::Value { of, min, max } => banded(cmp.value(v(of)), *min, *max, false),
        Test::Ratio { num, den, min, max } => banded(ratio(v(num), v(den)), *min, *max, false),
        Test::Speedup { of, base, min, max } => banded(ratio(v(base), v(of)), *min, *max, false),
        Test::Gain { of, base, min, max } => {
            let r = ratio(v(of), v(base));
            let g = [
                100.0 * (1.0 - r[2]),
                100.0 * (1.0 - r[1]),
                100.0 * (1.0 - r[0]),
            ];
            banded(g, *min, *max, true)
        }
        Test::Order {
            rows,
            strict,
            margin,
        } => order_test(rows, *strict, *margin, vals, &cmp),
        Test::Least {
            best,
            of,
            margin,
            direction,
        } => least_test(best, of, *margin, *direction, vals, &cmp),
        Test::Equal { a, b, tolerance } => equal_test(a, b, *tolerance, vals, &cmp),
    };
    match cmp.said() {
        Some((said, between)) => ((verdict, shown, derived, format!("{why}; {said}")), between),
        None => ((verdict, shown, derived, why), None),
    }
}

/// A timed group's compared quantities as ratios with the bounds each must clear: a band
/// test's `derived`, an ordering's neighbours, a `least` test's best against each rival; the
/// intervals as the test used them (`ratio` and [`floored`]). Empty when nothing is timed.
fn compared(
    test: &Test,
    vals: &BTreeMap<String, Value>,
    derived: Option<[f64; 3]>,
    floor: f64,
) -> Vec<Compared> {
    let timed = vals.values().any(|x| x.timed);
    if !timed {
        return Vec::new();
    }
    // The same intervals the test compared: between processes where measured, else floored.
    let cmp = Cmp::new(floor, timed);
    let r = |a: &str, b: &str| cmp.ratio(&vals[a], &vals[b]);
    match test {
        Test::Order {
            rows,
            strict,
            margin,
        } => rows
            .windows(2)
            .map(|w| Compared {
                iv: r(&w[0], &w[1]),
                bounds: vec![effect::before_bound(*strict, *margin)],
            })
            .collect(),
        Test::Least {
            best,
            of,
            margin,
            direction,
        } => of
            .iter()
            .map(|o| Compared {
                iv: r(best, o),
                bounds: vec![effect::least_bound(*direction, *margin)],
            })
            .collect(),
        Test::Equal { tolerance, .. } => derived
            .map(|d| Compared {
                iv: d,
                bounds: vec![1.0 - tolerance, 1.0 + tolerance],
            })
            .into_iter()
            .collect(),
        t => derived
            .and_then(|d| effect::banded(t, d))
            .into_iter()
            .collect(),
    }
}

/// A band test's outcome: the compared quantity `d` (percent when `pct`) in `min..=max`.
fn banded(d: [f64; 3], min: Option<f64>, max: Option<f64>, pct: bool, cmp: &Cmp) -> Outcome {
    let verdict = band_verdict(d[0], d[2], min, max);
    let unit = if pct { " %" } else { "" };
    let shown = if cmp.timed {
        format!("{}{unit} [{}, {}]", fmt(d[1]), fmt(d[0]), fmt(d[2]))
    } else {
        format!("{}{unit}", fmt(d[1]))
    };
    let why = match verdict {
        Verdict::Agree => format!("in {}", band_text(min, max)),
        Verdict::Disagree => format!("outside {}", band_text(min, max)),
        Verdict::Inconclusive if cmp.floored() => format!(
            "interval straddles {} (a time's is at least ±{} %: the variation between runs)",
            band_text(min, max),
            fmt(100.0 * cmp.floor)
        ),
        Verdict::Inconclusive | Verdict::Undecidable => {
            format!("interval straddles {}", band_text(min, max))
        }
    };
    (verdict, shown, Some(d), why)
}

/// The `order` test: each row before the next.
fn order_test(
    rows: &[String],
    strict: bool,
    margin: f64,
    vals: &BTreeMap<String, Value>,
    cmp: &Cmp,
) -> Outcome {
    let v = |n: &str| &vals[n];
    let timed = cmp.timed;
    let verdicts: Vec<Verdict> = rows
        .windows(2)
        .map(|w| before(v(&w[0]), v(&w[1]), strict, margin, cmp))
        .collect();
    // Each neighbour pair with the relation measured (`<`, `=`, `>`).
    let mut shown = String::new();
    for (i, n) in rows.iter().enumerate() {
        if i > 0 {
            let (a, b) = (v(&rows[i - 1]).v, v(n).v);
            shown.push_str(match a.partial_cmp(&b) {
                Some(std::cmp::Ordering::Less) => " < ",
                Some(std::cmp::Ordering::Equal) => " = ",
                _ => " > ",
            });
        }
        shown.push_str(&format!("{n} {}", fmt_iv(v(n).v, v(n).lo, v(n).hi, timed)));
    }
    let broken: Vec<String> = rows
        .windows(2)
        .zip(&verdicts)
        .filter(|(_, x)| **x != Verdict::Agree)
        .map(|(w, x)| {
            let rel = if *x == Verdict::Disagree {
                "not below"
            } else {
                "overlaps"
            };
            format!("{} {rel} {}", w[0], w[1])
        })
        .collect();
    let why = if broken.is_empty() {
        format!("in order ({} rows)", rows.len())
    } else {
        broken.join("; ")
    };
    (all_of(verdicts), shown, None, why)
}

/// The `least` test: `best` below (above) every row of `of` by the margin.
fn least_test(
    best: &str,
    of: &[String],
    margin: f64,
    direction: Direction,
    vals: &BTreeMap<String, Value>,
    cmp: &Cmp,
) -> Outcome {
    let v = |n: &str| &vals[n];
    let timed = cmp.timed;
    let b = v(best);
    let verdicts: Vec<(Verdict, &String)> = of
        .iter()
        .map(|o| {
            let x = v(o);
            let r = match direction {
                Direction::Lowest => before(b, x, true, margin, cmp),
                Direction::Highest => above(b, x, margin, cmp),
            };
            (r, o)
        })
        .collect();
    // The nearest rival.
    let rival = of
        .iter()
        .min_by(|a, c| {
            let key = |n: &str| match direction {
                Direction::Lowest => v(n).v,
                Direction::Highest => -v(n).v,
            };
            key(a).total_cmp(&key(c))
        })
        .expect("least has rivals");
    let shown = format!(
        "{best} {}; next {rival} {}",
        fmt_iv(b.v, b.lo, b.hi, timed),
        fmt_iv(v(rival).v, v(rival).lo, v(rival).hi, timed)
    );
    let word = match direction {
        Direction::Lowest => "not below",
        Direction::Highest => "not above",
    };
    let why = verdicts
        .iter()
        .filter(|(x, _)| *x != Verdict::Agree)
        .map(|(x, o)| {
            if *x == Verdict::Disagree {
                format!("{best} {word} {o} ({})", fmt(v(o).v))
            } else {
                format!("{best} overlaps {o}")
            }
        })
        .collect::<Vec<_>>()
        .join("; ");
    let why = if why.is_empty() {
        let word = match direction {
            Direction::Lowest => "lowest",
            Direction::Highest => "highest",
        };
        format!("{word} of {}", of.len() + 1)
    } else {
        why
    };
    (all_of(verdicts.into_iter().map(|x| x.0)), shown, None, why)
}

/// The `equal` test: `a` and `b` within the tolerance of each other.
fn equal_test(
    a: &str,
    b: &str,
    tolerance: f64,
    vals: &BTreeMap<String, Value>,
    cmp: &Cmp,
) -> Outcome {
    let (x, y) = (&vals[a], &vals[b]);
    let timed = cmp.timed;
    let r = cmp.ratio(x, y);
    let verdict = if timed {
        band_verdict(r[0], r[2], Some(1.0 - tolerance), Some(1.0 + tolerance))
    } else if (x.v - y.v).abs() <= tolerance * x.v.abs().max(y.v.abs()) {
        Verdict::Agree
    } else {
        Verdict::Disagree
    };
    let shown = format!(
        "{a} {}, {b} {} (Δ {} %)",
        fmt_iv(x.v, x.lo, x.hi, timed),
        fmt_iv(y.v, y.lo, y.hi, timed),
        fmt(100.0 * (r[1] - 1.0))
    );
    let why = format!("tolerance {} %", fmt(100.0 * tolerance));
    (verdict, shown, Some(r), why)
}

// ---------------------------------------------------------------------------------------
// Claims

/// Evaluate every claim of `file` on every device it names against `rows`.
pub fn evaluate(file: &ClaimsFile, rows: &RowSet) -> Vec<ClaimResult> {
    evaluate_with(file, rows, &Options::default())
}

/// [`evaluate`] with options.
pub fn evaluate_with(file: &ClaimsFile, rows: &RowSet, opts: &Options) -> Vec<ClaimResult> {
    let mut out = Vec::new();
    for c in &file.claims {
        for d in &c.devices {
            out.push(evaluate_claim(c, d, rows, opts));
        }
    }
    out
}

/// The claim's measure as reports show it: with each named selector's own, if any
/// (`build_ms (rtree: build:insert_ms)`).
fn shown_measure(c: &Claim) -> String {
    let own: Vec<String> = c
        .rows
        .iter()
        .filter_map(|(n, s)| s.measure().map(|m| format!("{n}: {m}")))
        .collect();
    if own.is_empty() {
        c.measure.clone()
    } else {
        format!("{} ({})", c.measure, own.join(", "))
    }
}

/// The rows of each selector by group (selector → group → rows), and every group.
type Grouped<'a> = (
    BTreeMap<&'a str, BTreeMap<String, Vec<&'a Row>>>,
    BTreeSet<String>,
);

fn evaluate_claim(c: &Claim, device: &str, set: &RowSet, opts: &Options) -> ClaimResult {
    let m = Measure::parse(&c.measure).expect("checked when the file was loaded");
    let names: Vec<&str> = {
        let mut seen = BTreeSet::new();
        c.test
            .names()
            .into_iter()
            .filter(|n| seen.insert(*n))
            .collect()
    };
    let base: Vec<&Row> = set
        .rows
        .iter()
        .filter(|r| filter_matches(c, device, r))
        .collect();
    let (by, groups) = group_rows(c, &names, &base);
    let mut results: Vec<GroupResult> = groups
        .iter()
        .map(|g| evaluate_group(c, g, &names, &by, &m, opts))
        .collect();
    if !results.is_empty() {
        results.extend(missing_groups(c, &groups));
    }
    let (verdict, ours, mut why) = combine(c, device, &results, &base, set);
    // Measured: every group's time interval was measured between processes.
    let measured = !results.is_empty() && results.iter().all(|g| g.between.is_some());
    let groups: Vec<(Option<&Effect>, bool)> = results
        .iter()
        .map(|g| {
            let open = !matches!(g.verdict, Verdict::Agree | Verdict::Disagree);
            (g.effect.as_ref(), open)
        })
        .collect();
    let claim_effect = effect::of_claim(&c.test, &groups);
    if let Some(e) = &claim_effect {
        why = format!("{why}; {}", effect::said(e));
    }
    let undecidable = super::kinds::undecidable(c, opts.time_floor, measured);
    let (verdict, why) = match &undecidable {
        Some(r) if verdict == Verdict::Inconclusive => {
            (Verdict::Undecidable, format!("undecidable: {r} ({why})"))
        }
        // Decided all the same (an interval wholly outside a band it could never be inside).
        Some(r) => (verdict, format!("{why}; undecidable by construction: {r}")),
        None => (verdict, why),
    };
    ClaimResult {
        id: c.id.clone(),
        place: c.place.clone(),
        text: c.text.clone(),
        paper: c.paper.clone(),
        paper_figure: c.paper_figure.clone(),
        device: device.into(),
        kind: c.kind,
        measure: shown_measure(c),
        verdict,
        undecidable,
        ours,
        why,
        note: c.note.clone(),
        test: c.test.clone(),
        effect: claim_effect,
        groups: results,
    }
}

/// The rows each selector of `names` matches among `base`, by group.
fn group_rows<'a>(c: &Claim, names: &[&'a str], base: &[&'a Row]) -> Grouped<'a> {
    let mut by: BTreeMap<&str, BTreeMap<String, Vec<&Row>>> = BTreeMap::new();
    let mut groups: BTreeSet<String> = BTreeSet::new();
    for n in names {
        let s = &c.rows[*n];
        let e = by.entry(n).or_default();
        for r in base.iter().filter(|r| selector_matches(s, r)) {
            let g = group_key(&c.per, r);
            groups.insert(g.clone());
            e.entry(g).or_default().push(r);
        }
    }
    (by, groups)
}

/// The filter's value for group key `k` (`scene`, `view`, a column, `param:NAME`).
fn filter_for_key<'c>(c: &'c Claim, k: &str) -> Option<&'c toml::Value> {
    match k.strip_prefix("param:") {
        Some(p) => match c.filter.0.get("params") {
            Some(toml::Value::Table(t)) => t.get(p),
            _ => None,
        },
        None => c.filter.0.get(k),
    }
}

/// A filter value as written (strings bare).
fn shown_value(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        v => v.to_string(),
    }
}

/// A group for each literal value (no `*`) the filter names for a `per` key that no group
/// has: partial rows must not decide a claim. Each is inconclusive and says what is missing.
fn missing_groups(c: &Claim, groups: &BTreeSet<String>) -> Vec<GroupResult> {
    let keys: Vec<Vec<&str>> = groups.iter().map(|g| g.split(" · ").collect()).collect();
    let mut out = Vec::new();
    for (i, k) in c.per.iter().enumerate() {
        let Some(f) = filter_for_key(c, k) else {
            continue;
        };
        let alts: Vec<&toml::Value> = match f {
            toml::Value::Array(a) => a.iter().collect(),
            v => vec![v],
        };
        for x in alts {
            if matches!(x, toml::Value::String(s) if s.contains('*')) {
                continue;
            }
            if keys
                .iter()
                .any(|g| g.get(i).is_some_and(|cell| cell_matches(x, cell)))
            {
                continue;
            }
            let shown = shown_value(x);
            let group = (0..c.per.len())
                .map(|j| if j == i { shown.as_str() } else { "*" })
                .collect::<Vec<_>>()
                .join(" · ");
            out.push(GroupResult {
                group,
                verdict: Verdict::Inconclusive,
                shown: "—".into(),
                derived: None,
                why: format!("rows missing: no rows for {k} = {shown}"),
                between: None,
                effect: None,
                values: BTreeMap::new(),
            });
        }
    }
    out
}

/// One group's result: its selectors' values pooled and the test run on them.
fn evaluate_group(
    c: &Claim,
    g: &str,
    names: &[&str],
    by: &BTreeMap<&str, BTreeMap<String, Vec<&Row>>>,
    m: &Measure,
    opts: &Options,
) -> GroupResult {
    let mut vals = BTreeMap::new();
    let mut problems = Vec::new();
    // What each picking selector picked (said after the test's why).
    let mut picked: Vec<String> = Vec::new();
    let rows: Vec<&Row> = names
        .iter()
        .filter_map(|n| by[n].get(g))
        .flatten()
        .copied()
        .collect();
    problems.extend(mixed_configs(&rows));
    for n in names {
        match by[n].get(g) {
            None => problems.push(format!("no rows for `{n}`")),
            Some(rs) => {
                // The selector's own measure, if it names one (checked at load).
                let own = c.rows[*n].measure().and_then(|x| Measure::parse(x).ok());
                let m = own.as_ref().unwrap_or(m);
                let pooled = match super::pick::of(&c.rows[*n].0) {
                    None => pool(n, rs, m, c.pool),
                    Some(p) => {
                        super::pick::pool_pick(n, rs, p, |v: &Value| v.v, |r| pool(n, r, m, c.pool))
                            .map(|(v, said)| {
                                picked.push(said);
                                v
                            })
                    }
                };
                match pooled {
                    Ok(v) => {
                        vals.insert(n.to_string(), v);
                    }
                    Err(e) => problems.push(e),
                }
            }
        }
    }
    if problems.is_empty() {
        let ((verdict, shown, derived, why), between) = run_test(&c.test, &vals, opts.time_floor);
        // The intervals compared: measured between processes, or this run's widened to the floor.
        let effect = effect::of_group(
            &compared(&c.test, &vals, derived, opts.time_floor),
            between.unwrap_or(1),
        );
        let (verdict, mut why) = timing_caveats(&vals, verdict, why, between.is_some());
        for p in &picked {
            why.push_str(&format!("; {p}"));
        }
        GroupResult {
            group: g.to_owned(),
            verdict,
            shown,
            derived,
            why,
            between,
            effect,
            values: vals,
        }
    } else {
        GroupResult {
            group: g.to_owned(),
            verdict: Verdict::Inconclusive,
            shown: "—".into(),
            derived: None,
            why: problems.join("; "),
            between: None,
            effect: None,
            values: vals,
        }
    }
}

/// Rows of one group from several sources (folders, CSVs) that were not made with the same
/// config: the same view and ray kind traced with a different number of rays (another image
/// size or ray count). Rows of one run agree by construction.
fn mixed_configs(rows: &[&Row]) -> Option<String> {
    let mut seen: BTreeMap<String, (f64, &Row)> = BTreeMap::new();
    for r in rows {
        let Some(n) = r.num("rays").filter(|n| *n > 0.0) else {
            continue;
        };
        let ctx = joined(r, &["scene", "ray_kind", "device"]);
        match seen.get(&ctx) {
            Some((m, r0)) if *m != n && r0.origin != r.origin => {
                return Some(format!(
                    "rows of different configs pooled: {} {} has {} rays in {} but {} in {}",
                    r.get("scene").unwrap_or(""),
                    r.get("ray_kind").unwrap_or(""),
                    fmt(*m),
                    r0.origin.display(),
                    fmt(n),
                    r.origin.display()
                ))
            }
            Some(_) => {}
            None => {
                seen.insert(ctx, (n, r));
            }
        }
    }
    None
}

/// The test's verdict and why, with the caveats of the timed values: too few runs, a
/// software GPU adapter or noisy rows make it inconclusive (noisy rows are only a note where
/// they were timed interleaved, or where the interval was measured between processes
/// (`between`): their disturbance is then in the spread it measures).
fn timing_caveats(
    vals: &BTreeMap<String, Value>,
    mut verdict: Verdict,
    mut why: String,
    between: bool,
) -> (Verdict, String) {
    let noisy: usize = vals.values().map(|v| v.noisy).sum();
    let software: usize = vals.values().map(|v| v.software).sum();
    let few: usize = vals.values().map(|v| v.few_runs).sum();
    let timed: Vec<&Value> = vals.values().filter(|v| v.timed).collect();
    let paired = timed.len() >= 2 && timed.windows(2).all(|w| w[0].paired(w[1]));
    if few > 0 {
        why = format!(
            "{few} timed rows have fewer than {MIN_TIMED_RUNS} timed runs (no interval); {why}"
        );
        verdict = Verdict::Inconclusive;
    } else if software > 0 {
        why = format!("timed on a software GPU adapter ({software} rows), not GPU figures; {why}");
        verdict = Verdict::Inconclusive;
    } else if noisy > 0 && paired {
        // Load fell on every row alike: the round-by-round ratio is what is judged.
        why =
            format!("{noisy} timed rows noisy, compared round by round (timed interleaved); {why}");
    } else if noisy > 0 && between {
        // The disturbed process's value is one of those whose spread gives the interval.
        why = format!("{noisy} timed rows noisy, in the spread between processes; {why}");
    } else if noisy > 0 {
        why = format!("{noisy} of the timed rows are noisy; {why}");
        verdict = Verdict::Inconclusive;
    }
    (verdict, why)
}

/// The claim's verdict, `ours` and `why` from its groups' results.
fn combine(
    c: &Claim,
    device: &str,
    gs: &[GroupResult],
    base: &[&Row],
    set: &RowSet,
) -> (Verdict, String, String) {
    if gs.is_empty() {
        return (
            Verdict::Inconclusive,
            "—".into(),
            no_groups_why(c, device, base, set),
        );
    }
    let count = |v: Verdict| gs.iter().filter(|g| g.verdict == v).count();
    let (agree, disagree, n) = (count(Verdict::Agree), count(Verdict::Disagree), gs.len());
    let verdict = match c.need {
        Need::All if disagree > 0 => Verdict::Disagree,
        Need::All if agree == n => Verdict::Agree,
        Need::Any if agree > 0 => Verdict::Agree,
        Need::Any if disagree == n => Verdict::Disagree,
        Need::Most if 2 * agree > n => Verdict::Agree,
        Need::Most if 2 * disagree >= n => Verdict::Disagree,
        _ => Verdict::Inconclusive,
    };
    let ours = combined_ours(c, gs, agree);
    let list = |v: Verdict| reasons(gs, v);
    let why = match verdict {
        Verdict::Agree if n == 1 => gs[0].why.clone(),
        Verdict::Agree if agree == n => format!("all {n} groups"),
        Verdict::Agree => format!("{agree} of {n} groups agree: {}", list(Verdict::Agree)),
        Verdict::Disagree => {
            let s = list(Verdict::Disagree);
            if n == 1 {
                s
            } else {
                format!("{disagree} of {n} groups disagree: {s}")
            }
        }
        Verdict::Inconclusive | Verdict::Undecidable => {
            let s = list(Verdict::Inconclusive);
            if n == 1 || count(Verdict::Inconclusive) == 0 {
                if s.is_empty() {
                    format!("{agree} of {n} groups agree, {disagree} disagree")
                } else {
                    s
                }
            } else {
                format!(
                    "{} of {n} groups inconclusive: {s}",
                    count(Verdict::Inconclusive)
                )
            }
        }
    };
    (verdict, ours, why)
}

/// Why a claim has no group: no rows, none of the device matching the filter, or none
/// matching the selectors.
fn no_groups_why(c: &Claim, device: &str, base: &[&Row], set: &RowSet) -> String {
    if set.rows.is_empty() {
        "no rows read".to_owned()
    } else if base.is_empty() {
        format!("rows missing: no {device} row matches the claim's filter")
    } else {
        let names: Vec<String> = c.test.names().iter().map(|n| format!("`{n}`")).collect();
        format!("rows missing: no row matches {}", names.join(", "))
    }
}

/// A claim's `ours` from its groups (`agree` of them agreeing): the one group's, the range
/// of the compared quantities, or how many groups hold.
fn combined_ours(c: &Claim, gs: &[GroupResult], agree: usize) -> String {
    let n = gs.len();
    if n == 1 {
        gs[0].shown.clone()
    } else {
        let ds: Vec<f64> = gs.iter().filter_map(|g| g.derived.map(|d| d[1])).collect();
        let pct = if matches!(c.test, Test::Gain { .. }) {
            " %"
        } else {
            ""
        };
        if ds.len() == n {
            let lo = ds.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = ds.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            format!("{}..{}{pct} ({n} groups)", fmt(lo), fmt(hi))
        } else {
            format!("{agree} of {n} groups hold")
        }
    }
}

/// The reasons of the groups with verdict `v`, at most four (and how many more).
fn reasons(gs: &[GroupResult], v: Verdict) -> String {
    let n = gs.len();
    let label = |g: &GroupResult| {
        if g.group.is_empty() {
            g.why.clone()
        } else if n > 1 && g.derived.is_some() {
            format!("{}: {}, {}", g.group, g.shown, g.why)
        } else {
            format!("{}: {}", g.group, g.why)
        }
    };
    // Reasons shared by several groups (an ambiguous selector) are said once.
    let mut sel: Vec<String> = Vec::new();
    let mut said: BTreeSet<&str> = BTreeSet::new();
    for g in gs.iter().filter(|g| g.verdict == v) {
        if g.derived.is_none() && v == Verdict::Inconclusive {
            if said.insert(g.why.as_str()) {
                let k = gs.iter().filter(|h| h.why == g.why).count();
                sel.push(if k > 1 {
                    format!("{} groups: {}", k, g.why)
                } else {
                    label(g)
                });
            }
        } else {
            sel.push(label(g));
        }
    }
    let more = sel.len().saturating_sub(4);
    let mut s = sel.into_iter().take(4).collect::<Vec<_>>().join("; ");
    if more > 0 {
        s.push_str(&format!("; +{more} more"));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn glob_matches_stars() {
        assert!(glob("path*", "path1"));
        assert!(glob("*", ""));
        assert!(glob("a*c", "abbbc"));
        assert!(!glob("a*c", "abbb"));
        assert!(glob("conference", "conference"));
        assert!(!glob("conf", "conference"));
        assert!(glob("*-boxed", "bunny-boxed"));
    }

    #[test]
    fn bands_decide_only_clear_intervals() {
        assert_eq!(band_verdict(0.9, 0.95, None, Some(1.0)), Verdict::Agree);
        assert_eq!(band_verdict(1.01, 1.2, None, Some(1.0)), Verdict::Disagree);
        assert_eq!(
            band_verdict(0.9, 1.1, None, Some(1.0)),
            Verdict::Inconclusive
        );
        assert_eq!(band_verdict(5.0, 5.0, Some(5.0), Some(5.0)), Verdict::Agree);
    }

    #[test]
    fn measures_parse() {
        assert!(Measure::parse("planes_per_ray + prims_per_ray").is_ok());
        assert!(Measure::parse("time + prims_per_ray").is_err());
        assert!(Measure::parse("build:paper_bytes").is_ok());
        assert!(Measure::parse("Bad Name").is_err());
        assert!(Measure::parse("time").unwrap().timed());
    }

    /// Student's t on the logs: log values -1, 0, 1 (mean 0, standard deviation 1) give
    /// `exp(±t(0.975, 2) / √3)` around 1; fewer than three processes, or a value not above 0,
    /// give none; a ratio's inverse gets the mirrored interval.
    #[test]
    fn intervals_between_processes_are_t_intervals_on_logs() {
        let e = std::f64::consts::E;
        let iv = between_processes(&[1.0 / e, 1.0, e]).unwrap();
        let h = 4.303 / 3f64.sqrt();
        assert!((iv[0] - (-h).exp()).abs() < 1e-12 && (iv[1] - 1.0).abs() < 1e-12);
        assert!((iv[2] - h.exp()).abs() < 1e-12, "{iv:?}");
        assert!(between_processes(&[1.0, 2.0]).is_none());
        assert!(between_processes(&[1.0, 2.0, 0.0]).is_none());
        let xs = [0.8, 0.9, 0.85, 0.95];
        let inv: Vec<f64> = xs.iter().map(|x| 1.0 / x).collect();
        let (a, b) = (
            between_processes(&xs).unwrap(),
            between_processes(&inv).unwrap(),
        );
        assert!((a[0] * b[2] - 1.0).abs() < 1e-12 && (a[2] * b[0] - 1.0).abs() < 1e-12);
        // More processes, a smaller quantile: the table's last entries and beyond.
        assert!(t975(2) > t975(3) && t975(30) > t975(31) && (t975(60) - 2.0).abs() < 0.002);
    }

    #[test]
    fn numbers_print_in_four_digits() {
        assert_eq!(fmt(0.123456), "0.12346");
        assert_eq!(fmt(12.0), "12");
        assert_eq!(fmt(55.04431), "55.044");
        assert_eq!(fmt(12345.4), "12345");
        assert_eq!(fmt(-7.25), "-7.25");
    }
}
