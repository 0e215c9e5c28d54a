//! The claims file's schema (serde, unknown keys refused) and its checks.

use crate::Error;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use crate::selector::unknown_column;
pub use crate::selector::{Selector, MEASURE_KEY};

/// One paper's claims file.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ClaimsFile {
    /// The paper, as reports name it.
    pub paper: String,
    /// The paper's text (a path), for readers.
    #[serde(default)]
    pub text: Option<String>,
    /// What `trace-bench reproduce` runs for this paper, in order.
    #[serde(default, rename = "run")]
    pub runs: Vec<RunSpec>,
    /// Notes that several claims share, by name (`[notes]`, `name = "text"`): a claim names
    /// them in its `notes`, and its note reads them, in that order, after its own `note`.
    #[serde(default)]
    pub notes: BTreeMap<String, String>,
    /// The paper's claims, in file order.
    #[serde(default, rename = "claim")]
    pub claims: Vec<Claim>,
    /// The paper's figures drawn from the runs' folders by a plotting script (`reproduce`,
    /// with matplotlib).
    #[serde(default, rename = "figure")]
    pub figures: Vec<FigureSpec>,
}

/// One of the paper's figures, drawn from our runs by a script of `scripts/`.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FigureSpec {
    /// The PNG's name in the report's `figures/` (`PAPER-NAME.png`): lowercase letters,
    /// digits and '-'.
    pub name: String,
    /// What it shows, beside which of the paper's figures or tables.
    pub title: String,
    /// A script of `scripts/` (`plot.py`, `irregular-figure6.py`).
    pub script: String,
    /// Its arguments; `{run:LABEL}` stands for the folders of the runs with that label (the
    /// config's file stem), `--out` is added.
    pub args: Vec<String>,
}

/// One run of `reproduce`: a `trace-bench run` of a config, or another trace-bench command.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RunSpec {
    /// The experiment config (a `trace-bench run`).
    #[serde(default)]
    pub config: Option<String>,
    /// Instead of `config`: a trace-bench command line, `{out}` standing for the run's folder.
    #[serde(default)]
    pub exec: Option<Vec<String>>,
    /// `--set` edits.
    #[serde(default)]
    pub set: Vec<String>,
    /// `--structure` filter.
    #[serde(default)]
    pub structure: Vec<String>,
    /// `--scene` filter.
    #[serde(default)]
    pub scene: Vec<String>,
    /// `--threads`.
    #[serde(default)]
    pub threads: Option<Vec<usize>>,
    /// `--device` (a run naming `gpu` is left out unless reproduce is asked for the GPU).
    #[serde(default)]
    pub device: Option<Vec<String>>,
    /// Wall seconds of one process of the run as declared, measured on the 2-core reference
    /// machine (reproduce plans `processes` times it: [`RunSpec::total_s`]).
    #[serde(default)]
    pub cost_s: f64,
    /// The part of `cost_s` that does not shrink with the image (loading, builds).
    #[serde(default)]
    pub fixed_s: f64,
    /// The part of `cost_s` that is the CPU rows' timed tracing (`meta.phases`' `timed trace`
    /// of a run as declared): it shrinks with the image and with the share of each batch the
    /// rows are timed on (`run.timed_share`, which reproduce sets to fit its budget before it
    /// shrinks any image); 0 (the default): the run is never timed on a share.
    #[serde(default)]
    pub trace_s: f64,
    /// Processes the run is made in (`run --processes`; default 1), for runs whose rows time
    /// claims compare: with three or more their intervals are measured between processes
    /// (`claims::MIN_PROCESSES`) instead of the floor.
    #[serde(default = "one")]
    pub processes: usize,
    /// Whether reproduce may shrink the images (same aspect) to fit its budget.
    #[serde(default)]
    pub scalable: bool,
    /// Time the run's CPU rows interleaved (`run.interleave`; default true: the rows a time
    /// claim compares then pair round for round). `false` for runs whose builds of one scene
    /// would not fit in memory together.
    #[serde(default = "yes")]
    pub interleave: bool,
    /// A run whose builds take minutes (the stand-in scenes of millions of triangles): made
    /// only with `reproduce --heavy` or when the budget covers every run as declared, never
    /// shrunk to fit (`claims/README.md`).
    #[serde(default)]
    pub heavy: bool,
    /// A remark for readers of the claims file (e.g. how `cost_s` was estimated).
    #[serde(default)]
    pub note: Option<String>,
}

