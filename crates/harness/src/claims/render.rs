//! Verdicts as a terminal table, Markdown or JSON.

use super::eval::{ClaimResult, Verdict};
use serde::Serialize;

/// Counts of each verdict.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct Tally {
    pub agree: usize,
    pub disagree: usize,
    pub inconclusive: usize,
}

impl Tally {
    pub fn of(rs: &[ClaimResult]) -> Tally {
        let mut t = Tally::default();
        for r in rs {
            match r.verdict {
                Verdict::Agree => t.agree += 1,
                Verdict::Disagree => t.disagree += 1,
                Verdict::Inconclusive => t.inconclusive += 1,
            }
        }
        t
    }
}

impl std::fmt::Display for Tally {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} agree, {} disagree, {} inconclusive",
            self.agree, self.disagree, self.inconclusive
        )
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

/// A terminal table: claim | paper | ours | verdict | why, cells wrapped to `width` columns.
pub fn text(rs: &[ClaimResult], width: u16) -> String {
    let mut t = comfy_table::Table::new();
    t.load_preset(comfy_table::presets::UTF8_HORIZONTAL_ONLY)
        .set_content_arrangement(comfy_table::ContentArrangement::Dynamic)
        .set_width(width.max(60))
        .set_header(["claim", "paper", "ours", "verdict", "why"]);
    for r in rs {
        t.add_row([
            label(r),
            r.paper.clone(),
            r.ours.clone(),
            r.verdict.as_str().to_owned(),
            r.why.clone(),
        ]);
    }
    format!("{t}\n{}\n", Tally::of(rs))
}

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// A Markdown table: claim (with where it stands) | paper | ours | verdict | why.
pub fn markdown(rs: &[ClaimResult]) -> String {
    let mut s = String::from(
        "| claim | where | paper | ours | verdict | why |\n|---|---|---|---|---|---|\n",
    );
    for r in rs {
        let v = match r.verdict {
            Verdict::Agree => "agree",
            Verdict::Disagree => "**disagree**",
            Verdict::Inconclusive => "*inconclusive*",
        };
        s.push_str(&format!(
            "| `{}` | {} | {} | {} | {} | {} |\n",
            md_cell(&label(r)),
            md_cell(&r.place),
            md_cell(&r.paper),
            md_cell(&r.ours),
            v,
            md_cell(&r.why)
        ));
    }
    s.push_str(&format!("\n{}\n", Tally::of(rs)));
    s
}

/// The verdicts as JSON: the paper, the tally and every claim with its groups' values.
pub fn json(paper: &str, sources: &[String], rs: &[ClaimResult]) -> serde_json::Value {
    serde_json::json!({
        "paper": paper,
        "results": sources,
        "tally": Tally::of(rs),
        "claims": rs,
    })
}
