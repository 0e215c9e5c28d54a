//! Where our implementation differs from a paper, as data: `claims/deviations/PAPER.toml`
//! beside `claims/PAPER.toml`, one `[[deviation]]` per difference (what, why, its kind and the
//! claims it touches), rendered as REPRODUCTION.md's "Deviations" section. Every claim a
//! deviation names must be in the paper's claims file: a deviation naming an unknown claim is
//! refused when it loads. A deviation's `check` tables tie the figures its text states to the
//! config keys, `[[run]]` tables and code they describe ([`check`]: a problem when either side
//! changes).

use super::schema::{ClaimsFile, RunSpec};
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
    /// Statements of `what` checked against the repository ([`check`]): each names a figure
    /// the text states (`says`) and where the code or a config holds it.
    #[serde(default, rename = "check", skip_serializing)]
    pub checks: Vec<Check>,
}

/// One figure a deviation's `what` states, checked against what it describes: a key of a
/// config (`config`, `key`, `value` or `len`), the `[[run]]`s of the paper's claims file (`run`,
/// optionally `scene`, `structure` and `device`, with `key`, `heavy` and/or `scalable`) or a literal of a
/// source file (`file`, `contains`). Paths are from the repository root.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Check {
    /// The figure as the text states it: `what` must contain this string.
    pub says: String,
    /// A config of the repository (`configs/sparse-boxes.toml`).
    #[serde(default)]
    pub config: Option<String>,
    /// The `[[run]]`s of the paper's claims file whose `config` matches (a glob: `*` every
    /// config run); each of them must hold the check, and one at least must match.
    #[serde(default)]
    pub run: Option<String>,
    /// With `run`: only the runs whose `scene` filter names it (`crown`).
    #[serde(default)]
    pub scene: Option<String>,
    /// With `run`: only the runs whose `structure` filter names it (`sparse-boxes:btr`).
    #[serde(default)]
    pub structure: Option<String>,
    /// With `run`: only the runs on that device (`cpu`, `gpu`): the run's `device`, else its
    /// config's `run.devices`, else the CPU.
    #[serde(default)]
    pub device: Option<String>,
    /// A dotted TOML key (`scene.camera.width`; in an array of tables the first element that
    /// has the rest, or an index: `scene.0.views.0.eye`); for a run, its `set` edit of the
    /// key (or of a key above it) if it has one, else its config's value.
    #[serde(default)]
    pub key: Option<String>,
    /// The value the text states for `key` (numbers compare by value: 90 = 90.0).
    #[serde(default)]
    pub value: Option<toml::Value>,
    /// Instead of `value`: the length of the array at `key`.
    #[serde(default)]
    pub len: Option<usize>,
    /// With `run`: whether the runs are `heavy` (made only with `reproduce --heavy`).
    #[serde(default)]
    pub heavy: Option<bool>,
    /// With `run`: whether reproduce may shrink their images (`scalable`).
    #[serde(default)]
    pub scalable: Option<bool>,
    /// A source file of the repository (`crates/kdtree/src/gpu.rs`).
    #[serde(default)]
    pub file: Option<String>,
    /// With `file`: a literal the file must contain (a constant the text states).
    #[serde(default)]
    pub contains: Option<String>,
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
        for (j, c) in d.checks.iter().enumerate() {
            c.shape()
                .map_err(|m| err(&format!("check[{j}]"), m.to_owned()))?;
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

impl Check {
    /// Whether the check's fields make one check: `config` with `key` and `value` or `len`;
    /// `run` with `key` (and `value` or `len`), `heavy` or `scalable`; `file` with `contains`.
    fn shape(&self) -> Result<(), &'static str> {
        if self.says.trim().is_empty() {
            return Err("give `says`, the figure `what` states");
        }
        let targets = [&self.config, &self.run, &self.file];
        if targets.iter().filter(|t| t.is_some()).count() != 1 {
            return Err("give one of `config`, `run` or `file`");
        }
        let keyed = self.value.is_some() || self.len.is_some();
        if self.value.is_some() && self.len.is_some() {
            return Err("give `value` or `len`, not both");
        }
        if self.key.is_some() != keyed {
            return Err("`key` takes `value` or `len`, and they take `key`");
        }
        let run_only = self.scene.is_some()
            || self.structure.is_some()
            || self.device.is_some()
            || self.heavy.is_some()
            || self.scalable.is_some();
        if self.file.is_some() {
            if self.contains.is_none() || self.key.is_some() || run_only {
                return Err("`file` takes `contains` only");
            }
        } else if self.contains.is_some() {
            return Err("`contains` goes with `file`");
        } else if self.config.is_some() {
            if self.key.is_none() || run_only {
                return Err("`config` takes `key` with `value` or `len`");
            }
        } else if self.key.is_none() && self.heavy.is_none() && self.scalable.is_none() {
            return Err("`run` takes `key` (with `value` or `len`), `heavy` or `scalable`");
        }
        Ok(())
    }

    /// What the check looks at, for its problem lines.
    fn target(&self) -> String {
        let mut s = match (&self.config, &self.run, &self.file) {
            (Some(c), _, _) => format!("config {c}"),
            (_, Some(r), _) => format!("run {r}"),
            (_, _, Some(f)) => format!("file {f}"),
            _ => String::new(),
        };
        for (name, v) in [
            ("scene", &self.scene),
            ("structure", &self.structure),
            ("device", &self.device),
        ] {
            if let Some(v) = v {
                s.push_str(&format!(" {name} {v}"));
            }
        }
        if let Some(k) = &self.key {
            s.push_str(&format!(", key {k}"));
        }
        s
    }

    /// How the check disagrees with the repository at `root` (`runs`: the paper's
    /// `[[run]]`s), one message each; none when it holds.
    fn problems(&self, what: &str, root: &Path, runs: &[RunSpec]) -> Vec<String> {
        let mut out = Vec::new();
        if !what.contains(&self.says) {
            out.push(format!("`what` does not say \"{}\"", self.says));
        }
        let found = if let Some(f) = &self.file {
            self.file_problem(root, f)
        } else if let Some(c) = &self.config {
            read_toml(root, c).and_then(|v| self.value_problem(lookup(&v, self.key())))
        } else {
            self.run_problem(root, runs)
        };
        out.extend(found.err());
        out
    }

    fn key(&self) -> &str {
        self.key.as_deref().unwrap_or_default()
    }

    fn file_problem(&self, root: &Path, file: &str) -> Result<(), String> {
        let text = std::fs::read_to_string(root.join(file))
            .map_err(|e| format!("cannot read {file}: {e}"))?;
        let lit = self.contains.as_deref().unwrap_or_default();
        if text.contains(lit) {
            Ok(())
        } else {
            Err(format!("{file} does not contain \"{lit}\""))
        }
    }

    /// `value` or `len` against `found`, the value at `key` (none: the key is absent).
    fn value_problem(&self, found: Option<&toml::Value>) -> Result<(), String> {
        let Some(v) = found else {
            return Err(format!("no key {}", self.key()));
        };
        if let Some(want) = &self.value {
            if !same(v, want) {
                return Err(format!("{} is {v}, the check states {want}", self.key()));
            }
        }
        if let Some(n) = self.len {
            match v.as_array() {
                Some(a) if a.len() == n => {}
                Some(a) => {
                    return Err(format!(
                        "{} has {} entries, the check states {n}",
                        self.key(),
                        a.len()
                    ))
                }
                None => return Err(format!("{} is {v}, not an array", self.key())),
            }
        }
        Ok(())
    }

    /// The check on every `[[run]]` it selects (at least one).
    fn run_problem(&self, root: &Path, runs: &[RunSpec]) -> Result<(), String> {
        let pat = self.run.as_deref().unwrap_or_default();
        let names =
            |list: &[String], x: &Option<String>| x.as_ref().is_none_or(|x| list.contains(x));
        let mut picked = 0;
        for (k, r) in runs.iter().enumerate() {
            let Some(config) = r.config.as_deref() else {
                continue;
            };
            let at = |m: String| format!("run[{k}] ({config}): {m}");
            if !super::eval::select::glob(pat, config)
                || !names(&r.scene, &self.scene)
                || !names(&r.structure, &self.structure)
                || (self.device.is_some()
                    && !names(&run_devices(root, r).map_err(at)?, &self.device))
            {
                continue;
            }
            picked += 1;
            if let Some(h) = self.heavy.filter(|&h| h != r.heavy) {
                return Err(at(format!("heavy = {}, the check states {h}", r.heavy)));
            }
            if let Some(s) = self.scalable.filter(|&s| s != r.scalable) {
                return Err(at(format!(
                    "scalable = {}, the check states {s}",
                    r.scalable
                )));
            }
            if self.key.is_some() {
                let v = run_value(root, r, self.key()).map_err(at)?;
                self.value_problem(v.as_ref()).map_err(at)?;
            }
        }
        if picked == 0 {
            return Err("no [[run]] of the paper's claims file matches".into());
        }
        Ok(())
    }
}

