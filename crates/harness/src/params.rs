//! Structure parameters: typed specs with defaults, checked config values, sweeps.
//!
//! A builder declares its parameters as [`ParamSpec`]s (name, kind with range, default, doc
//! citing the paper's symbol). A config's `params` table gives each a value or a list of
//! values; lists expand into the cartesian product of parameter sets (a sweep), in the order of
//! the specs.

use std::fmt;

/// The type and range of a parameter.
#[derive(Clone, Copy, Debug)]
pub enum ParamKind {
    Int { min: i64, max: i64 },
    Float { min: f64, max: f64 },
    Bool,
    Choice(&'static [&'static str]),
}

/// One declared parameter.
#[derive(Clone, Copy, Debug)]
pub struct ParamSpec {
    pub name: &'static str,
    pub kind: ParamKind,
    /// Default, written as in a config (`"16"`, `"1.0"`, `"true"`, `"sah"`).
    pub default: &'static str,
    pub doc: &'static str,
}

/// A parameter value.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    Int(i64),
    Float(f64),
    Bool(bool),
    Str(String),
}

impl fmt::Display for ParamValue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamValue::Int(v) => write!(f, "{v}"),
            ParamValue::Float(v) => write!(f, "{v}"),
            ParamValue::Bool(v) => write!(f, "{v}"),
            ParamValue::Str(v) => write!(f, "{v}"),
        }
    }
}

impl ParamSpec {
    /// Check and convert one TOML value against this spec.
    pub fn convert(&self, v: &toml::Value) -> Result<ParamValue, String> {
        match (self.kind, v) {
            (ParamKind::Int { min, max }, toml::Value::Integer(i)) => {
                if *i < min || *i > max {
                    Err(format!("{i} is out of range {min}..={max}"))
                } else {
                    Ok(ParamValue::Int(*i))
                }
            }
            (ParamKind::Float { min, max }, toml::Value::Integer(_) | toml::Value::Float(_)) => {
                let x = match v {
                    toml::Value::Integer(i) => *i as f64,
                    toml::Value::Float(x) => *x,
                    _ => unreachable!(),
                };
                if !(x >= min && x <= max) {
                    Err(format!("{x} is out of range {min}..={max}"))
                } else {
                    Ok(ParamValue::Float(x))
                }
            }
            (ParamKind::Bool, toml::Value::Boolean(b)) => Ok(ParamValue::Bool(*b)),
            (ParamKind::Choice(options), toml::Value::String(s)) => {
                if options.contains(&s.as_str()) {
                    Ok(ParamValue::Str(s.clone()))
                } else {
                    Err(format!("`{s}` is not one of {}", options.join(", ")))
                }
            }
            (kind, v) => Err(format!(
                "expected {}, found {}",
                kind_name(kind),
                v.type_str()
            )),
        }
    }

    /// The default as a value.
    pub fn default_value(&self) -> ParamValue {
        let v: toml::Value = match self.kind {
            ParamKind::Choice(_) => toml::Value::String(self.default.to_string()),
            _ => toml::from_str::<toml::Table>(&format!("v = {}", self.default))
                .ok()
                .and_then(|t| t.get("v").cloned())
                .unwrap_or(toml::Value::String(self.default.into())),
        };
        self.convert(&v)
            .unwrap_or_else(|e| panic!("default of `{}` is invalid: {e}", self.name))
    }
}

fn kind_name(k: ParamKind) -> String {
    match k {
        ParamKind::Int { .. } => "an integer".into(),
        ParamKind::Float { .. } => "a number".into(),
        ParamKind::Bool => "true or false".into(),
        ParamKind::Choice(o) => format!("one of \"{}\"", o.join("\", \"")),
    }
}

/// A full set of parameter values, in spec order.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ParamSet(pub Vec<(&'static str, ParamValue)>);