impl RunSpec {
    /// The run's label: the config's file stem, or the command's first word.
    pub fn label(&self) -> String {
        match (&self.config, &self.exec) {
            (Some(c), _) => Path::new(c)
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            (None, Some(e)) => e.first().cloned().unwrap_or_default(),
            _ => String::new(),
        }
    }
}

/// The run labels a figure argument names (`{run:LABEL}`).
pub(crate) fn run_refs(arg: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut rest = arg;
    while let Some(i) = rest.find("{run:") {
        let tail = &rest[i + 5..];
        let Some(j) = tail.find('}') else { break };
        out.push(&tail[..j]);
        rest = &tail[j + 1..];
    }
    out
}

/// One claim of a paper.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Claim {
    /// Unique in the file; `[a-z0-9-]`.
    pub id: String,
    /// Where it stands in the paper (table, row, column or section).
    #[serde(rename = "where")]
    pub place: String,
    /// The claim in words.
    pub text: String,
    /// The paper's figure(s), as printed.
    pub paper: String,
    /// The paper's figure in a few words (`1.57 vs 1.59 s`) for the report's short tables,
    /// where `paper` is longer; the full `paper` stays in the reasons.
    #[serde(default)]
    pub paper_figure: Option<String>,
    /// Why this test and this tolerance: once the file is loaded, its own note, then
    /// the texts of the shared `notes` it names.
    #[serde(default)]
    pub note: Option<String>,
    /// Names of the file's shared notes (`[notes]`) that this claim's note ends with.
    #[serde(default)]
    pub notes: Vec<String>,
    /// What the claim is: a statement of the paper (tallied), an observation or an invariant
    /// (shown apart, not tallied); claims/README.md, "Kinds".
    #[serde(default)]
    pub kind: ClaimKind,
    /// Why the claim cannot be decided, stated before measuring (e.g. a GPU-only figure that no
    /// GPU row can give): its `inconclusive` reads `undecidable`. A band narrower than the
    /// timing floor is found without it (`kinds::undecidable`).
    #[serde(default)]
    pub undecidable: Option<String>,
    /// A column, a sum of columns (`a + b`), `time`, `mrays_per_s`, `build:KEY`, `heap_ratio`.
    pub measure: String,
    /// How the rows of a selector pool in a group (default: by the measure).
    #[serde(default)]
    pub pool: Option<Pool>,
    /// A selector every row of the claim matches.
    #[serde(default)]
    pub filter: Selector,
    /// Group keys; the test runs per group.
    #[serde(default)]
    pub per: Vec<String>,
    /// How the groups' verdicts combine into the claim's (default `all`).
    #[serde(default)]
    pub need: Need,
    /// Devices the claim is evaluated on, once each (default `cpu`).
    #[serde(default = "default_devices")]
    pub devices: Vec<String>,
    /// Named selectors the test compares.
    pub rows: BTreeMap<String, Selector>,
    /// The test over the named selectors, with its band.
    pub test: Test,
}

impl Claim {
    /// Every measure the claim reads: its own, then its named selectors' own (`MEASURE_KEY`).
    pub fn measures(&self) -> impl Iterator<Item = &str> {
        std::iter::once(self.measure.as_str())
            .chain(self.rows.values().filter_map(Selector::measure))
    }
}

/// What a claim is (claims/README.md, "Kinds").
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq, PartialOrd, Ord)]
#[serde(rename_all = "lowercase")]
pub enum ClaimKind {
    /// A statement of the paper, on the measure and device it speaks of: tallied.
    #[default]
    Claim,
    /// A GPU statement tried on the CPU, a question the paper leaves open, or our own figure
    /// for the record: evaluated and shown, not tallied.
    Observation,
    /// A property of our code true by construction (two kernels visiting the same nodes, one
    /// build's memory in two rows): evaluated and shown, not tallied; where cheap, a test.
    Invariant,
}

impl ClaimKind {
    /// Every kind, in report order.
    pub const ALL: [ClaimKind; 3] = [
        ClaimKind::Claim,
        ClaimKind::Observation,
        ClaimKind::Invariant,
    ];

    /// The kind as a claims file writes it.
    pub fn as_str(self) -> &'static str {
        match self {
            ClaimKind::Claim => "claim",
            ClaimKind::Observation => "observation",
            ClaimKind::Invariant => "invariant",
        }
    }
}