/// The devices a config run makes rows on: its `device`, else its config's `run.devices`,
/// else the CPU.
fn run_devices(root: &Path, run: &RunSpec) -> Result<Vec<String>, String> {
    if let Some(d) = &run.device {
        return Ok(d.clone());
    }
    let config = read_toml(root, run.config.as_deref().unwrap_or_default())?;
    Ok(match lookup(&config, "run.devices") {
        Some(toml::Value::String(d)) => vec![d.clone()],
        Some(toml::Value::Array(a)) => a
            .iter()
            .filter_map(|d| d.as_str().map(str::to_owned))
            .collect(),
        _ => vec!["cpu".to_owned()],
    })
}

/// A TOML file of the repository as a value.
fn read_toml(root: &Path, file: &str) -> Result<toml::Value, String> {
    let text =
        std::fs::read_to_string(root.join(file)).map_err(|e| format!("cannot read {file}: {e}"))?;
    text.parse::<toml::Table>()
        .map(toml::Value::Table)
        .map_err(|e| format!("{file}: {}", e.message()))
}

/// The value at dotted `key` in `v`: in an array, an index (`scene.0`) or the first element
/// that has the rest of the key.
fn lookup<'a>(v: &'a toml::Value, key: &str) -> Option<&'a toml::Value> {
    if key.is_empty() {
        return Some(v);
    }
    let (head, rest) = key.split_once('.').unwrap_or((key, ""));
    match v {
        toml::Value::Table(t) => lookup(t.get(head)?, rest),
        toml::Value::Array(a) => match head.parse::<usize>() {
            Ok(i) => lookup(a.get(i)?, rest),
            Err(_) => a.iter().find_map(|e| lookup(e, key)),
        },
        _ => None,
    }
}

