//! No number that is not a number: every float a config or claims file gives is finite
//! (issue 62). TOML writes `nan` and `inf`, which serde then takes as any other float, and a
//! NaN compares false with every bound, so a check written `if x < lo || x > hi` lets it
//! through. [`check_toml`] refuses such a value anywhere in a file, naming its key and line,
//! before the file's own checks read it: no value of trace-bench's files means "infinite" or
//! "not a number".

use crate::error::{line_of, Error};
use std::path::Path;
use toml_edit::{Item, Value};

/// The first float of `text` (TOML, named `file` in the error) that is NaN or infinite: an
/// [`Error::Config`] naming its dotted key (`scene.light`) and line. `Ok` where there is none
/// or where `text` does not parse (the caller's parser reports that).
pub fn check_toml(file: &Path, text: &str) -> Result<(), Error> {
    let Ok(doc) = toml_edit::ImDocument::parse(text) else {
        return Ok(());
    };
    let mut bad = None;
    walk_table(doc.as_table(), "", &mut bad);
    match bad {
        None => Ok(()),
        Some((key, at, x)) => Err(Error::Config {
            file: file.to_path_buf(),
            line: line_of(text, at),
            key,
            message: format!("{x} is not a finite number: give a finite value"),
        }),
    }
}

type Bad = Option<(String, usize, f64)>;

fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_owned()
    } else {
        format!("{prefix}.{key}")
    }
}

fn walk_table(t: &toml_edit::Table, prefix: &str, bad: &mut Bad) {
    for (k, item) in t.iter() {
        walk_item(item, &join(prefix, k), bad);
    }
}

fn walk_item(item: &Item, key: &str, bad: &mut Bad) {
    match item {
        Item::Value(v) => walk_value(v, key, bad),
        Item::Table(t) => walk_table(t, key, bad),
        Item::ArrayOfTables(a) => a.iter().for_each(|t| walk_table(t, key, bad)),
        Item::None => {}
    }
}

fn walk_value(v: &Value, key: &str, bad: &mut Bad) {
    if bad.is_some() {
        return;
    }
    match v {
        Value::Float(f) if !f.value().is_finite() => {
            *bad = Some((key.to_owned(), f.span().map_or(0, |s| s.start), *f.value()));
        }
        Value::Array(a) => a.iter().for_each(|x| walk_value(x, key, bad)),
        Value::InlineTable(t) => {
            for (k, x) in t.iter() {
                walk_value(x, &join(key, k), bad);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_float_that_is_not_finite_is_named_with_its_line() {
        let file = Path::new("c.toml");
        let ok = "[run]\ntarget_ci = 0.05\n[[scene]]\nlight = [0, 1.5, 2]\n";
        assert!(check_toml(file, ok).is_ok());
        for (text, key, line) in [
            ("[run]\ntarget_ci = nan\n", "run.target_ci", 2),
            ("[[scene]]\nsource = \"a\"\n[[scene]]\nlight = [inf, 0, 0]\n", "scene.light", 4),
            ("[[scene]]\ncamera = { eye = [0, -nan, 1] }\n", "scene.camera.eye", 2),
            ("[[structure]]\nparams = { alpha = [1.0, -inf] }\n", "structure.params.alpha", 2),
            ("[[claim]]\n[claim.test]\nbound = +inf\n", "claim.test.bound", 3),
        ] {
            let e = check_toml(file, text).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("c.toml:{line}: {key}: ")) && e.contains("not a finite number"),
                "{text}: {e}"
            );
        }
        // Not TOML: left to the caller's parser.
        assert!(check_toml(file, "[run\n").is_ok());
    }
}