fn yes() -> bool {
    true
}

fn one() -> usize {
    1
}

impl RunSpec {
    /// Wall seconds of the whole run: `processes` times `cost_s`.
    pub fn total_s(&self) -> f64 {
        self.cost_s * self.processes as f64
    }

    /// The part of [`RunSpec::total_s`] that does not shrink with the image.
    pub fn total_fixed_s(&self) -> f64 {
        self.fixed_s * self.processes as f64
    }

    /// Wall seconds of the whole run with its CPU rows timed on `share` of each batch and
    /// its images at `scale` of their pixels (a run that is not `scalable` keeps them):
    /// `fixed_s + scale * (share * trace_s + rest)` per process, where the rest (counting,
    /// validation, the oracle) is `cost_s - fixed_s - trace_s`.
    pub fn planned_s(&self, share: f64, scale: f64) -> f64 {
        let scale = if self.scalable { scale } else { 1.0 };
        let var = (self.cost_s - self.fixed_s).max(0.0);
        let trace = self.trace_s.clamp(0.0, var);
        (self.fixed_s + scale * (share * trace + var - trace)) * self.processes as f64
    }
}

fn default_devices() -> Vec<String> {
    vec!["cpu".into()]
}

/// How the rows a selector matches in a group pool into one value.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Pool {
    /// `Σ v·rays / Σ rays`: the per-ray mean over all the rows' rays.
    Rays,
    /// The sum of the rows' values.
    Sum,
    /// The mean of the rows' values.
    Mean,
    /// The largest of the rows' values.
    Max,
    /// The smallest of the rows' values.
    Min,
}

/// How the groups' verdicts combine.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Need {
    /// `agree` if every group agrees, `disagree` if any disagrees.
    #[default]
    All,
    /// `agree` if one group agrees, `disagree` if every group disagrees.
    Any,
    /// `agree` if more than half agree, `disagree` if half or more disagree.
    Most,
}

/// Which way a `least` test's best row must stand from the others.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// `best` is below every other by the margin.
    #[default]
    Lowest,
    /// `best` is above every other by the margin.
    Highest,
}

/// The share of the paper's printed gap an ordering must hold by: an `order` or `least` test
/// whose paper prints the figures it orders gives their smallest relative gap (`gap`), and
/// our values must differ by at least `GAP_SHARE · gap` (half of it). One rule for every such
/// claim, fixed before measuring: a gap of 0.1 % no longer passes where the paper prints 3 %,
/// and a real effect half the paper's size still does (claims/README.md, "Margins from the
/// paper's gap").
pub const GAP_SHARE: f64 = 0.5;

/// The margin of an ordering: [`GAP_SHARE`]` · gap` where the paper prints a gap, else the
/// explicit `margin` (default 0).
fn margin_of(margin: Option<f64>, gap: Option<f64>) -> f64 {
    gap.map_or(margin.unwrap_or(0.0), |g| GAP_SHARE * g)
}

