//! Verdicts of several reproduce reports made alike (the same command run again, on the same
//! build), compared claim by claim: what the brief asks of the claims, that counter verdicts
//! are stable run after run, checked from the reports' `verdicts.json` rather than by hand.
//!
//! A counter claim (no timing in its measure: [`crate::ClaimResult::timed`]) must have the
//! same verdict in every report; a time claim may be decided in one report and inconclusive
//! or undecidable in another (its interval crossed a bound), but must not agree in one and
//! disagree in another. Claims are matched by paper, id and device; one missing from a
//! report is listed, not compared.

use crate::Error;
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The comparison of several reports.
#[derive(Debug, Default)]
pub struct Stability {
    /// Counter claims with one verdict in every report.
    pub counter_same: usize,
    /// Counter claims whose verdict moved: `paper id [device]: v1, v2, …`.
    pub counter_moved: Vec<String>,
    /// Time claims with one verdict in every report.
    pub time_same: usize,
    /// Time claims decided in some reports and inconclusive or undecidable in others.
    pub time_decided_once: Vec<String>,
    /// Time claims that agree in one report and disagree in another.
    pub time_flipped: Vec<String>,
    /// Claims missing from some report (`paper id [device]`).
    pub missing: Vec<String>,
}

impl Stability {
    /// Whether the reports agree as they must (no counter verdict moved, no time verdict
    /// went between agree and disagree).
    /// The claims every report has (what was compared).
    pub fn compared(&self) -> usize {
        self.counter_same
            + self.counter_moved.len()
            + self.time_same
            + self.time_flipped.len()
            + self.time_decided_once.len()
    }

    /// The reports agree as the command asks: some claim in common (two reports
    /// with nothing in common compare nothing), no counter claim moved, no time claim between
    /// agree and disagree.
    pub fn holds(&self) -> bool {
        self.compared() > 0 && self.counter_moved.is_empty() && self.time_flipped.is_empty()
    }
}

/// One report's claims: `(paper, id, device)` → (verdict, timed).
type Claims = BTreeMap<(String, String, String), (String, bool)>;

/// The claims of the report at `folder` (or of the `verdicts.json` named).
fn claims_of(folder: &Path) -> Result<Claims, Error> {
    let path = if folder.is_dir() {
        folder.join("verdicts.json")
    } else {
        folder.to_path_buf()
    };
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    let doc: Value = serde_json::from_str(&text).map_err(|e| Error::io(&path, e))?;
    let mut out = BTreeMap::new();
    let papers = doc["papers"].as_array().ok_or_else(|| {
        Error::io(
            &path,
            "no `papers` list: not a reproduce report's verdicts.json",
        )
    })?;
    for p in papers {
        let key = p["key"].as_str().unwrap_or_default().to_owned();
        for c in p["claims"].as_array().into_iter().flatten() {
            let timed = c["timed"].as_bool().ok_or_else(|| {
                Error::io(
                    &path,
                    "claims without `timed`: a report made before it was recorded (rerun \
                     reproduce with its --out to evaluate it again)",
                )
            })?;
            let id = c["id"].as_str().unwrap_or_default().to_owned();
            let device = c["device"].as_str().unwrap_or_default().to_owned();
            let verdict = c["verdict"].as_str().unwrap_or_default().to_owned();
            out.insert((key.clone(), id, device), (verdict, timed));
        }
    }
    Ok(out)
}

