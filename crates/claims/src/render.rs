//! Verdicts as a terminal table, Markdown or JSON: the paper's claims first (the tally), then
//! observations and invariants, each in its own section with its own counts.

use super::eval::{ClaimResult, GroupResult, Verdict};
use super::measure::fmt;
use super::schema::{ClaimKind, Direction, Test};
use serde::Serialize;

/// Counts of each verdict among the results of one kind.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Tally {
    /// Results whose verdict is `agree`.
    pub agree: usize,
    /// Results whose verdict is `disagree`.
    pub disagree: usize,
    /// Results whose verdict is `inconclusive`.
    pub inconclusive: usize,
    /// Results whose verdict is `undecidable`.
    pub undecidable: usize,
    /// Results whose verdict is `stale` (rows of an older method only): counted apart.
    #[serde(default)]
    pub stale: usize,
}

impl Tally {
    /// The tally of the paper's claims (kind `claim`); observations and invariants are not
    /// tallied ([`Tally::of_kind`] counts them apart).
    pub fn of(rs: &[ClaimResult]) -> Tally {
        Tally::of_kind(rs, ClaimKind::Claim)
    }

    /// Counts of the results of one kind.
    pub fn of_kind(rs: &[ClaimResult], kind: ClaimKind) -> Tally {
        let mut t = Tally::default();
        for r in rs.iter().filter(|r| r.kind == kind) {
            match r.verdict {
                Verdict::Agree => t.agree += 1,
                Verdict::Disagree => t.disagree += 1,
                Verdict::Inconclusive => t.inconclusive += 1,
                Verdict::Undecidable => t.undecidable += 1,
                Verdict::Stale => t.stale += 1,
            }
        }
        t
    }

    /// Results counted.
    pub fn total(&self) -> usize {
        self.agree + self.disagree + self.inconclusive + self.undecidable + self.stale
    }
}

impl std::fmt::Display for Tally {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} agree, {} disagree, {} inconclusive",
            self.agree, self.disagree, self.inconclusive
        )?;
        if self.undecidable > 0 {
            write!(f, ", {} undecidable", self.undecidable)?;
        }
        if self.stale > 0 {
            write!(f, " ({} stale apart, not tallied)", self.stale)?;
        }
        Ok(())
    }
}

/// The counts of every kind: the claims' tally, and the observations' and invariants' apart.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Kinds {
    /// The paper's claims (kind `claim`): the tally.
    pub claims: Tally,
    /// The observations, counted apart.
    pub observations: Tally,
    /// The invariants, counted apart.
    pub invariants: Tally,
}

impl Kinds {
    /// The counts of every kind among `rs`.
    pub fn of(rs: &[ClaimResult]) -> Kinds {
        Kinds {
            claims: Tally::of_kind(rs, ClaimKind::Claim),
            observations: Tally::of_kind(rs, ClaimKind::Observation),
            invariants: Tally::of_kind(rs, ClaimKind::Invariant),
        }
    }
}

/// The section title of a kind, and what it holds.
pub fn section(kind: ClaimKind) -> (&'static str, &'static str) {
    match kind {
        ClaimKind::Claim => ("Claims", "the paper's statements, tallied"),
        ClaimKind::Observation => (
            "Observations",
            "not tallied: a GPU statement tried on the CPU, a question the paper leaves \
             open, or our own figure for the record",
        ),
        ClaimKind::Invariant => (
            "Invariants",
            "not tallied: properties of our code true by construction, such as two kernels \
             visiting the same nodes or one build's memory in two rows; shown as a check of \
             the runs",
        ),
    }
}

/// The stale results' section title and what it holds.
pub const STALE_SECTION: (&str, &str) = (
    "Stale",
    "not tallied: every row that would decide them was made by an older method than this \
     binary's (the rows' `method`); the reason names the commit that made them and the command \
     that renews them",
);

/// A section of the verdicts: one kind's results that are not stale, or the stale ones.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Section {
    Kind(ClaimKind),
    Stale,
}