/// A claim's test; bands are inclusive, either bound optional.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Test {
    /// `min <= v(of) <= max`.
    Value {
        /// The selector whose value is tested.
        of: String,
        /// Lower bound (inclusive), if any.
        min: Option<f64>,
        /// Upper bound (inclusive), if any.
        max: Option<f64>,
    },
    /// `min <= v(num) / v(den) <= max`.
    Ratio {
        /// The numerator's selector.
        num: String,
        /// The denominator's selector.
        den: String,
        /// Lower bound of the ratio (inclusive), if any.
        min: Option<f64>,
        /// Upper bound of the ratio (inclusive), if any.
        max: Option<f64>,
    },
    /// `min <= 100 (1 − v(of) / v(base)) <= max` (percent; less is better).
    Gain {
        /// The selector measured.
        of: String,
        /// The selector it is compared against.
        base: String,
        /// Lower bound of the gain, percent (inclusive), if any.
        min: Option<f64>,
        /// Upper bound of the gain, percent (inclusive), if any.
        max: Option<f64>,
    },
    /// `min <= v(base) / v(of) <= max`.
    Speedup {
        /// The selector measured.
        of: String,
        /// The selector it is compared against.
        base: String,
        /// Lower bound of the speedup (inclusive), if any.
        min: Option<f64>,
        /// Upper bound of the speedup (inclusive), if any.
        max: Option<f64>,
    },
    /// `v(a) <= v(b) <= …` (strict: `v(a) < v(b)·(1 − margin)`; with a `gap`, strict with
    /// the margin [`GAP_SHARE`]` · gap`: [`Test::margin`]).
    Order {
        /// The selectors, in ascending order of value.
        rows: Vec<String>,
        /// `v(a) < v(b)·(1 − margin)` for each neighbour pair instead of `v(a) <= v(b)`
        /// (implied by `gap`).
        #[serde(default)]
        strict: bool,
        /// Relative margin of a strict order where the paper states a threshold but prints
        /// no figures (unused unless `strict`; default 0; not with `gap`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        margin: Option<f64>,
        /// The smallest relative gap the paper prints between neighbours, `(pb − pa) / pb`
        /// (`0 < gap < 1`): the order is then strict with the margin `GAP_SHARE · gap`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gap: Option<f64>,
    },
    /// `v(best)` below (above) every `v(o)` by the margin.
    Least {
        /// The selector that must be the extreme.
        best: String,
        /// The selectors it is compared against.
        of: Vec<String>,
        /// Relative margin by which `best` must beat each where the paper states a threshold
        /// but prints no figures (default 0; not with `gap`).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        margin: Option<f64>,
        /// The relative gap the paper prints between `best` and its nearest rival (`(pb − pa)
        /// / pb`, `(pa − pb) / pa` for `highest`; `0 < gap < 1`): the margin is then
        /// `GAP_SHARE · gap`.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gap: Option<f64>,
        /// Whether `best` must be the lowest (default) or the highest.
        #[serde(default)]
        direction: Direction,
    },
    /// `|v(a) − v(b)| <= tolerance · max(|v(a)|, |v(b)|)`.
    Equal {
        /// One of the two selectors compared.
        a: String,
        /// The other selector compared.
        b: String,
        /// Allowed difference relative to the larger magnitude (default 0).
        #[serde(default)]
        tolerance: f64,
    },
}

impl Test {
    /// The selectors the test names, in order.
    pub fn names(&self) -> Vec<&str> {
        match self {
            Test::Value { of, .. } => vec![of],
            Test::Ratio { num, den, .. } => vec![num, den],
            Test::Gain { of, base, .. } | Test::Speedup { of, base, .. } => vec![of, base],
            Test::Order { rows, .. } => rows.iter().map(String::as_str).collect(),
            Test::Least { best, of, .. } => std::iter::once(best.as_str())
                .chain(of.iter().map(String::as_str))
                .collect(),
            Test::Equal { a, b, .. } => vec![a, b],
        }
    }

    /// The relative margin an ordering (`order`, `least`) must hold by: [`GAP_SHARE`]` · gap`
    /// where the paper prints a gap, else `margin` (default 0); 0 for other tests.
    pub fn margin(&self) -> f64 {
        match self {
            Test::Order { margin, gap, .. } | Test::Least { margin, gap, .. } => {
                margin_of(*margin, *gap)
            }
            _ => 0.0,
        }
    }

    /// Whether an `order` is strict (`strict = true`, or a `gap`); a `least` always is.
    pub fn is_strict(&self) -> bool {
        match self {
            Test::Order { strict, gap, .. } => *strict || gap.is_some(),
            Test::Least { .. } => true,
            _ => false,
        }
    }

    /// The band of a band test.
    pub fn band(&self) -> Option<(Option<f64>, Option<f64>)> {
        match self {
            Test::Value { min, max, .. }
            | Test::Ratio { min, max, .. }
            | Test::Gain { min, max, .. }
            | Test::Speedup { min, max, .. } => Some((*min, *max)),
            _ => None,
        }
    }
}

/// A claim's test: the rows it names are defined, its band and margins are sound.
fn check_test(c: &Claim) -> Result<(), String> {
    for n in c.test.names() {
        if !c.rows.contains_key(n) {
            return Err(format!(
                "names rows `{n}`, which claim.rows does not define (it has: {})",
                c.rows.keys().cloned().collect::<Vec<_>>().join(", ")
            ));
        }
    }
    if let Some((min, max)) = c.test.band() {
        match (min, max) {
            (None, None) => return Err("give min, max or both".into()),
            (Some(a), Some(b)) if a > b => return Err(format!("min {a} is above max {b}")),
            _ => {}
        }
    }
    let negative = |m: &Option<f64>| m.is_some_and(|m| m < 0.0);
    match &c.test {
        Test::Order { rows, margin, .. } if rows.len() < 2 || negative(margin) => {
            return Err("order needs two rows or more, margin >= 0".into())
        }
        Test::Least { of, margin, .. } if of.is_empty() || negative(margin) => {
            return Err("least needs `of` rows, margin >= 0".into())
        }
        Test::Equal { tolerance, .. } if *tolerance < 0.0 => {
            return Err("tolerance must be >= 0".into())
        }
        _ => {}
    }
    Ok(())
}

