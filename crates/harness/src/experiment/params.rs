//! A config's `params` table to parameter sets: checked against the structure's own table
//! ([`tb_core::params`](mod@tb_core::params), declared next to its params struct), defaults from the structure.
//! Each key gives a value or a list of values; lists expand into the cartesian product of
//! parameter sets (a sweep), in the order of the specs.

use tb_core::params::{ParamKind, ParamSet, ParamSpec, ParamValue};

/// Check and convert one TOML value against `spec` (kind and range).
pub fn convert(spec: &ParamSpec, v: &toml::Value) -> Result<ParamValue, String> {
    let value = match (spec.kind, v) {
        (ParamKind::Int { .. }, toml::Value::Integer(i)) => ParamValue::Int(*i),
        (ParamKind::Float { .. }, toml::Value::Integer(i)) => ParamValue::Float(*i as f64),
        (ParamKind::Float { .. }, toml::Value::Float(x)) => ParamValue::Float(*x),
        (ParamKind::Bool, toml::Value::Boolean(b)) => ParamValue::Bool(*b),
        (ParamKind::Choice(_), toml::Value::String(s)) => ParamValue::Str(s.clone()),
        (kind, v) => {
            return Err(format!(
                "expected {}, found {}",
                kind.describe(),
                v.type_str()
            ))
        }
    };
    spec.check(&value)?;
    Ok(value)
}

/// Expand a config's `params` table into parameter sets. `Err((key, message))` names the
/// offending key.
pub fn expand(
    specs: &[ParamSpec],
    defaults: &ParamSet,
    table: &toml::Table,
) -> Result<Vec<ParamSet>, (String, String)> {
    for key in table.keys() {
        if !specs.iter().any(|s| s.name == key) {
            let known: Vec<&str> = specs.iter().map(|s| s.name).collect();
            let msg = if known.is_empty() {
                "this structure takes no parameters".to_string()
            } else {
                format!("unknown parameter (known: {})", known.join(", "))
            };
            return Err((key.clone(), msg));
        }
    }
    let mut axes: Vec<(&'static str, Vec<ParamValue>)> = Vec::new();
    for spec in specs {
        let values = match table.get(spec.name) {
            None => vec![defaults
                .get(spec.name)
                .cloned()
                .ok_or_else(|| (spec.name.to_string(), "has no default".to_string()))?],
            Some(toml::Value::Array(list)) => {
                if list.is_empty() {
                    return Err((spec.name.into(), "an empty list sweeps over nothing".into()));
                }
                let mut out = Vec::new();
                for v in list {
                    out.push(convert(spec, v).map_err(|m| (spec.name.to_string(), m))?);
                }
                out
            }
            Some(v) => vec![convert(spec, v).map_err(|m| (spec.name.to_string(), m))?],
        };
        axes.push((spec.name, values));
    }
    let mut sets = vec![ParamSet::default()];
    for (name, values) in axes {
        let mut next = Vec::with_capacity(sets.len() * values.len());
        for s in &sets {
            for v in &values {
                let mut s2 = s.clone();
                s2.0.push((name, v.clone()));
                next.push(s2);
            }
        }
        sets = next;
    }
    Ok(sets)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::Params;

    tb_core::choice! {
        #[derive(Clone, Copy, Debug, PartialEq)]
        enum Split { Sah = "sah", Median = "median" }
    }

    tb_core::params! {
        #[derive(Clone, Copy, Debug, PartialEq)]
        struct P {
            bins: u32 = 16, ParamKind::Int { min: 2, max: 256 };
            c_trav: f32 = 1.0, ParamKind::Float { min: 0.0, max: 1e3 };
            split: Split = Split::Sah, ParamKind::Choice(Split::NAMES);
        }
    }

    fn expand_p(t: &str) -> Result<Vec<ParamSet>, (String, String)> {
        let t: toml::Table = toml::from_str(t).unwrap();
        expand(P::SPECS, &P::default().to_set(), &t)
    }

    #[test]
    fn sweeps_expand_in_spec_order() {
        let sets = expand_p("bins = [4, 8]\nsplit = [\"sah\", \"median\"]").unwrap();
        assert_eq!(sets.len(), 4);
        assert_eq!(sets[0].to_string(), "bins=4;c_trav=1;split=sah");
        assert_eq!(sets[3].to_string(), "bins=8;c_trav=1;split=median");
        let p = P::from_set(&sets[3]).unwrap();
        assert_eq!((p.bins, p.c_trav, p.split), (8, 1.0, Split::Median));
    }

    #[test]
    fn bad_values_name_the_key() {
        assert_eq!(expand_p("bins = 1").unwrap_err().0, "bins");
        assert!(expand_p("bins = \"x\"")
            .unwrap_err()
            .1
            .contains("expected an integer"));
        assert!(expand_p("leaf = 3")
            .unwrap_err()
            .1
            .contains("unknown parameter"));
        assert!(expand_p("split = \"x\"")
            .unwrap_err()
            .1
            .contains("not one of"));
        assert!(expand_p("bins = []").unwrap_err().1.contains("empty list"));
    }
}
