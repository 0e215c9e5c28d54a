//! The columns a claims file may name: those of every CSV a run writes, derived from the row
//! types that write them (`results.csv`: [`tb_results::output::Row`], its counter columns
//! included; `dynamic.csv` and `dynamic-choice.csv`: [`tb_results::tables::DynamicRow`] and
//! [`tb_results::tables::ChoiceRow`]; `weights.csv`: [`tb_results::tables::WEIGHTS_COLUMNS`]),
//! with each column's kind of value.

use std::collections::BTreeMap;
use std::sync::OnceLock;

/// What a column holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    Text,
    Number,
    /// A count: a whole number at least 0 (`threads`, `rays`, `frame`).
    Count,
    Bool,
}

/// Keys a selector takes beside the columns: `scene` (the table), `view`, `file`, `params`.
pub(crate) const PSEUDO: &[&str] = &["scene", "view", "file", "params"];

/// Every known column and its kind (a column in several files is text if it is text in any).
pub(crate) fn known() -> &'static BTreeMap<String, Kind> {
    static K: OnceLock<BTreeMap<String, Kind>> = OnceLock::new();
    K.get_or_init(|| {
        use tb_results::tables::{ChoiceRow, DynamicRow};
        let mut m = BTreeMap::new();
        let results = tb_results::output::Row::default();
        add(&mut m, serde_json::to_value(&results), |col| {
            let probe = |v: serde_json::Value| {
                let mut o = serde_json::Map::new();
                o.insert(col.to_owned(), v);
                serde_json::from_value::<tb_results::output::Row>(o.into()).is_ok()
            };
            if probe(0.into()) && !probe((-1).into()) && !probe(0.5.into()) {
                Kind::Count
            } else if probe(0.into()) {
                Kind::Number
            } else if probe(true.into()) {
                Kind::Bool
            } else {
                Kind::Text
            }
        });
        let text = |_: &str| Kind::Text;
        add(&mut m, serde_json::to_value(DynamicRow::default()), text);
        add(&mut m, serde_json::to_value(ChoiceRow::default()), text);
        for (c, numeric) in tb_results::tables::WEIGHTS_COLUMNS {
            let k = if numeric { Kind::Number } else { Kind::Text };
            merge(&mut m, c, k);
        }
        m
    })
}

/// Add a row type's columns, each kind from its default value (`null`: asked of `null_kind`).
fn add(
    m: &mut BTreeMap<String, Kind>,
    v: Result<serde_json::Value, serde_json::Error>,
    null_kind: impl Fn(&str) -> Kind,
) {
    let Ok(serde_json::Value::Object(o)) = v else {
        unreachable!("a row type serializes to an object");
    };
    for (c, v) in o {
        let k = match v {
            serde_json::Value::Number(n) if n.is_u64() => Kind::Count,
            serde_json::Value::Number(_) => Kind::Number,
            serde_json::Value::Bool(_) => Kind::Bool,
            serde_json::Value::Null => null_kind(&c),
            _ => Kind::Text,
        };
        merge(m, &c, k);
    }
}

fn merge(m: &mut BTreeMap<String, Kind>, c: &str, k: Kind) {
    let e = m.entry(c.to_owned()).or_insert(k);
    *e = match (*e, k) {
        (a, b) if a == b => a,
        (Kind::Count | Kind::Number, Kind::Count | Kind::Number) => Kind::Number,
        _ => Kind::Text,
    };
}

/// Check a selector value against its column's kind (numbers for numeric columns, booleans
/// for boolean ones; a string that reads as one passes).
pub(crate) fn check_kind(kind: Kind, v: &toml::Value) -> Result<(), String> {
    let ok = |x: &toml::Value| match (kind, x) {
        (Kind::Text, _) => true,
        (Kind::Number, toml::Value::Integer(_) | toml::Value::Float(_)) => true,
        (Kind::Number, toml::Value::String(s)) => s.trim().parse::<f64>().is_ok(),
        (Kind::Count, toml::Value::Integer(i)) => *i >= 0,
        (Kind::Count, toml::Value::Float(f)) => *f >= 0.0 && f.fract() == 0.0,
        (Kind::Count, toml::Value::String(s)) => s.trim().parse::<u64>().is_ok(),
        (Kind::Bool, toml::Value::Boolean(_)) => true,
        (Kind::Bool, toml::Value::String(s)) => s == "true" || s == "false",
        _ => false,
    };
    let alts: Vec<&toml::Value> = match v {
        toml::Value::Array(a) => a.iter().collect(),
        v => vec![v],
    };
    match alts.into_iter().find(|x| !ok(x)) {
        None => Ok(()),
        Some(x) => Err(format!(
            "{x} is not {}",
            match kind {
                Kind::Number => "a number (the column is numeric)",
                Kind::Count => "a whole number at least 0 (the column counts)",
                _ => "true or false",
            }
        )),
    }
}

/// Whether `k` names something a selector or `per` can read.
pub(crate) fn is_known(k: &str) -> bool {
    PSEUDO.contains(&k) || known().contains_key(k)
}

/// Whether a CSV header is one trace-bench writes besides results (`dynamic.csv`,
/// `dynamic-choice.csv`, `weights.csv`).
pub(crate) fn is_ours(header: &[String]) -> bool {
    use tb_results::tables::{ChoiceRow, DynamicRow};
    let keys = |v: Result<serde_json::Value, serde_json::Error>| -> Vec<String> {
        match v {
            Ok(serde_json::Value::Object(o)) => o.keys().cloned().collect(),
            _ => Vec::new(),
        }
    };
    let weights: Vec<String> = tb_results::tables::WEIGHTS_COLUMNS
        .iter()
        .map(|c| c.0.to_owned())
        .collect();
    [
        keys(serde_json::to_value(DynamicRow::default())),
        keys(serde_json::to_value(ChoiceRow::default())),
        weights,
    ]
    .iter()
    .any(|h| h[..] == header[..])
}