/// An ordering's `gap`: a relative gap `0 < gap < 1`, and not beside a `margin` (the margin
/// then comes from the one rule, [`GAP_SHARE`]` · gap`).
fn check_gap(margin: Option<f64>, gap: Option<f64>) -> Result<(), String> {
    let Some(g) = gap else { return Ok(()) };
    if margin.is_some() {
        return Err(format!(
            "give gap or margin, not both (with the paper's gap the margin is \
             GAP_SHARE · gap = {GAP_SHARE} · {g})"
        ));
    }
    if !(g > 0.0 && g < 1.0) {
        return Err(format!(
            "{g} is not a relative gap (0 < gap < 1: (pb − pa) / pb of the paper's figures)"
        ));
    }
    Ok(())
}

impl ClaimsFile {
    /// Add the shared notes each claim names after its own note (joined by `; `); an unknown
    /// name is an error naming the claim's line.
    pub(crate) fn share_notes(&mut self, path: &Path, text: &str) -> Result<(), Error> {
        for c in &mut self.claims {
            if c.notes.is_empty() {
                continue;
            }
            let mut parts = Vec::with_capacity(c.notes.len() + 1);
            for name in &c.notes {
                let Some(shared) = self.notes.get(name) else {
                    let known: Vec<&str> = self.notes.keys().map(String::as_str).collect();
                    return Err(Error::Config {
                        file: path.into(),
                        line: find_line(text, &format!("id = \"{}\"", c.id), 0),
                        key: format!("claim {}: notes", c.id),
                        message: format!(
                            "no shared note `{name}` in [notes] (it has: {})",
                            if known.is_empty() {
                                "none".to_string()
                            } else {
                                known.join(", ")
                            }
                        ),
                    });
                };
                parts.push(shared.clone());
            }
            c.note = Some(
                c.note
                    .take()
                    .into_iter()
                    .chain(parts)
                    .collect::<Vec<_>>()
                    .join("; "),
            );
        }
        Ok(())
    }

    /// Every claim's ids, selectors, measure, test and groups, before any row is read.
    pub(crate) fn check(&self, path: &Path, text: &str) -> Result<(), Error> {
        self.check_runs(path, text)?;
        self.check_figures(path, text)?;
        let mut ids = BTreeSet::new();
        for c in &self.claims {
            let line = find_line(text, &format!("id = \"{}\"", c.id), 0);
            let err = |key: &str, m: String| Error::Config {
                file: path.into(),
                line,
                key: format!("claim {}: {key}", c.id),
                message: m,
            };
            if c.id.is_empty()
                || !c
                    .id
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-')
            {
                return Err(err("id", "use lowercase letters, digits and '-'".into()));
            }
            if !ids.insert(c.id.as_str()) {
                return Err(err("id", "appears twice in the file".into()));
            }
            c.filter.check().map_err(|m| err("filter", m))?;
            super::pick::check_filter(&c.filter.0).map_err(|m| err("filter", m))?;
            if c.filter.0.contains_key(MEASURE_KEY) {
                return Err(err(
                    "filter",
                    format!(
                        "{MEASURE_KEY} belongs in the claim or in a named selector of claim.rows"
                    ),
                ));
            }
            for (name, s) in &c.rows {
                s.check().map_err(|m| err(&format!("rows.{name}"), m))?;
            }
            check_test(c).map_err(|m| err("test", m))?;
            if let Test::Order { margin, gap, .. } | Test::Least { margin, gap, .. } = &c.test {
                check_gap(*margin, *gap).map_err(|m| err("test.gap", m))?;
            }
            let m = super::measure::Measure::parse(&c.measure).map_err(|m| err("measure", m))?;
            m.check_columns().map_err(|m| err("measure", m))?;
            for p in &c.per {
                let col = p.strip_prefix("param:").map_or(Some(p.as_str()), |_| None);
                if p.is_empty() || p.contains(char::is_whitespace) || p == "param:" {
                    return Err(err("per", format!("`{p}` is not a column or group key")));
                }
                if let Some(col) = col.filter(|c| !super::columns::is_known(c)) {
                    return Err(err("per", unknown_column(col, "group key")));
                }
            }
            if c.undecidable
                .as_deref()
                .is_some_and(|r| r.trim().is_empty())
            {
                return Err(err("undecidable", "give the reason in words".into()));
            }
            if c.devices.is_empty() {
                return Err(err("devices", "name at least one device".into()));
            }
            if let Some(d) = c
                .devices
                .iter()
                .find(|d| !["cpu", "gpu"].contains(&d.as_str()))
            {
                return Err(err(
                    "devices",
                    format!("unknown device `{d}` (known: cpu, gpu)"),
                ));
            }
        }
        Ok(())
    }

