//! A claim's row selectors (`[claim.rows]`, `filter`): the columns they name, checked when a
//! claims file loads, with the nearest known column suggested for a typo.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A row selector: column (or `scene`, `view`, `params`, `file`) → value or alternatives; a
/// named selector may also `pick` (module `pick`) and name its own `measure`
/// (`MEASURE_KEY`).
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(transparent)]
pub struct Selector(pub BTreeMap<String, toml::Value>);

/// The key of a named selector's own measure, which its rows are pooled by instead of the
/// claim's: one reading of a claim whose two sides are measured differently (Feldmann's
/// Table 5 read as the kd-tree's whole build against the R-tree's insertion alone:
/// `rtree = { …, measure = "build:insert_ms" }`). Not a column; not in `filter`.
pub const MEASURE_KEY: &str = "measure";

impl Selector {
    /// The selector's own measure, if it names one (checked at load).
    pub fn measure(&self) -> Option<&str> {
        match self.0.get(MEASURE_KEY)? {
            toml::Value::String(m) => Some(m),
            _ => None,
        }
    }

    pub(crate) fn check(&self) -> Result<(), String> {
        use super::columns;
        for (k, v) in &self.0 {
            if k == super::pick::KEY {
                super::pick::check(v)?;
                continue;
            }
            if k == MEASURE_KEY {
                let toml::Value::String(m) = v else {
                    return Err(format!("{MEASURE_KEY}: a measure is a string"));
                };
                let m = super::measure::Measure::parse(m).map_err(|e| format!("{k}: {e}"))?;
                m.check_columns().map_err(|e| format!("{k}: {e}"))?;
                continue;
            }
            if !columns::is_known(k) {
                return Err(unknown_column(k, "field"));
            }
            if k == "params" {
                let toml::Value::Table(t) = v else {
                    return Err("params: must be a table of parameter = value".into());
                };
                for (pk, pv) in t {
                    check_value(pv).map_err(|m| format!("params.{pk}: {m}"))?;
                }
            } else {
                check_value(v).map_err(|m| format!("{k}: {m}"))?;
                if let Some(kind) = columns::known().get(k.as_str()) {
                    columns::check_kind(*kind, v).map_err(|m| format!("{k}: {m}"))?;
                }
            }
        }
        Ok(())
    }
}

/// `unknown field `k``, with the nearest known column when one is near.
pub(crate) fn unknown_column(k: &str, what: &str) -> String {
    let near = super::columns::known()
        .keys()
        .map(String::as_str)
        .chain(super::columns::PSEUDO.iter().copied())
        .map(|c| (edit_distance(k, c), c))
        .min()
        .filter(|(d, _)| *d <= 2.max(k.len() / 4));
    let hint = near.map(|(_, c)| format!(" (did you mean `{c}`?)"));
    format!(
        "unknown {what} `{k}`: not a column of the CSVs a run writes (see claims/README.md){}",
        hint.unwrap_or_default()
    )
}

/// Levenshtein distance.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1];
        for (j, cb) in b.iter().enumerate() {
            let sub = prev[j] + usize::from(ca != *cb);
            cur.push(sub.min(prev[j + 1] + 1).min(cur[j] + 1));
        }
        prev = cur;
    }
    prev[b.len()]
}

fn check_value(v: &toml::Value) -> Result<(), String> {
    match v {
        toml::Value::String(_)
        | toml::Value::Integer(_)
        | toml::Value::Float(_)
        | toml::Value::Boolean(_) => Ok(()),
        toml::Value::Array(a) if !a.is_empty() => a.iter().try_for_each(|x| match x {
            toml::Value::Array(_) | toml::Value::Table(_) => {
                Err("a list of alternatives holds plain values".into())
            }
            x => check_value(x),
        }),
        toml::Value::Array(_) => Err("an empty list matches nothing".into()),
        _ => Err("expected a string, number, boolean or a list of them".into()),
    }
}
