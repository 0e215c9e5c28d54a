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

    /// A timing of either sort (with an interval, or a wall-clock column): its comparisons
    /// get the floor between runs (`TIME_FLOOR`).
    pub(crate) fn floored(&self) -> bool {
        self.timed() || self.0.iter().any(Term::wall_clock)
    }
}

impl Term {
    /// A column computed from wall-clock time (`primary_ms`, `ao_ms_per_spp`, `elapsed_ms`,
    /// the dynamic table's `spp`, …) or a `build_stats` entry that is one (`build:insert_ms`,
    /// the grids' `build:build_merge_ms`, …): no interval of its own, but subject to
    /// `TIME_FLOOR`.
    pub(crate) fn wall_clock(&self) -> bool {
        let timing = |c: &str| c.ends_with("_ms") || c.contains("_ms_");
        match self {
            Term::Col(c) => timing(c) || c == "spp",
            Term::Build(k) => timing(k),
            _ => false,
        }
    }
}

/// A number in five significant digits (whole numbers from 10,000).
pub(crate) fn fmt(x: f64) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "n/a".into()
        } else if x > 0.0 {
            "∞".into()
        } else {
            "-∞".into()
        };
    }
    let a = x.abs();
    if a >= 10000.0 || a == 0.0 {
        return format!("{x:.0}");
    }
    let d = (4 - a.log10().floor() as i32).clamp(0, 8) as usize;
    let s = format!("{x:.d$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_owned()
    } else {
        s
    }
}
