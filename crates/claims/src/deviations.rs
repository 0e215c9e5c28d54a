//! Where our implementation differs from a paper, as data: `claims/deviations/PAPER.toml`
//! beside `claims/PAPER.toml`, one `[[deviation]]` per difference (what, why, its kind and the
//! claims it touches), rendered as REPRODUCTION.md's "Deviations" section. Every claim a
//! deviation names must be in the paper's claims file: a deviation naming an unknown claim is
//! refused when it loads.

use super::schema::ClaimsFile;
use crate::Error;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// One paper's deviations file.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviationsFile {
    #[serde(default, rename = "deviation")]
    deviations: Vec<Deviation>,
}

/// One difference between our implementation and the paper.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Deviation {
    /// What the deviation changes: a method, a measure, a view or the hardware.
    pub kind: DeviationKind,
    /// What differs (ours against the paper's).
    pub what: String,
    /// Why it differs (or why it is kept).
    pub why: String,
    /// The claims it touches: ids, globs (`t5-cpu-*`), `measure:NAME` (every claim of that
    /// measure), `device:NAME` (every claim evaluated on that device), or several of these
    /// joined by `&` (claims matching all: `measure:time & device:cpu`); each must match.
    pub claims: Vec<String>,
}

/// What a deviation changes.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum DeviationKind {
    /// A method (builder, traversal, rule) that is not the paper's.
    Method,
    /// A measure (counter, memory, time) that is not counted as the paper counts it.
    Measure,
    /// A scene or view that is not the paper's.
    View,
    /// The machine: device, cores, timing.
    Hardware,
}

impl DeviationKind {
    /// The kind as the report names it (`method`, `measure`, `scene or view`, `hardware`).
    pub fn as_str(self) -> &'static str {
        match self {
            DeviationKind::Method => "method",
            DeviationKind::Measure => "measure",
            DeviationKind::View => "scene or view",
            DeviationKind::Hardware => "hardware",
        }
    }
}

/// A deviation with the ids of the claims it touches.
#[derive(Clone, Debug, Serialize)]
pub struct Resolved {
    /// The deviation as its file states it.
    #[serde(flatten)]
    pub deviation: Deviation,
    /// Every claim id its `claims` match, in the file's order.
    pub ids: Vec<String>,
    /// The claims as the report shows them: an id as itself, a pattern by its ids when few,
    /// else with its count.
    #[serde(skip)]
    pub shown: String,
}

/// The deviations file of the claims file `claims_path`: `deviations/STEM.toml` beside it.
pub fn path_for(claims_path: &Path) -> PathBuf {
    let stem = claims_path.file_stem().unwrap_or_default();
    claims_path
        .parent()
        .unwrap_or(Path::new("."))
        .join("deviations")
        .join(Path::new(stem).with_extension("toml"))
}

/// The deviations of the paper whose claims file is `claims_path` (none without a file),
/// every claim they name checked against `file`.
pub fn load(claims_path: &Path, file: &ClaimsFile) -> Result<Vec<Resolved>, Error> {
    let path = path_for(claims_path);
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    parse(&path, &text, file)
}

/// [`load`] on text already read (`path` names it in errors).
pub fn parse(path: &Path, text: &str, file: &ClaimsFile) -> Result<Vec<Resolved>, Error> {
    let raw: DeviationsFile =
        toml::from_str(text).map_err(|e| super::syntax_error(path, text, &e))?;
    let mut out = Vec::new();
    for (i, d) in raw.deviations.into_iter().enumerate() {
        let err = |key: &str, message: String| Error::Config {
            file: path.into(),
            line: super::schema::find_line(text, "[[deviation]]", i),
            key: format!("deviation[{i}].{key}"),
            message,
        };
        if d.what.trim().is_empty() || d.why.trim().is_empty() {
            return Err(err("what", "give what differs and why, in words".into()));
        }
        if d.claims.is_empty() {
            return Err(err("claims", "name the claims it touches".into()));
        }
        let mut ids: Vec<String> = Vec::new();
        let mut shown: Vec<String> = Vec::new();
        for p in &d.claims {
            let m = matching(p, file);
            if m.is_empty() {
                return Err(err(
                    "claims",
                    format!(
                        "`{p}` names no claim of the paper's claims file ({})",
                        file.paper
                    ),
                ));
            }
            shown.push(shown_pattern(p, &m));
            ids.extend(
                m.into_iter()
                    .filter(|id| !ids.contains(id))
                    .collect::<Vec<_>>(),
            );
        }
        let order = |id: &String| file.claims.iter().position(|c| &c.id == id);
        ids.sort_by_key(order);
        out.push(Resolved {
            deviation: d,
            ids,
            shown: shown.join(", "),
        });
    }
    Ok(out)
}

/// The ids of the claims of `file` that `pattern` names.
fn matching(pattern: &str, file: &ClaimsFile) -> Vec<String> {
    let hit = |c: &super::Claim, p: &str| {
        if let Some(m) = p.strip_prefix("measure:") {
            c.measures().any(|x| x == m)
        } else if let Some(d) = p.strip_prefix("device:") {
            c.devices.iter().any(|x| x == d)
        } else {
            super::eval::select::glob(p, &c.id)
        }
    };
    file.claims
        .iter()
        .filter(|c| pattern.split('&').all(|p| hit(c, p.trim())))
        .map(|c| c.id.clone())
        .collect()
}

/// A pattern as the report shows it: an id as `id`, any other by its ids when few, else with
/// its count.
fn shown_pattern(p: &str, ids: &[String]) -> String {
    if ids.len() == 1 && ids[0] == p {
        format!("`{p}`")
    } else if ids.len() <= 4 {
        ids.iter()
            .map(|i| format!("`{i}`"))
            .collect::<Vec<_>>()
            .join(", ")
    } else {
        format!("`{p}` ({} claims)", ids.len())
    }
}

/// One paper's deviations as a Markdown table: kind | what | why | claims touched.
pub fn markdown(ds: &[Resolved]) -> String {
    let e = |x: &str| x.replace('|', "\\|").replace('\n', " ");
    let mut s = String::from("| kind | what differs | why | claims touched |\n|---|---|---|---|\n");
    for d in ds {
        s.push_str(&format!(
            "| {} | {} | {} | {}{} |\n",
            d.deviation.kind.as_str(),
            e(&d.deviation.what),
            e(&d.deviation.why),
            d.shown,
            if d.deviation.claims.len() > 1 {
                format!("; {} claims in all", d.ids.len())
            } else {
                String::new()
            }
        ));
    }
    s
}
