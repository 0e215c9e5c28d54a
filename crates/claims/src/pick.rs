//! A selector's `pick = "max"` or `"min"`: the selector may match several variants (structure,
//! params, traversal) in a group, each is pooled as a selector alone would be, and the one with
//! the largest (smallest) value stands for the selector (`claims/README.md`, Selectors). For a
//! paper's statement about the extremes of a sweep: "the slowest pair of one sweep beats the
//! fastest of another" is a strict ordering of `pick = "max"` before `pick = "min"`.

use super::rows::Row;
use std::collections::{BTreeMap, BTreeSet};

/// The selector key.
pub(crate) const KEY: &str = "pick";

/// Which variant stands for the selector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Pick {
    Max,
    Min,
}

impl Pick {
    fn word(self) -> &'static str {
        match self {
            Pick::Max => "largest",
            Pick::Min => "smallest",
        }
    }
}

/// The pick of a selector (its fields), if it has one (checked at load: `max` or `min`).
pub(crate) fn of(s: &BTreeMap<String, toml::Value>) -> Option<Pick> {
    match s.get(KEY)? {
        toml::Value::String(x) if x == "max" => Some(Pick::Max),
        toml::Value::String(x) if x == "min" => Some(Pick::Min),
        _ => None,
    }
}

/// A `pick` value is `"max"` or `"min"`.
pub(crate) fn check(v: &toml::Value) -> Result<(), String> {
    match v {
        toml::Value::String(x) if x == "max" || x == "min" => Ok(()),
        v => Err(format!("{KEY}: {v} is not \"max\" or \"min\"")),
    }
}

/// A claim's `filter` (its fields) does not pick (a pick belongs to a named selector).
pub(crate) fn check_filter(filter: &BTreeMap<String, toml::Value>) -> Result<(), String> {
    if filter.contains_key(KEY) {
        return Err(format!("{KEY} belongs in a named selector of claim.rows"));
    }
    Ok(())
}

/// The variant of a row: what a selector must fix unless it picks.
fn variant(r: &Row) -> String {
    ["structure", "params", "traversal"]
        .iter()
        .map(|c| r.get(c).unwrap_or(""))
        .collect::<Vec<_>>()
        .join("|")
}

/// Pool every variant of `rows` with `pool_one` and keep the one `p` asks for by `value`;
/// with it, the words that say which it was (`ig` = the largest of 16 variants: …).
pub(crate) fn pool_pick<'r, V>(
    name: &str,
    rows: &[&'r Row],
    p: Pick,
    value: impl Fn(&V) -> f64,
    pool_one: impl Fn(&[&'r Row]) -> Result<V, String>,
) -> Result<(V, String), String> {
    let mut by: BTreeMap<String, Vec<&'r Row>> = BTreeMap::new();
    for r in rows {
        by.entry(variant(r)).or_default().push(r);
    }
    let mut best: Option<(V, &Row)> = None;
    for rs in by.values() {
        let v = pool_one(rs)?;
        let better = match &best {
            None => true,
            Some((b, _)) => match p {
                Pick::Max => value(&v) > value(b),
                Pick::Min => value(&v) < value(b),
            },
        };
        if better {
            best = Some((v, rs[0]));
        }
    }
    let (v, r) = best.ok_or_else(|| format!("`{name}`: no rows to pick from"))?;
    Ok((
        v,
        format!(
            "`{name}` = the {} of {} variants: {}",
            p.word(),
            by.len(),
            differing(r, rows)
        ),
    ))
}

/// What sets row `r` apart among `rows`: the structure, traversal and parameters that vary.
fn differing(r: &Row, rows: &[&Row]) -> String {
    let mut d = Vec::new();
    for c in ["structure", "traversal"] {
        let vals: BTreeSet<&str> = rows.iter().filter_map(|x| x.get(c)).collect();
        if vals.len() > 1 {
            d.push(format!("{c} {}", r.get(c).unwrap_or("")));
        }
    }
    let ps: Vec<BTreeMap<&str, &str>> = rows.iter().map(|x| x.params()).collect();
    for (k, v) in r.params() {
        if ps.iter().any(|p| p.get(k) != Some(&v)) {
            d.push(format!("{k}={v}"));
        }
    }
    if d.is_empty() {
        "one variant".into()
    } else {
        d.join(", ")
    }
}
