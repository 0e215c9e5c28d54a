//! The generic evaluator: rows → pooled values per group and selector → a test → verdicts.
//! What it yields ([`value`]), which rows a claim takes ([`select`]), how they pool ([`pool`]),
//! the tests ([`compare`]), and here the claims: groups evaluated and combined into a verdict.

use crate::effect::{self, ClaimEffect, Compared, Effect};
use crate::measure::{fmt, Measure, Term};
use crate::rows::{Row, RowSet};
use crate::schema::{Claim, ClaimKind, ClaimsFile, Direction, Need, Pool, Selector, Test};
use serde::Serialize;
use std::collections::{BTreeMap, BTreeSet};

mod compare;
mod pool;
pub(crate) mod select;
mod value;

use compare::*;
use pool::*;
use select::*;
pub use value::*;

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

/// Whether claim `c` (measure `m`) compares timings: its measure or a selector's own floored.
fn timed(c: &Claim, m: &Measure) -> bool {
    m.floored()
        || c.rows
            .values()
            .filter_map(|s| s.measure().and_then(|x| Measure::parse(x).ok()))
            .any(|x| x.floored())
}

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
    // Rows of an older method are left out; they only say why a claim is `stale`.
    let (base, old): (Vec<&Row>, Vec<&Row>) = set
        .rows
        .iter()
        .filter(|r| filter_matches(c, device, r))
        .partition(|r| r.current(&opts.methods));
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
    let stale = stale_rows(c, &names, &by, &old, &opts.methods);
    let (verdict, why) = match stale {
        Some(s) if verdict == Verdict::Inconclusive => (Verdict::Stale, format!("stale: {s}")),
        _ if !old.is_empty() => (
            verdict,
            format!("{why}; {} rows of an older method left out", old.len()),
        ),
        _ => (verdict, why),
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
        timed: timed(c, &m),
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

/// Why claim `c` is stale, if it is: a selector of `names` with no rows of the current
/// methods in any group (`by`) but rows of an older one (`old`); the reason names those
/// selectors, how many rows, the commits that made them, their methods and the current ones,
/// and the command that would renew them.
fn stale_rows(
    c: &Claim,
    names: &[&str],
    by: &BTreeMap<&str, BTreeMap<String, Vec<&Row>>>,
    old: &[&Row],
    methods: &BTreeMap<String, u32>,
) -> Option<String> {
    let mut lacking = Vec::new();
    let mut rows: Vec<&Row> = Vec::new();
    for n in names {
        if by.get(n).is_some_and(|g| !g.is_empty()) {
            continue;
        }
        let s = &c.rows[*n];
        let m: Vec<&Row> = old
            .iter()
            .copied()
            .filter(|r| selector_matches(s, r))
            .collect();
        if !m.is_empty() {
            lacking.push(format!("`{n}`"));
            rows.extend(m);
        }
    }
    if lacking.is_empty() {
        return None;
    }
    let set = |f: &dyn Fn(&Row) -> String| -> String {
        let v: BTreeSet<String> = rows.iter().map(|r| f(r)).collect();
        v.into_iter().collect::<Vec<_>>().join(", ")
    };
    let commits = set(&|r| r.made_by().unwrap_or("an unknown commit").to_owned());
    let made = set(&|r| match r.get("method").map(str::trim) {
        Some(m) if !m.is_empty() => m.to_owned(),
        _ => "none (before method versions)".to_owned(),
    });
    let gpu = rows.iter().any(|r| r.get("device") == Some("gpu"));
    let mut now: BTreeSet<String> = rows
        .iter()
        .filter_map(|r| r.get("structure"))
        .chain(["harness"])
        .chain(gpu.then_some("gpu"))
        .filter_map(|k| methods.get(k).map(|v| format!("{k}={v}")))
        .collect();
    if now.is_empty() {
        now.insert("—".into());
    }
    let renew = if gpu {
        "`scripts/gpu-reference.sh` on a machine with a GPU"
    } else {
        "`trace-bench reproduce` of this paper"
    };
    Some(format!(
        "{} only in rows of an older method ({} rows, made by {commits}; method {made}, now {}); \
         renew them with {renew}",
        lacking.join(", "),
        rows.len(),
        now.into_iter().collect::<Vec<_>>().join(";")
    ))
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
                let pooled = match crate::pick::of(&c.rows[*n].0) {
                    None => pool(n, rs, m, c.pool),
                    Some(p) => {
                        crate::pick::pool_pick(n, rs, p, |v: &Value| v.v, |r| pool(n, r, m, c.pool))
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
/// (`between`): their disturbance is then in the spread it measures). Too few runs in a row
/// matter only where its own spread would give the interval: measured between processes, one
/// timed run (one build) per process is a sample of that spread like any other.
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
    if few > 0 && !between {
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
        Verdict::Inconclusive | Verdict::Undecidable | Verdict::Stale => {
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
