//! No number that is not a number: every float a config or claims file gives is finite.
//! TOML writes `nan` and `inf`, which serde then takes as any other float, and a NaN compares
//! false with every bound, so a check written `if x < lo || x > hi` lets it
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

/// The dotted key (`scene.inset`, `run.repeat`) of the innermost value or table of `text`
/// whose span holds byte `pos`: where a TOML error points, for a message that names no key
/// ("missing field `scale`", "invalid type: map, expected a sequence").
pub fn key_at(text: &str, pos: usize) -> Option<String> {
    let doc = toml_edit::ImDocument::parse(text).ok()?;
    let mut best = None;
    key_in_table(doc.as_table(), "", pos, &mut best);
    best
}

fn holds(span: Option<std::ops::Range<usize>>, pos: usize) -> bool {
    span.is_some_and(|s| s.start <= pos && pos < s.end.max(s.start + 1))
}

fn key_in_table(t: &toml_edit::Table, prefix: &str, pos: usize, best: &mut Option<String>) {
    for (k, item) in t.iter() {
        let key = join(prefix, k);
        let key_span = t.key(k).and_then(|k| k.span());
        match item {
            Item::Value(v) => {
                let whole = key_span
                    .clone()
                    .zip(v.span())
                    .map(|(a, b)| a.start..b.end)
                    .or(v.span());
                if holds(whole, pos) {
                    *best = Some(key.clone());
                    key_in_value(v, &key, pos, best);
                }
            }
            Item::Table(sub) => {
                if holds(sub.span(), pos) || holds(key_span, pos) {
                    *best = Some(key.clone());
                }
                key_in_table(sub, &key, pos, best);
            }
            Item::ArrayOfTables(a) => {
                for sub in a.iter() {
                    if holds(sub.span(), pos) {
                        *best = Some(key.clone());
                    }
                    key_in_table(sub, &key, pos, best);
                }
            }
            Item::None => {}
        }
    }
}

fn key_in_value(v: &Value, key: &str, pos: usize, best: &mut Option<String>) {
    if let Value::InlineTable(t) = v {
        for (k, x) in t.iter() {
            let sub = join(key, k);
            let whole = t
                .key(k)
                .and_then(|k| k.span())
                .zip(x.span())
                .map(|(a, b)| a.start..b.end);
            if holds(whole, pos) {
                *best = Some(sub.clone());
                key_in_value(x, &sub, pos, best);
            }
        }
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
            (
                "[[scene]]\nsource = \"a\"\n[[scene]]\nlight = [inf, 0, 0]\n",
                "scene.light",
                4,
            ),
            (
                "[[scene]]\ncamera = { eye = [0, -nan, 1] }\n",
                "scene.camera.eye",
                2,
            ),
            (
                "[[structure]]\nparams = { alpha = [1.0, -inf] }\n",
                "structure.params.alpha",
                2,
            ),
            (
                "[[claim]]\n[claim.test]\nbound = +inf\n",
                "claim.test.bound",
                3,
            ),
        ] {
            let e = check_toml(file, text).unwrap_err().to_string();
            assert!(
                e.starts_with(&format!("c.toml:{line}: {key}: "))
                    && e.contains("not a finite number"),
                "{text}: {e}"
            );
        }
        // Not TOML: left to the caller's parser.
        assert!(check_toml(file, "[run\n").is_ok());
    }

    #[test]
    fn the_key_at_an_error_is_found() {
        let text = "[run]\nrepeat = 3\n[[scene]]\nsource = \"a\"\n[scene.inset]\nat = [1, 2, 3]\n[[scene]]\ncamera = { width = 8, fov = 9 }\n";
        let at = |needle: &str| key_at(text, text.find(needle).unwrap());
        assert_eq!(at("3\n").as_deref(), Some("run.repeat"));
        assert_eq!(at("[scene.inset]").as_deref(), Some("scene.inset"));
        assert_eq!(at("[1, 2").as_deref(), Some("scene.inset.at"));
        assert_eq!(at("9 }").as_deref(), Some("scene.camera.fov"));
        assert_eq!(at("[run]").as_deref(), Some("run"));
    }
}