    /// Every figure has a name, a script of `scripts/` and runs that the file makes.
    fn check_figures(&self, path: &Path, text: &str) -> Result<(), Error> {
        let labels: Vec<String> = self.runs.iter().map(RunSpec::label).collect();
        let mut names = BTreeSet::new();
        for (i, f) in self.figures.iter().enumerate() {
            let err = |m: String| Error::Config {
                file: path.into(),
                line: find_line(text, "[[figure]]", i),
                key: format!("figure[{i}]"),
                message: m,
            };
            if f.name.is_empty()
                || !f
                    .name
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-')
            {
                return Err(err("name: use lowercase letters, digits and '-'".into()));
            }
            if !names.insert(f.name.as_str()) {
                return Err(err(format!("name `{}` appears twice", f.name)));
            }
            if f.script.is_empty() || f.script.contains(['/', '\\']) {
                return Err(err("script: a file name of scripts/".into()));
            }
            for a in &f.args {
                for label in run_refs(a) {
                    if !labels.iter().any(|l| l == label) {
                        return Err(err(format!(
                            "`{{run:{label}}}` names no run of the file (its runs: {})",
                            labels.join(", ")
                        )));
                    }
                }
            }
        }
        Ok(())
    }

    /// Every run names a config or a command, and costs seconds.
    fn check_runs(&self, path: &Path, text: &str) -> Result<(), Error> {
        for (i, r) in self.runs.iter().enumerate() {
            let line = find_line(text, "[[run]]", i);
            let err = |m: String| Error::Config {
                file: path.into(),
                line,
                key: format!("run[{i}]"),
                message: m,
            };
            match (&r.config, &r.exec) {
                (Some(_), Some(_)) => return Err(err("give config or exec, not both".into())),
                (None, None) => return Err(err("needs config or exec".into())),
                (None, Some(e)) if e.is_empty() => return Err(err("exec is empty".into())),
                _ => {}
            }
            if !(r.cost_s >= 0.0 && r.fixed_s >= 0.0 && r.fixed_s <= r.cost_s.max(r.fixed_s)) {
                return Err(err("cost_s and fixed_s must be seconds >= 0".into()));
            }
            if !(r.trace_s >= 0.0 && r.fixed_s + r.trace_s <= r.cost_s.max(r.fixed_s)) {
                return Err(err(
                    "trace_s must be seconds >= 0 and fixed_s + trace_s at most cost_s".into(),
                ));
            }
            if r.trace_s > 0.0 && r.exec.is_some() {
                return Err(err(
                    "trace_s: only a `config` run is timed on a share of its rays".into(),
                ));
            }
            let max = tb_results::output::MAX_PROCESSES;
            if !(1..=max).contains(&r.processes) {
                return Err(err(format!("processes must be 1 to {max}")));
            }
            if r.processes > 1 && r.exec.is_some() {
                return Err(err(
                    "processes: only a `config` run is made in several processes".into(),
                ));
            }
        }
        Ok(())
    }

    /// Claims by id.
    pub fn claim(&self, id: &str) -> Option<&Claim> {
        self.claims.iter().find(|c| c.id == id)
    }
}

/// 1-based line of the `nth` occurrence of `needle` in `text` (1 when absent).
pub(crate) fn find_line(text: &str, needle: &str, nth: usize) -> usize {
    text.match_indices(needle)
        .nth(nth)
        .map(|(p, _)| tb_results::error::line_of(text, p))
        .unwrap_or(1)
}