impl ParamSet {
    fn get(&self, name: &str) -> &ParamValue {
        &self
            .0
            .iter()
            .find(|(n, _)| *n == name)
            .unwrap_or_else(|| panic!("no parameter `{name}`"))
            .1
    }

    pub fn int(&self, name: &str) -> i64 {
        match self.get(name) {
            ParamValue::Int(v) => *v,
            v => panic!("parameter `{name}` is not an integer: {v}"),
        }
    }

    pub fn float(&self, name: &str) -> f64 {
        match self.get(name) {
            ParamValue::Float(v) => *v,
            ParamValue::Int(v) => *v as f64,
            v => panic!("parameter `{name}` is not a number: {v}"),
        }
    }

    pub fn bool(&self, name: &str) -> bool {
        match self.get(name) {
            ParamValue::Bool(v) => *v,
            v => panic!("parameter `{name}` is not a bool: {v}"),
        }
    }

    pub fn str(&self, name: &str) -> &str {
        match self.get(name) {
            ParamValue::Str(v) => v,
            v => panic!("parameter `{name}` is not a string: {v}"),
        }
    }
}

impl fmt::Display for ParamSet {
    /// `name=value;name=value` in spec order (the `params` column).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (n, v)) in self.0.iter().enumerate() {
            if i > 0 {
                write!(f, ";")?;
            }
            write!(f, "{n}={v}")?;
        }
        Ok(())
    }
}

/// Expand a config's `params` table into parameter sets. `Err((key, message))` names the
/// offending key.
pub fn expand(specs: &[ParamSpec], table: &toml::Table) -> Result<Vec<ParamSet>, (String, String)> {
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
            None => vec![spec.default_value()],
            Some(toml::Value::Array(list)) => {
                if list.is_empty() {
                    return Err((spec.name.into(), "an empty list sweeps over nothing".into()));
                }
                let mut out = Vec::new();
                for v in list {
                    out.push(spec.convert(v).map_err(|m| (spec.name.to_string(), m))?);
                }
                out
            }
            Some(v) => vec![spec.convert(v).map_err(|m| (spec.name.to_string(), m))?],
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

    const SPECS: &[ParamSpec] = &[
        ParamSpec {
            name: "bins",
            kind: ParamKind::Int { min: 2, max: 256 },
            default: "16",
            doc: "",
        },
        ParamSpec {
            name: "c_trav",
            kind: ParamKind::Float { min: 0.0, max: 1e3 },
            default: "1.0",
            doc: "",
        },
        ParamSpec {
            name: "split",
            kind: ParamKind::Choice(&["sah", "median"]),
            default: "sah",
            doc: "",
        },
    ];

    #[test]
    fn sweeps_expand_in_spec_order() {
        let t: toml::Table =
            toml::from_str("bins = [4, 8]\nsplit = [\"sah\", \"median\"]").unwrap();
        let sets = expand(SPECS, &t).unwrap();
        assert_eq!(sets.len(), 4);
        assert_eq!(sets[0].to_string(), "bins=4;c_trav=1;split=sah");
        assert_eq!(sets[3].to_string(), "bins=8;c_trav=1;split=median");
        assert_eq!(sets[1].int("bins"), 4);
        assert_eq!(sets[1].float("c_trav"), 1.0);
    }

    #[test]
    fn bad_values_name_the_key() {
        let t: toml::Table = toml::from_str("bins = 1").unwrap();
        assert_eq!(expand(SPECS, &t).unwrap_err().0, "bins");
        let t: toml::Table = toml::from_str("bins = \"x\"").unwrap();
        assert!(expand(SPECS, &t)
            .unwrap_err()
            .1
            .contains("expected an integer"));
        let t: toml::Table = toml::from_str("leaf = 3").unwrap();
        assert!(expand(SPECS, &t)
            .unwrap_err()
            .1
            .contains("unknown parameter"));
        let t: toml::Table = toml::from_str("split = \"x\"").unwrap();
        assert!(expand(SPECS, &t).unwrap_err().1.contains("not one of"));
    }
}
