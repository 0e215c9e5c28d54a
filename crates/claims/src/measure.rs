//! A claim's `measure`: one timed term, a sum of deterministic ones, or the ratio of two such
//! measures of the same rows (`claims/README.md`, Measures).

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

/// A parsed `measure`: one timed term or a sum of deterministic ones (`num`), divided by
/// another such measure (`den`) when the measure is a ratio `a / b`.
#[derive(Clone, Debug)]
pub(crate) struct Measure {
    pub(crate) num: Vec<Term>,
    pub(crate) den: Option<Vec<Term>>,
}

impl Measure {
    /// `a`, `a + b + …`, or `A / B` where each side is one term or a parenthesised sum
    /// (`(a + b) / c`: a sum beside `/` without parentheses is refused as ambiguous). A ratio's
    /// sides cannot be trace times (`time`, `mrays_per_s`): those pool over rows timed round
    /// by round, and a ratio of them is a `ratio` test between selectors.
    pub(crate) fn parse(s: &str) -> Result<Measure, String> {
        let parts: Vec<&str> = s.split('/').collect();
        match parts[..] {
            [one] => {
                if one.contains(['(', ')']) {
                    return Err("parentheses only around a side of a ratio `(a + b) / c`".into());
                }
                Ok(Measure {
                    num: sum(one)?,
                    den: None,
                })
            }
            [n, d] => {
                let (num, den) = (side(n)?, side(d)?);
                if num
                    .iter()
                    .chain(&den)
                    .any(|t| matches!(t, Term::Time | Term::Mrays))
                {
                    return Err(
                        "a ratio's sides are columns of one row; trace times (time, mrays_per_s) \
                         are compared between selectors by a `ratio` test"
                            .into(),
                    );
                }
                Ok(Measure {
                    num,
                    den: Some(den),
                })
            }
            _ => Err("one `/` at most".into()),
        }
    }

    /// The numerator alone, then the denominator alone (`None` for a plain measure).
    pub(crate) fn sides(&self) -> Option<(Measure, Measure)> {
        let den = self.den.clone()?;
        let m = |t: Vec<Term>| Measure { num: t, den: None };
        Some((m(self.num.clone()), m(den)))
    }

    /// Every column term names a numeric column of the CSVs a run writes.
    pub(crate) fn check_columns(&self) -> Result<(), String> {
        use super::columns::{known, Kind};
        for t in self.num.iter().chain(self.den.iter().flatten()) {
            if let Term::Col(c) = t {
                match known().get(c.as_str()) {
                    None => {
                        return Err(format!(
                            "`{c}` is not a column of the CSVs a run writes (see claims/README.md, Measures)"
                        ))
                    }
                    Some(Kind::Number | Kind::Count) => {}
                    Some(_) => return Err(format!("`{c}` is not a numeric column")),
                }
            }
        }
        Ok(())
    }

    /// A timing of either sort (with an interval, or a wall-clock column or `build_stats`
    /// entry, on either side of a ratio): its comparisons get the floor between runs
    /// (`TIME_FLOOR`).
    pub(crate) fn floored(&self) -> bool {
        self.timed()
            || self
                .num
                .iter()
                .chain(self.den.iter().flatten())
                .any(|t| t.wall_clock() || matches!(t, Term::BuildTime))
    }

    /// A single timed term (`time`, `mrays_per_s`, `build_ms`), pooled with its interval.
    pub(crate) fn timed(&self) -> bool {
        self.den.is_none()
            && matches!(
                self.num[..],
                [Term::Time] | [Term::Mrays] | [Term::BuildTime]
            )
    }
}