/// The value a run gives `key`: its last `set` edit of the key or of a key above it, else its
/// config's value.
fn run_value(root: &Path, run: &RunSpec, key: &str) -> Result<Option<toml::Value>, String> {
    let mut edited = None;
    for e in &run.set {
        let Some((k, v)) = e.split_once('=') else {
            continue;
        };
        let k = k.trim();
        let rest = if k == key {
            Some("")
        } else {
            key.strip_prefix(k).and_then(|r| r.strip_prefix('.'))
        };
        if let Some(rest) = rest {
            let v = format!("v = {}", v.trim())
                .parse::<toml::Table>()
                .ok()
                .and_then(|mut t| t.remove("v"))
                .unwrap_or_else(|| toml::Value::String(v.trim().to_owned()));
            edited = Some(lookup(&v, rest).cloned());
        }
    }
    if let Some(v) = edited {
        return Ok(v);
    }
    let config = run.config.as_deref().unwrap_or_default();
    Ok(lookup(&read_toml(root, config)?, key).cloned())
}

/// Whether two TOML values are the same, numbers by value (`90` = `90.0`).
fn same(a: &toml::Value, b: &toml::Value) -> bool {
    use toml::Value as V;
    let num = |v: &V| match v {
        V::Integer(i) => Some(*i as f64),
        V::Float(f) => Some(*f),
        _ => None,
    };
    match (a, b) {
        (V::Array(x), V::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(p, q)| same(p, q))
        }
        (V::Table(x), V::Table(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same(v, w)))
        }
        _ => match (num(a), num(b)) {
            (Some(p), Some(q)) => p == q,
            _ => a == b,
        },
    }
}