/// The results of each kind present, in the order claims, observations, invariants, then the
/// stale results of every kind apart.
fn by_kind(rs: &[ClaimResult]) -> Vec<(Section, Vec<&ClaimResult>)> {
    let fresh = |r: &&ClaimResult| r.verdict != Verdict::Stale;
    let mut v: Vec<(Section, Vec<&ClaimResult>)> = ClaimKind::ALL
        .iter()
        .map(|k| {
            let of: Vec<&ClaimResult> = rs.iter().filter(|r| r.kind == *k).filter(fresh).collect();
            (Section::Kind(*k), of)
        })
        .filter(|(k, v)| *k == Section::Kind(ClaimKind::Claim) || !v.is_empty())
        .collect();
    let stale: Vec<&ClaimResult> = rs.iter().filter(|r| !fresh(r)).collect();
    if !stale.is_empty() {
        v.push((Section::Stale, stale));
    }
    v
}

/// A section's title and what it holds.
fn section_of(s: Section) -> (&'static str, &'static str) {
    match s {
        Section::Kind(k) => section(k),
        Section::Stale => STALE_SECTION,
    }
}

/// The count line of one section (`tally` for claims).
fn count_line(s: Section, rs: &[ClaimResult]) -> String {
    match s {
        Section::Kind(ClaimKind::Claim) => Tally::of_kind(rs, ClaimKind::Claim).to_string(),
        Section::Kind(k) => {
            let t = Tally::of_kind(rs, k);
            format!("{} (not tallied, {}): {t}", section(k).0, t.total())
        }
        Section::Stale => {
            let n = rs.iter().filter(|r| r.verdict == Verdict::Stale).count();
            format!("Stale (not tallied): {n}")
        }
    }
}

/// The claim's label: its id, and the device when it is not the CPU.
fn label(r: &ClaimResult) -> String {
    if r.device == "cpu" {
        r.id.clone()
    } else {
        format!("{} [{}]", r.id, r.device)
    }
}

/// A terminal table per kind: claim | paper | ours | verdict | why, cells wrapped to `width`
/// columns, each kind's counts below its table.
pub fn text(rs: &[ClaimResult], width: u16) -> String {
    let kinds = by_kind(rs);
    let mut out = String::new();
    for (kind, v) in &kinds {
        if kinds.len() > 1 {
            let (title, what) = section_of(*kind);
            out.push_str(&format!("{title} ({what})\n"));
        }
        let mut t = comfy_table::Table::new();
        t.load_preset(comfy_table::presets::UTF8_HORIZONTAL_ONLY)
            .set_content_arrangement(comfy_table::ContentArrangement::Dynamic)
            .set_width(width.max(60))
            .set_header(["claim", "paper", "ours", "verdict", "why"]);
        for r in v {
            t.add_row([
                label(r),
                r.paper.clone(),
                r.ours.clone(),
                r.verdict.as_str().to_owned(),
                r.why.clone(),
            ]);
        }
        out.push_str(&format!("{t}\n{}\n", count_line(*kind, rs)));
    }
    out
}

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// A verdict as Markdown shows it (`**disagree**`, `*inconclusive*`, …).
pub fn md_verdict(v: Verdict) -> &'static str {
    match v {
        Verdict::Agree => "agree",
        Verdict::Disagree => "**disagree**",
        Verdict::Inconclusive => "*inconclusive*",
        Verdict::Undecidable => "*undecidable*",
        Verdict::Stale => "*stale*",
    }
}

