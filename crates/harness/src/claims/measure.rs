//! A claim's `measure`: one timed term, or a sum of deterministic ones (`claims/README.md`).

/// One term of a measure.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Term {
    /// `build_ms`: a timing, with the spread of its builds (`build_ms_runs`).
    BuildTime,
    Col(String),
    Build(String),
    HeapRatio,
    Time,
    Mrays,
}

/// A parsed `measure`: one timed term, or a sum of deterministic ones.
#[derive(Clone, Debug)]
pub(crate) struct Measure(pub(crate) Vec<Term>);

impl Measure {
    pub(crate) fn parse(s: &str) -> Result<Measure, String> {
        let terms: Vec<Term> = s
            .split('+')
            .map(|t| {
                let t = t.trim();
                Ok(match t {
                    "time" | "trace_ms_median" => Term::Time,
                    "mrays_per_s" => Term::Mrays,
                    "heap_ratio" => Term::HeapRatio,
                    "build_ms" => Term::BuildTime,
                    _ if t.starts_with("build:") && t.len() > 6 => Term::Build(t[6..].into()),
                    _ if !t.is_empty()
                        && t.bytes()
                            .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'_') =>
                    {
                        Term::Col(t.into())
                    }
                    _ => {
                        return Err(format!(
                            "`{t}` is not a column, time, mrays_per_s, build:KEY or heap_ratio"
                        ))
                    }
                })
            })
            .collect::<Result<_, String>>()?;
        if terms.len() > 1
            && terms
                .iter()
                .any(|t| matches!(t, Term::Time | Term::Mrays | Term::BuildTime))
        {
            return Err("a time measure (time, mrays_per_s, build_ms) stands alone".into());
        }
        Ok(Measure(terms))
    }

    /// Every column term names a numeric column of the CSVs a run writes.
    pub(crate) fn check_columns(&self) -> Result<(), String> {
        use super::columns::{known, Kind};
        for t in &self.0 {
            if let Term::Col(c) = t {
                match known().get(c.as_str()) {
                    None => {
                        return Err(format!(
                            "`{c}` is not a column of the CSVs a run writes (see claims/README.md, Measures)"
                        ))
                    }
                    Some(Kind::Number) => {}
                    Some(_) => return Err(format!("`{c}` is not a numeric column")),
                }
            }
        }
        Ok(())
    }

    pub(crate) fn timed(&self) -> bool {
        matches!(self.0[..], [Term::Time] | [Term::Mrays] | [Term::BuildTime])
    }
}