/// One side of a ratio: one term, or a sum in parentheses.
fn side(s: &str) -> Result<Vec<Term>, String> {
    let t = s.trim();
    match t.strip_prefix('(').and_then(|x| x.strip_suffix(')')) {
        Some(inner) if !inner.contains(['(', ')']) => sum(inner),
        Some(_) => Err(format!("`{t}`: one pair of parentheses around a side")),
        None if t.contains(['(', ')']) => Err(format!("`{t}`: unbalanced parentheses")),
        None if t.contains('+') => Err(format!(
            "`{t}`: a sum beside `/` needs parentheses, `({t}) / …` or `… / ({t})`"
        )),
        None => sum(t),
    }
}

/// `a + b + …`: one timed term alone, or deterministic terms.
fn sum(s: &str) -> Result<Vec<Term>, String> {
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
    Ok(terms)
}

/// The ratio of two values pooled from the same rows, each `[lo, v, hi]`: `n / d`, its
/// interval the widest the two intervals allow (`n.lo / d.hi .. n.hi / d.lo`; a point where
/// both are points). The caller marks it a timing when either side is one (its comparisons
/// then get the floor between runs) and carries the sides' caveats over; it is not paired
/// round by round: only trace times are, and they are not a ratio's sides.
pub(crate) fn divide(n: [f64; 3], d: [f64; 3]) -> Result<[f64; 3], String> {
    if d[1].is_nan() || d[1] <= 0.0 {
        return Err(format!("the denominator is {}, not above 0", d[1]));
    }
    let hi = if d[0] > 0.0 {
        n[2] / d[0]
    } else {
        f64::INFINITY
    };
    Ok([n[0] / d[2], n[1] / d[1], hi])
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_parse() {
        let m = Measure::parse("build:build_expand_ms / build_ms").unwrap();
        assert_eq!(m.num, vec![Term::Build("build_expand_ms".into())]);
        assert_eq!(m.den, Some(vec![Term::BuildTime]));
        assert!(!m.timed());
        let m = Measure::parse("build:a / (build:a + build:b + build:c)").unwrap();
        assert_eq!(m.den.as_ref().map(Vec::len), Some(3));
        let m = Measure::parse("(planes_per_ray + prims_per_ray) / cells_per_ray").unwrap();
        assert_eq!(m.num.len(), 2);
        // Ambiguous or malformed.
        assert!(Measure::parse("build:a / build:b + build:c").is_err());
        assert!(Measure::parse("a + b / c").is_err());
        assert!(Measure::parse("a / b / c").is_err());
        assert!(Measure::parse("(a / b").is_err());
        assert!(Measure::parse("(a + b)").is_err());
        assert!(Measure::parse("((a + b)) / c").is_err());
        // Trace times are not a ratio's sides; build_ms stands alone on its side.
        assert!(Measure::parse("time / build_ms").is_err());
        assert!(Measure::parse("build:a / mrays_per_s").is_err());
        assert!(Measure::parse("build:a / (build_ms + build:b)").is_err());
    }

    #[test]
    fn ratios_divide_intervals() {
        assert_eq!(
            divide([2.0, 2.0, 2.0], [8.0, 8.0, 8.0]),
            Ok([0.25, 0.25, 0.25])
        );
        assert_eq!(
            divide([1.0, 2.0, 3.0], [2.0, 4.0, 6.0]),
            Ok([1.0 / 6.0, 0.5, 1.5])
        );
        assert_eq!(
            divide([1.0, 1.0, 1.0], [0.0, 1.0, 2.0]).unwrap()[2],
            f64::INFINITY
        );
        assert!(divide([1.0; 3], [0.0; 3]).is_err());
        assert!(divide([1.0; 3], [f64::NAN; 3]).is_err());
    }

    #[test]
    fn ratio_columns_are_checked() {
        assert!(Measure::parse("cells_per_ray / prims_per_ray")
            .unwrap()
            .check_columns()
            .is_ok());
        assert!(Measure::parse("cells_per_ray / bogus_per_ray")
            .unwrap()
            .check_columns()
            .is_err());
        assert!(Measure::parse("(bogus_per_ray + cells_per_ray) / build_ms")
            .unwrap()
            .check_columns()
            .is_err());
    }
}