/// A Markdown table per kind: claim (with where it stands) | paper | ours | verdict | why,
/// each kind's counts below its table.
pub fn markdown(rs: &[ClaimResult]) -> String {
    let kinds = by_kind(rs);
    let mut s = String::new();
    for (kind, v) in &kinds {
        if kinds.len() > 1 {
            let (title, what) = section_of(*kind);
            s.push_str(&format!("**{title}** ({what}):\n\n"));
        }
        s.push_str("| claim | where | paper | ours | verdict | why |\n|---|---|---|---|---|---|\n");
        for r in v {
            s.push_str(&format!(
                "| `{}` | {} | {} | {} | {} | {} |\n",
                md_cell(&label(r)),
                md_cell(&r.place),
                md_cell(&r.paper),
                md_cell(&r.ours),
                md_verdict(r.verdict),
                md_cell(&r.why)
            ));
        }
        s.push_str(&format!("\n{}\n", count_line(*kind, rs)));
        if kinds.len() > 1 {
            s.push('\n');
        }
    }
    s
}

/// The verdicts as JSON: the paper, the tally (claims only), every kind's counts and every
/// result with its kind and its groups' values.
pub fn json(paper: &str, sources: &[String], rs: &[ClaimResult]) -> serde_json::Value {
    serde_json::json!({
        "paper": paper,
        "results": sources,
        "tally": Tally::of(rs),
        "kinds": Kinds::of(rs),
        "claims": rs,
    })
}

/// The longest cell of the report's short tables before it is shortened.
pub const SHORT: usize = 48;

/// `s` in at most about [`SHORT`] characters: whole when short, else its first clause (before
/// `; ` or ` (`), cut at a word, marked `…`.
pub fn shorten(s: &str) -> String {
    if s.chars().count() <= SHORT {
        return s.to_owned();
    }
    let mut t = s;
    for sep in ["; ", " ("] {
        if let Some(i) = t.find(sep).filter(|i| *i > 0) {
            t = &t[..i];
        }
    }
    if t.chars().count() <= SHORT {
        return format!("{t} …");
    }
    let cut: String = t.chars().take(SHORT).collect();
    let cut = cut.rsplit_once(' ').map_or(cut.as_str(), |(a, _)| a);
    format!("{cut} …")
}

/// The paper's figure for a short table: the claim's `paper_figure`, else its `paper`
/// shortened.
pub fn short_paper(r: &ClaimResult) -> String {
    r.paper_figure.clone().unwrap_or_else(|| shorten(&r.paper))
}

/// Our figure for a short table: `ours` when short; one group's ordering as the relations
/// measured (`a < b < c`), a `least` test's best against its nearest rival, an equality's
/// difference; else `ours` shortened. The intervals stay in the reasons.
pub fn short_ours(r: &ClaimResult) -> String {
    if r.ours.chars().count() <= SHORT {
        return r.ours.clone();
    }
    match &r.groups[..] {
        [g] => relation(&r.test, g).unwrap_or_else(|| shorten(&r.ours)),
        _ => shorten(&r.ours),
    }
}

fn relation(t: &Test, g: &GroupResult) -> Option<String> {
    let v = |n: &str| g.values.get(n).map(|x| x.v);
    let rel = |a: f64, b: f64| {
        if a < b {
            " < "
        } else if a == b {
            " = "
        } else {
            " > "
        }
    };
    match t {
        Test::Order { rows, .. } => {
            let mut s = rows[0].clone();
            for w in rows.windows(2) {
                s.push_str(rel(v(&w[0])?, v(&w[1])?));
                s.push_str(&w[1]);
            }
            Some(s)
        }
        Test::Least {
            best,
            of,
            direction,
            ..
        } => {
            let key = |n: &String| {
                v(n).map(|x| match direction {
                    Direction::Lowest => x,
                    Direction::Highest => -x,
                })
            };
            let rival = of
                .iter()
                .filter_map(|n| key(n).map(|k| (k, n)))
                .min_by(|a, b| a.0.total_cmp(&b.0))?
                .1;
            Some(format!(
                "{best}{}{rival} (nearest of {})",
                rel(v(best)?, v(rival)?),
                of.len()
            ))
        }
        Test::Equal { .. } => g
            .derived
            .map(|d| format!("Δ {} %", fmt(100.0 * (d[1] - 1.0)))),
        _ => None,
    }
}