/// Every deviation check of the repository at `root` against its configs, claims files and
/// code: one line per problem, naming the deviations file, the deviation and the check (and a
/// file that does not load). Reads `claims/deviations/*.toml`, each with `claims/STEM.toml`.
pub fn check(root: &Path) -> Vec<String> {
    let dir = root.join("claims").join("deviations");
    let mut files: Vec<PathBuf> = match std::fs::read_dir(&dir) {
        Ok(rd) => rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect(),
        Err(e) => return vec![format!("cannot read {}: {e}", dir.display())],
    };
    files.sort();
    let mut out = Vec::new();
    for path in files {
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        let shown = format!("claims/deviations/{name}");
        let claims_path = root.join("claims").join(&*name);
        let loaded = crate::load(&claims_path).and_then(|f| {
            let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
            Ok((parse(&path, &text, &f)?, f.runs))
        });
        let (ds, runs) = match loaded {
            Ok(x) => x,
            Err(e) => {
                out.push(format!("{shown}: {e}"));
                continue;
            }
        };
        for (i, d) in ds.iter().enumerate() {
            for (j, c) in d.deviation.checks.iter().enumerate() {
                for p in c.problems(&d.deviation.what, root, &runs) {
                    out.push(format!(
                        "{shown}: deviation[{i}].check[{j}] ({}): {p}",
                        c.target()
                    ));
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::check;
    use std::path::Path;

    const CLAIMS: &str = "paper = \"p\"\n\
        [[run]]\nconfig = \"configs/c.toml\"\nscene = [\"a\"]\nstructure = [\"kd\"]\nset = [\"scene.camera.width=256\", 'structure=[{name = \"kd\", params = {d = 3}}]']\ncost_s = 1\nscalable = true\n\
        [[run]]\nconfig = \"configs/c.toml\"\nscene = [\"crown\"]\nset = [\"scene.camera.width=64\"]\ncost_s = 1\nheavy = true\n\
        [[claim]]\nid = \"c\"\nwhere = \"T1\"\ntext = \"t\"\npaper = \"p\"\nmeasure = \"interior_per_ray\"\nrows.a = { traversal = \"a\" }\ntest = { kind = \"value\", of = \"a\", min = 0 }\n";

    const CONFIG: &str = "[run]\ndevices = [\"cpu\"]\n[[scene]]\nname = \"a\"\ncamera = { width = 1024, height = 768 }\n\
        views = [{ eye = [1, 2, 3] }, { eye = [4, 5.5, 6] }]\n\
        [[scene]]\nname = \"crown\"\ncamera = { width = 1024, height = 768 }\n";

    const CODE: &str = "const REG_SLOTS: u32 = 8u;\n";

    /// One deviation with a check of each kind, every one holding on CONFIG, CLAIMS and CODE.
    const DEVIATIONS: &str = "[[deviation]]\nkind = \"view\"\n\
        what = \"Images of 256 x 768 as declared (reproduce may shrink them), the crown at 64 x 768 only with --heavy; the eye at (4, 5.5, 6) of 2 views; 8 entries in registers\"\n\
        why = \"w\"\nclaims = [\"c\"]\n\
        [[deviation.check]]\nconfig = \"configs/c.toml\"\nkey = \"scene.views.1.eye\"\nvalue = [4, 5.5, 6.0]\nsays = \"(4, 5.5, 6)\"\n\
        [[deviation.check]]\nconfig = \"configs/c.toml\"\nkey = \"scene.0.views\"\nlen = 2\nsays = \"2 views\"\n\
        [[deviation.check]]\nrun = \"configs/*.toml\"\nkey = \"scene.camera.height\"\nvalue = 768\nsays = \"x 768\"\n\
        [[deviation.check]]\nrun = \"configs/c.toml\"\nscene = \"a\"\nkey = \"scene.camera.width\"\nvalue = 256\nscalable = true\nsays = \"256 x 768\"\n\
        [[deviation.check]]\nrun = \"configs/c.toml\"\ndevice = \"cpu\"\nstructure = \"kd\"\nkey = \"structure.0.params.d\"\nvalue = 3\nsays = \"reproduce may shrink\"\n\
        [[deviation.check]]\nrun = \"configs/c.toml\"\nscene = \"crown\"\nheavy = true\nkey = \"scene.camera.width\"\nvalue = 64\nsays = \"--heavy\"\n\
        [[deviation.check]]\nfile = \"src/k.wgsl\"\ncontains = \"const REG_SLOTS: u32 = 8u;\"\nsays = \"8 entries in registers\"\n";

    /// A repository of CLAIMS, CONFIG, CODE and DEVIATIONS, the text `from` replaced by `to` in
    /// the file `edit`, and its problems.
    fn problems(edit: &str, from: &str, to: &str) -> Vec<String> {
        let t = tempfile::tempdir().unwrap();
        let root = t.path();
        for (p, text) in [
            ("claims/p.toml", CLAIMS),
            ("claims/deviations/p.toml", DEVIATIONS),
            ("configs/c.toml", CONFIG),
            ("src/k.wgsl", CODE),
        ] {
            let text = if p == edit {
                assert!(text.contains(from), "{p} has no {from}");
                text.replacen(from, to, 1)
            } else {
                text.to_owned()
            };
            std::fs::create_dir_all(root.join(p).parent().unwrap()).unwrap();
            std::fs::write(root.join(p), text).unwrap();
        }
        check(Path::new(root))
    }

    #[test]
    fn checks_of_every_kind_hold_where_text_and_code_agree() {
        assert_eq!(problems("", "", ""), Vec::<String>::new());
    }

    /// Each kind of check fails when the text changes and when the code or config changes,
    /// with one line naming the file, the deviation, the check and the difference.
    #[test]
    fn each_check_fails_when_the_text_or_the_code_differs() {
        let dev = "claims/deviations/p.toml";
        let cases = [
            // The text.
            (dev, "(4, 5.5, 6)", "(4, 5, 6)", "check[0] (config configs/c.toml, key scene.views.1.eye): `what` does not say \"(4, 5.5, 6)\""),
            (dev, "2 views", "two views", "check[1] (config configs/c.toml, key scene.0.views): `what` does not say"),
            (dev, "256 x 768", "128 x 96", "check[3] (run configs/c.toml scene a, key scene.camera.width): `what` does not say \"256 x 768\""),
            (dev, "only with --heavy", "always", "check[5] (run configs/c.toml scene crown, key scene.camera.width): `what` does not say \"--heavy\""),
            (dev, "8 entries in registers", "16 entries in workgroup memory", "check[6] (file src/k.wgsl): `what` does not say"),
            // A config's key.
            ("configs/c.toml", "eye = [4, 5.5, 6]", "eye = [4, 5, 6]", "check[0] (config configs/c.toml, key scene.views.1.eye): scene.views.1.eye is [4, 5, 6], the check states [4, 5.5, 6.0]"),
            ("configs/c.toml", "{ eye = [4, 5.5, 6] }]", "{ eye = [4, 5.5, 6] }, { eye = [0, 0, 1] }]", "check[1] (config configs/c.toml, key scene.0.views): scene.0.views has 3 entries, the check states 2"),
            // A run: its config's value, its set edits (of the key, of a key above it), heavy, scalable.
            ("configs/c.toml", "height = 768 }\nviews", "height = 600 }\nviews", "check[2] (run configs/*.toml, key scene.camera.height): run[0] (configs/c.toml): scene.camera.height is 600, the check states 768"),
            ("claims/p.toml", "width=256", "width=128", "check[3] (run configs/c.toml scene a, key scene.camera.width): run[0] (configs/c.toml): scene.camera.width is 128, the check states 256"),
            ("claims/p.toml", "d = 3", "d = 5", "check[4] (run configs/c.toml structure kd device cpu, key structure.0.params.d): run[0] (configs/c.toml): structure.0.params.d is 5"),
            ("configs/c.toml", "devices = [\"cpu\"]", "devices = [\"gpu\"]", "check[4] (run configs/c.toml structure kd device cpu, key structure.0.params.d): no [[run]] of the paper's claims file matches"),
            ("claims/p.toml", "cost_s = 1\nscalable = true", "cost_s = 1", "check[3] (run configs/c.toml scene a, key scene.camera.width): run[0] (configs/c.toml): scalable = false, the check states true"),
            ("claims/p.toml", "heavy = true", "heavy = false", "check[5] (run configs/c.toml scene crown, key scene.camera.width): run[1] (configs/c.toml): heavy = false, the check states true"),
            ("claims/p.toml", "scene = [\"crown\"]", "scene = [\"hairball\"]", "check[5] (run configs/c.toml scene crown, key scene.camera.width): no [[run]] of the paper's claims file matches"),
            (dev, "run = \"configs/c.toml\"\nscene = \"crown\"", "run = \"configs/d.toml\"\nscene = \"crown\"", "check[5] (run configs/d.toml scene crown, key scene.camera.width): no [[run]] of the paper's claims file matches"),
            // A file's literal.
            ("src/k.wgsl", "8u", "16u", "check[6] (file src/k.wgsl): src/k.wgsl does not contain \"const REG_SLOTS: u32 = 8u;\""),
        ];
        for (file, from, to, want) in cases {
            let got = problems(file, from, to);
            assert_eq!(got.len(), 1, "{file}: {from} -> {to}: {got:?}");
            assert!(
                got[0].starts_with("claims/deviations/p.toml: deviation[0].")
                    && got[0].contains(want),
                "{file}: {from} -> {to}: {got:?}"
            );
        }
    }

    /// A check that is not one check (two targets, a key without a value, a run-only field on
    /// a config, no `says`) or has an unknown field is refused when the file loads.
    #[test]
    fn malformed_checks_are_refused_at_load() {
        let first = "[[deviation.check]]\nconfig = \"configs/c.toml\"\nkey = \"scene.views.1.eye\"\nvalue = [4, 5.5, 6.0]\nsays = \"(4, 5.5, 6)\"\n";
        for bad in [
            "[[deviation.check]]\nconfig = \"configs/c.toml\"\nfile = \"src/k.wgsl\"\nkey = \"scene.views.1.eye\"\nvalue = [4, 5.5, 6.0]\n",
            "[[deviation.check]]\nconfig = \"configs/c.toml\"\nkey = \"scene.views.1.eye\"\n",
            "[[deviation.check]]\nconfig = \"configs/c.toml\"\nheavy = true\nkey = \"scene.views.1.eye\"\nvalue = [4, 5.5, 6.0]\n",
            "[[deviation.check]]\nconfig = \"configs/c.toml\"\nkey = \"scene.views.1.eye\"\nvalue = [4, 5.5, 6.0]\nlen = 3\n",
            "[[deviation.check]]\nfile = \"src/k.wgsl\"\nkey = \"scene.views.1.eye\"\nvalue = 1\ncontains = \"x\"\n",
            "[[deviation.check]]\nrun = \"configs/c.toml\"\n",
            "[[deviation.check]]\nconfig = \"configs/c.toml\"\nkeys = \"scene\"\nvalue = 1\n",
        ] {
            let got = problems("claims/deviations/p.toml", first, &format!("{bad}says = \"2 views\"\n"));
            let want = if bad.contains("keys") { "unknown field" } else { "deviation[0].check[0]" };
            assert!(got.len() == 1 && got[0].contains(want), "{bad}: {got:?}");
        }
        let got = problems(
            "claims/deviations/p.toml",
            "says = \"(4, 5.5, 6)\"",
            "says = \" \"",
        );
        assert!(
            got.len() == 1 && got[0].contains("deviation[0].check[0]") && got[0].contains("`says`"),
            "{got:?}"
        );
    }
}
