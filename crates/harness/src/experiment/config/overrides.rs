//! Command-line changes to a config without editing it: `--set key=value` (applied to the TOML
//! before it is checked, so the effective config is what `results.json` records) and the
//! `--scene` / `--structure` filters.

use super::{scene_label, Ctx, RawConfig};
use crate::error::HarnessError;
use toml::Value;

/// Apply `key=value` settings to config `text`; the value is TOML (`9`, `[1, 2]`, `"x"`) or,
/// when it does not parse as TOML, a string. A dotted key walks tables; an array of tables
/// (`scene`, `structure`) is entered element by element, so `scene.camera.width=256` sets
/// every scene's camera width, unless an index follows it (`structure.1.params.beta=[1, 2]`:
/// the second `[[structure]]` table only). Returns the effective config text.
pub fn apply_sets(file: &str, text: &str, sets: &[String]) -> Result<String, HarnessError> {
    let bad = |set: &str, m: &str| {
        HarnessError::File(tb_results::Error::ConfigSyntax {
            file: file.into(),
            message: format!("--set {set}: {m}"),
        })
    };
    let mut doc: toml::Table = toml::from_str(text).map_err(|e| {
        HarnessError::File(tb_results::Error::ConfigSyntax {
            file: file.into(),
            message: e.message().trim().replace('\n', " "),
        })
    })?;
    for set in sets {
        let (key, raw) = set
            .split_once('=')
            .ok_or_else(|| bad(set, "expected key=value"))?;
        let path: Vec<&str> = key.trim().split('.').collect();
        if path.iter().any(|p| p.is_empty()) {
            return Err(bad(set, "empty key"));
        }
        let value = toml::from_str::<toml::Table>(&format!("v = {raw}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| Value::String(raw.to_string()));
        set_path(&mut doc, &path, &value).map_err(|m| bad(set, &m))?;
    }
    toml::to_string(&doc).map_err(|e| bad("", &e.to_string()))
}

fn set_path(t: &mut toml::Table, path: &[&str], value: &Value) -> Result<(), String> {
    let (first, rest) = path.split_first().expect("non-empty path");
    if rest.is_empty() {
        t.insert(first.to_string(), value.clone());
        return Ok(());
    }
    let entry = t
        .entry(first.to_string())
        .or_insert_with(|| Value::Table(toml::Table::new()));
    match entry {
        Value::Table(sub) => set_path(sub, rest, value),
        Value::Array(items) if !items.is_empty() && items.iter().all(Value::is_table) => {
            // `structure.1.params.beta=…`: only the second table of the array.
            if let Ok(i) = rest[0].parse::<usize>() {
                let n = items.len();
                return match (items.get_mut(i), &rest[1..]) {
                    (Some(Value::Table(sub)), more) if !more.is_empty() => {
                        set_path(sub, more, value)
                    }
                    (Some(_), _) => Err(format!("`{first}.{i}` is a table: name a key in it")),
                    (None, _) => Err(format!("`{first}` has {n} tables (0 to {})", n - 1)),
                };
            }
            for item in items {
                if let Value::Table(sub) = item {
                    set_path(sub, rest, value)?;
                }
            }
            Ok(())
        }
        other => Err(format!("`{first}` is {}, not a table", other.type_str())),
    }
}

/// Keep only the scenes labelled (or sourced) as one of `names`, and the structures named in
/// `structures` (`NAME` or `NAME:traversal`, the latter running only that traversal).
pub(super) fn filter(
    cx: &Ctx,
    raw: &mut RawConfig,
    scenes: &[String],
    structures: &[String],
) -> Result<(), HarnessError> {
    if !scenes.is_empty() {
        filter_scenes(cx, raw, scenes)?;
    }
    if !structures.is_empty() {
        filter_structures(cx, raw, structures)?;
    }
    Ok(())
}

/// Keep only the scenes labelled (or sourced) as one of `scenes`.
fn filter_scenes(cx: &Ctx, raw: &mut RawConfig, scenes: &[String]) -> Result<(), HarnessError> {
    let label = |s: &super::RawScene| {
        s.name
            .clone()
            .unwrap_or_else(|| scene_label(s.source.get_ref()))
    };
    for n in scenes {
        if !raw
            .scenes
            .iter()
            .any(|s| &label(s) == n || s.source.get_ref() == n)
        {
            let known: Vec<String> = raw.scenes.iter().map(label).collect();
            return Err(cx.err(
                0..0,
                "scene",
                format!("--scene {n}: no such scene (labels: {})", known.join(", ")),
            ));
        }
    }
    raw.scenes.retain(|s| {
        scenes
            .iter()
            .any(|n| *n == label(s) || n == s.source.get_ref())
    });
    Ok(())
}

/// Keep only the structures named in `structures` (`NAME` or `NAME:traversal`).
fn filter_structures(
    cx: &Ctx,
    raw: &mut RawConfig,
    structures: &[String],
) -> Result<(), HarnessError> {
    // Per block of the config: `None` = not asked for; `Some(None)` = asked for whole;
    // `Some(Some(list))` = only these traversals. A block is kept once, so its builds run
    // once, however many of its traversals are asked for; `NAME:traversal` picks the
    // blocks of that name that run the traversal (those that list it, or list none).
    let mut want: Vec<Option<Option<Vec<String>>>> = vec![None; raw.structures.len()];
    for spec in structures {
        let (name, traversal) = match spec.split_once(':') {
            Some((n, t)) => (n, Some(t)),
            None => (spec.as_str(), None),
        };
        let named: Vec<usize> = (0..raw.structures.len())
            .filter(|&i| raw.structures[i].name.get_ref() == name)
            .collect();
        if named.is_empty() {
            let known: Vec<&str> = raw
                .structures
                .iter()
                .map(|s| s.name.get_ref().as_str())
                .collect();
            return Err(cx.err(
                0..0,
                "structure",
                format!(
                    "--structure {spec}: the config has no structure `{name}` (has: {})",
                    known.join(", ")
                ),
            ));
        }
        let Some(t) = traversal else {
            for i in named {
                want[i] = Some(None);
            }
            continue;
        };
        let runs = |i: &usize| {
            raw.structures[*i]
                .traversals
                .as_ref()
                .is_none_or(|l| l.get_ref().iter().any(|x| x == t))
        };
        let running: Vec<usize> = named.iter().copied().filter(runs).collect();
        if running.is_empty() {
            return Err(cx.err(
                0..0,
                "structure",
                format!(
                    "--structure {spec}: no `{name}` table of the config runs traversal `{t}` (its `traversals` lists leave it out)"
                ),
            ));
        }
        for i in running {
            match &mut want[i] {
                Some(None) => {}
                Some(Some(list)) => {
                    if !list.iter().any(|x| x == t) {
                        list.push(t.to_string());
                    }
                }
                w @ None => *w = Some(Some(vec![t.to_string()])),
            }
        }
    }
    let mut kept = Vec::new();
    for (s, w) in raw.structures.iter().zip(want) {
        let Some(only) = w else { continue };
        let mut s = s.clone();
        if let Some(list) = only {
            s.traversals = Some(toml::Spanned::new(s.name.span(), list));
        }
        kept.push(s);
    }
    raw.structures = kept;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_walk_tables_and_arrays_of_tables() {
        let text = "[run]\nrepeat = 3\n[[scene]]\nsource = \"a\"\n[[scene]]\nsource = \"b\"\ncamera = { width = 64 }\n";
        let out = apply_sets(
            "t.toml",
            text,
            &[
                "run.repeat=9".into(),
                "scene.camera.width=256".into(),
                "run.triangle_test=watertight".into(),
            ],
        )
        .unwrap();
        let t: toml::Table = toml::from_str(&out).unwrap();
        assert_eq!(t["run"]["repeat"].as_integer(), Some(9));
        assert_eq!(t["run"]["triangle_test"].as_str(), Some("watertight"));
        for s in t["scene"].as_array().unwrap() {
            assert_eq!(s["camera"]["width"].as_integer(), Some(256));
        }
        // An index enters one table of an array of tables only.
        let out = apply_sets("t.toml", text, &["scene.1.camera.width=32".into()]).unwrap();
        let t: toml::Table = toml::from_str(&out).unwrap();
        let widths: Vec<Option<i64>> = t["scene"]
            .as_array()
            .unwrap()
            .iter()
            .map(|s| s.get("camera").and_then(|c| c["width"].as_integer()))
            .collect();
        assert_eq!(widths, [None, Some(32)]);
        for bad in ["scene.2.source=c", "scene.1=3"] {
            assert!(apply_sets("t.toml", text, &[bad.into()]).is_err(), "{bad}");
        }
        let e = apply_sets("t.toml", text, &["run.repeat.x=1".into()]).unwrap_err();
        assert!(e.to_string().contains("--set run.repeat.x=1"), "{e}");
        assert!(apply_sets("t.toml", text, &["repeat".into()]).is_err());
    }
}