/// Compare the verdicts of `reports` (report folders or their `verdicts.json`), two or more.
pub fn compare(reports: &[PathBuf]) -> Result<Stability, Error> {
    if reports.len() < 2 {
        return Err(Error::Other(
            "compare: give two or more reports (folders or verdicts.json)".into(),
        ));
    }
    let all = reports
        .iter()
        .map(|r| claims_of(r))
        .collect::<Result<Vec<_>, _>>()?;
    let mut s = Stability::default();
    let keys: std::collections::BTreeSet<_> = all.iter().flat_map(|m| m.keys()).collect();
    for k in keys {
        let name = format!("{} {} [{}]", k.0, k.1, k.2);
        let vs: Option<Vec<&(String, bool)>> = all.iter().map(|m| m.get(k)).collect();
        let Some(vs) = vs else {
            s.missing.push(name);
            continue;
        };
        let verdicts: Vec<&str> = vs.iter().map(|v| v.0.as_str()).collect();
        let same = verdicts.iter().all(|v| *v == verdicts[0]);
        let line = format!("{name}: {}", verdicts.join(", "));
        match (vs.iter().any(|v| v.1), same) {
            (false, true) => s.counter_same += 1,
            (false, false) => s.counter_moved.push(line),
            (true, true) => s.time_same += 1,
            (true, false) if verdicts.contains(&"agree") && verdicts.contains(&"disagree") => {
                s.time_flipped.push(line)
            }
            (true, false) => s.time_decided_once.push(line),
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(dir: &Path, name: &str, claims: &[(&str, &str, bool)]) -> PathBuf {
        let claims: Vec<Value> = claims
            .iter()
            .map(|(id, v, t)| serde_json::json!({"id": id, "device": "cpu", "verdict": v, "timed": t}))
            .collect();
        let doc = serde_json::json!({"papers": [{"key": "p", "claims": claims}]});
        let f = dir.join(name);
        std::fs::create_dir_all(&f).unwrap();
        std::fs::write(f.join("verdicts.json"), doc.to_string()).unwrap();
        f
    }

    /// Reports with no claim in common compare nothing, and do not hold.
    #[test]
    fn reports_with_nothing_in_common_do_not_hold() {
        let dir = tempfile::tempdir().unwrap();
        let a = report(dir.path(), "a", &[("c1", "agree", false)]);
        let b = report(dir.path(), "b", &[("c2", "agree", false)]);
        let s = compare(&[a.clone(), b]).unwrap();
        assert_eq!((s.compared(), s.missing.len()), (0, 2));
        assert!(!s.holds());
        let s = compare(&[a.clone(), a]).unwrap();
        assert!(s.holds());
    }

    #[test]
    fn counter_moves_and_time_flips_fail_decided_once_passes() {
        let dir = tempfile::tempdir().unwrap();
        let a = report(
            dir.path(),
            "a",
            &[
                ("c1", "agree", false),
                ("t1", "agree", true),
                ("t2", "agree", true),
            ],
        );
        let b = report(
            dir.path(),
            "b",
            &[
                ("c1", "agree", false),
                ("t1", "inconclusive", true),
                ("t2", "agree", true),
            ],
        );
        let s = compare(&[a.clone(), b.clone()]).unwrap();
        assert!(s.holds(), "{s:?}");
        assert_eq!((s.counter_same, s.time_same), (1, 1));
        assert_eq!(s.time_decided_once, ["p t1 [cpu]: agree, inconclusive"]);
        let c = report(
            dir.path(),
            "c",
            &[("c1", "disagree", false), ("t1", "disagree", true)],
        );
        let s = compare(&[a, b, c]).unwrap();
        assert!(!s.holds());
        assert_eq!(s.counter_moved, ["p c1 [cpu]: agree, agree, disagree"]);
        assert_eq!(
            s.time_flipped,
            ["p t1 [cpu]: agree, inconclusive, disagree"]
        );
        assert_eq!(s.missing, ["p t2 [cpu]"]);
    }

    #[test]
    fn a_report_without_timed_is_refused_in_one_line() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("old");
        std::fs::create_dir_all(&f).unwrap();
        std::fs::write(
            f.join("verdicts.json"),
            r#"{"papers":[{"key":"p","claims":[{"id":"c","device":"cpu","verdict":"agree"}]}]}"#,
        )
        .unwrap();
        let e = compare(&[f.clone(), f]).unwrap_err().to_string();
        assert!(e.contains("without `timed`") && !e.contains('\n'), "{e}");
    }
}
