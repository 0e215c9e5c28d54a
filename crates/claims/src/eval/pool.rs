//! Pooling: one selector's rows in one group become one value (a counter's mean or sum, a
//! time's median with its interval, across processes where a run was made in several).

use super::*;

/// Pool one selector's rows in one group, or say why not. A timing whose rows come from
/// several processes of a run (`process`, `run --processes`) is pooled per process, then
/// across them ([`across_processes`]).
pub(super) fn pool(
    name: &str,
    rows: &[&Row],
    m: &Measure,
    pool: Option<Pool>,
) -> Result<Value, String> {
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
pub(super) fn across_processes(mut per: Vec<(String, Value)>) -> Value {
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

/// The rows that traced rays: a batch with no rays (a skipped batch: its `note` says why)
/// measured nothing.
fn with_rays<'r>(rows: &[&'r Row]) -> Vec<&'r Row> {
    rows.iter()
        .copied()
        .filter(|r| r.num("rays") != Some(0.0))
        .collect()
}

/// [`pool`] on the rows of one process (or of a run of one).
pub(super) fn pool_one(
    name: &str,
    rows: &[&Row],
    m: &Measure,
    pool: Option<Pool>,
) -> Result<Value, String> {
    if let Some((n, d)) = m.sides() {
        return pool_ratio(name, rows, (&n, &d), pool);
    }
    let rows = with_rays(rows);
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
/// ([`crate::measure::divide`]); a timing when either side is, with both sides' caveats.
pub(super) fn pool_ratio(
    name: &str,
    rows: &[&Row],
    (n, d): (&Measure, &Measure),
    p: Option<Pool>,
) -> Result<Value, String> {
    let (n, d) = (pool_one(name, rows, n, p)?, pool_one(name, rows, d, p)?);
    let [lo, v, hi] = crate::measure::divide([n.lo, n.v, n.hi], [d.lo, d.v, d.hi])
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
pub(super) fn variant_diff(a: &Row, b: &Row) -> String {
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
pub(super) fn one_per_build<'r>(rows: &[&'r Row]) -> Vec<&'r Row> {
    let mut b: BTreeMap<String, &Row> = BTreeMap::new();
    for r in rows {
        b.entry(r.build_key()).or_insert(r);
    }
    b.into_values().collect()
}

/// Pool `(value, weight)` pairs: `rays` is the weighted mean (weights = rays).
pub(super) fn aggregate(p: Pool, xs: &[(f64, f64)]) -> f64 {
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

pub(super) fn term_name(t: &Term) -> String {
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
/// builds. A row whose build was not timed (`build_timed = false`) is refused: its time is of
/// an untimed build (all cores) or of the build that made a cache entry.
pub(super) fn pool_build_time(
    name: &str,
    rows: &[&Row],
    pool: Option<Pool>,
) -> Result<Value, String> {
    let b = one_per_build(rows);
    let (mut v, mut lo, mut hi, mut few) = (Vec::new(), Vec::new(), Vec::new(), 0);
    for r in &b {
        let Some(m) = r.num("build_ms") else {
            return Err(format!("`{name}`: a row has no build_ms"));
        };
        if r.get("build_timed") == Some("false") {
            return Err(format!(
                "`{name}`: a row's build was not timed (build_timed = false: built untimed or \
                 loaded from the build cache); its run must time its builds (run.time_builds, \
                 or build_repeat above 1)"
            ));
        }
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
pub(super) fn pool_time(name: &str, rows: &[&Row], mrays: bool) -> Result<Value, String> {
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
