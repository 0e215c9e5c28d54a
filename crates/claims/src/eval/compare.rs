//! The tests a claim names (band, order, least, equal, compared effects) on pooled values,
//! each giving a verdict, the figure we measured and its interval.

use super::*;

pub(super) fn fmt_iv(v: f64, lo: f64, hi: f64, timed: bool) -> String {
    if timed {
        format!("{} [{}, {}]", fmt(v), fmt(lo), fmt(hi))
    } else {
        fmt(v)
    }
}

pub(super) fn band_text(min: Option<f64>, max: Option<f64>) -> String {
    match (min, max) {
        (Some(a), Some(b)) => format!("[{}, {}]", fmt(a), fmt(b)),
        (Some(a), None) => format!(">= {}", fmt(a)),
        (None, Some(b)) => format!("<= {}", fmt(b)),
        (None, None) => "any".into(),
    }
}

pub(super) fn band_verdict(lo: f64, hi: f64, min: Option<f64>, max: Option<f64>) -> Verdict {
    let (a, b) = (
        min.unwrap_or(f64::NEG_INFINITY),
        max.unwrap_or(f64::INFINITY),
    );
    if lo >= a && hi <= b {
        Verdict::Agree
    } else if hi < a || lo > b {
        Verdict::Disagree
    } else {
        Verdict::Inconclusive
    }
}

/// The round-by-round ratio `n / d` of values timed together: its median and 95 % interval.
pub(super) fn paired_ratio(n: &Value, d: &Value) -> [f64; 3] {
    let r: Vec<f64> = n
        .runs
        .iter()
        .zip(&d.runs)
        .map(|(a, b)| a / b.max(1e-300))
        .collect();
    let (lo, hi) = tb_results::stats::median_ci(&r);
    [lo, tb_results::stats::median(&mut r.clone()), hi]
}

/// How a group's compared times get their intervals: between the processes both sides come
/// from, where they share [`MIN_PROCESSES`] or more ([`between_processes`] of the per-process
/// quantity: the round-by-round ratio of each process where its rows were timed interleaved,
/// else the ratio of its values); otherwise their own intervals (the hull of the shared
/// processes' own) widened to at least the floor between runs ([`TIME_FLOOR`]). It records the fewest processes compared and whether the
/// floor was used, for the group's `why`.
pub(super) struct Cmp {
    floor: f64,
    /// The group compares timings (else intervals are points and nothing is widened).
    timed: bool,
    /// The fewest processes of a comparison so far (`usize::MAX`: none yet), and whether one
    /// was widened to the floor.
    how: std::cell::Cell<(usize, bool)>,
}

impl Cmp {
    fn new(floor: f64, timed: bool) -> Cmp {
        Cmp {
            floor,
            timed,
            how: std::cell::Cell::new((usize::MAX, false)),
        }
    }

    fn note(&self, processes: usize, floored: bool) {
        let (p, f) = self.how.get();
        self.how.set((p.min(processes), f || floored));
    }

    /// The ratio `n / d` with its interval.
    fn ratio(&self, n: &Value, d: &Value) -> [f64; 3] {
        let common = n.common(d);
        if self.timed && common.len() >= MIN_PROCESSES {
            let rs: Vec<f64> = common
                .iter()
                .map(|(a, b)| {
                    if a.paired(b) {
                        paired_ratio(a, b)[1]
                    } else {
                        a.v / b.v
                    }
                })
                .collect();
            if let Some(iv) = between_processes(&rs) {
                self.note(common.len(), false);
                return iv;
            }
        }
        // Fewer processes: the hull of each shared process's own ratio (round by round where
        // paired), or the values' intervals where they share none.
        let r = if common.is_empty() {
            ratio(n, d)
        } else {
            let ivs: Vec<[f64; 3]> = common.iter().map(|(a, b)| ratio(a, b)).collect();
            let mid = ivs.iter().map(|x| x[1].ln()).sum::<f64>() / ivs.len() as f64;
            [
                ivs.iter().map(|x| x[0]).fold(f64::INFINITY, f64::min),
                mid.exp(),
                ivs.iter().map(|x| x[2]).fold(f64::NEG_INFINITY, f64::max),
            ]
        };
        if self.timed {
            self.note(common.len().max(1), true);
            floor_iv(r, self.floor)
        } else {
            r
        }
    }

    /// `x` with its interval.
    fn value(&self, x: &Value) -> [f64; 3] {
        let d = [x.lo, x.v, x.hi];
        if !self.timed {
            d
        } else if x.measured {
            self.note(x.processes, false);
            d
        } else {
            self.note(x.processes, true);
            floor_iv(d, self.floor)
        }
    }

    /// Whether a comparison so far was widened to the floor.
    fn floored(&self) -> bool {
        self.how.get().1
    }

    /// Where the timed comparisons' intervals came from, in words (`between 3 processes`,
    /// `floor ±20 %, 1 process`), and the processes when measured between them.
    fn said(&self) -> Option<(String, Option<usize>)> {
        let (p, floored) = self.how.get();
        if !self.timed || p == usize::MAX {
            return None;
        }
        let procs = format!("{p} process{}", if p == 1 { "" } else { "es" });
        Some(if floored {
            (
                format!(
                    "interval: floor ±{} % (the variation between runs, not measured), {procs}",
                    fmt(100.0 * self.floor)
                ),
                None,
            )
        } else {
            (format!("interval between {procs}"), Some(p))
        })
    }
}

/// `x` before `y` in an ordering (strict: below `y·(1 − margin)`), with intervals (of the
/// paired ratio where they were timed together; between processes where measured there).
pub(super) fn before(x: &Value, y: &Value, strict: bool, margin: f64, cmp: &Cmp) -> Verdict {
    if x.timed || y.timed {
        let r = cmp.ratio(x, y);
        let f = if strict { 1.0 - margin } else { 1.0 };
        return if (strict && r[2] < f) || (!strict && r[2] <= f) {
            Verdict::Agree
        } else if (strict && r[0] >= f) || (!strict && r[0] > f) {
            Verdict::Disagree
        } else {
            Verdict::Inconclusive
        };
    }
    if strict {
        let f = 1.0 - margin;
        if x.hi < y.lo * f {
            Verdict::Agree
        } else if x.lo >= y.hi * f {
            Verdict::Disagree
        } else {
            Verdict::Inconclusive
        }
    } else if x.hi <= y.lo {
        Verdict::Agree
    } else if x.lo > y.hi {
        Verdict::Disagree
    } else {
        Verdict::Inconclusive
    }
}

/// `x` above `y` by the margin (strict), with intervals.
pub(super) fn above(x: &Value, y: &Value, margin: f64, cmp: &Cmp) -> Verdict {
    let f = 1.0 + margin;
    if x.timed || y.timed {
        let r = cmp.ratio(x, y);
        return if r[0] > f {
            Verdict::Agree
        } else if r[2] <= f {
            Verdict::Disagree
        } else {
            Verdict::Inconclusive
        };
    }
    if x.lo > y.hi * f {
        Verdict::Agree
    } else if x.hi <= y.lo * f {
        Verdict::Disagree
    } else {
        Verdict::Inconclusive
    }
}

pub(super) fn all_of(vs: impl IntoIterator<Item = Verdict>) -> Verdict {
    let mut out = Verdict::Agree;
    for v in vs {
        match v {
            Verdict::Disagree => return Verdict::Disagree,
            Verdict::Inconclusive | Verdict::Undecidable | Verdict::Stale => {
                out = Verdict::Inconclusive
            }
            Verdict::Agree => {}
        }
    }
    out
}

/// Ratio `n / d` with its interval within one run (paired round by round where they were
/// timed together).
pub(super) fn ratio(n: &Value, d: &Value) -> [f64; 3] {
    if n.paired(d) && n.per_process.is_empty() {
        return paired_ratio(n, d);
    }
    [
        n.lo / d.hi,
        n.v / d.v,
        if d.lo > 0.0 {
            n.hi / d.lo
        } else {
            f64::INFINITY
        },
    ]
}

/// A test's outcome on one group: verdict, the compared quantity as shown, the compared
/// quantity with its interval (band tests), why.
pub(super) type Outcome = (Verdict, String, Option<[f64; 3]>, String);

/// Run the test on one group's values; with the processes its time intervals were measured
/// between (`None`: the floor, or no timing).
pub(super) fn run_test(
    test: &Test,
    vals: &BTreeMap<String, Value>,
    floor: f64,
) -> (Outcome, Option<usize>) {
    let v = |n: &str| &vals[n];
    let cmp = Cmp::new(floor, vals.values().any(|x| x.timed));
    let ratio = |a: &Value, b: &Value| cmp.ratio(a, b);
    let banded = |d: [f64; 3], min, max, pct: bool| banded(d, min, max, pct, &cmp);
    let (verdict, shown, derived, why) = match test {
        Test::Value { of, min, max } => banded(cmp.value(v(of)), *min, *max, false),
        Test::Ratio { num, den, min, max } => banded(ratio(v(num), v(den)), *min, *max, false),
        Test::Speedup { of, base, min, max } => banded(ratio(v(base), v(of)), *min, *max, false),
        Test::Gain { of, base, min, max } => {
            let r = ratio(v(of), v(base));
            let g = [
                100.0 * (1.0 - r[2]),
                100.0 * (1.0 - r[1]),
                100.0 * (1.0 - r[0]),
            ];
            banded(g, *min, *max, true)
        }
        Test::Order { rows, .. } => order_test(rows, test.is_strict(), test.margin(), vals, &cmp),
        Test::Least {
            best,
            of,
            direction,
            ..
        } => least_test(best, of, test.margin(), *direction, vals, &cmp),
        Test::Equal { a, b, tolerance } => equal_test(a, b, *tolerance, vals, &cmp),
    };
    match cmp.said() {
        Some((said, between)) => ((verdict, shown, derived, format!("{why}; {said}")), between),
        None => ((verdict, shown, derived, why), None),
    }
}

/// A timed group's compared quantities as ratios with the bounds each must clear: a band
/// test's `derived`, an ordering's neighbours, a `least` test's best against each rival; the
/// intervals as the test used them (`ratio` and [`floored`]). Empty when nothing is timed.
pub(super) fn compared(
    test: &Test,
    vals: &BTreeMap<String, Value>,
    derived: Option<[f64; 3]>,
    floor: f64,
) -> Vec<Compared> {
    let timed = vals.values().any(|x| x.timed);
    if !timed {
        return Vec::new();
    }
    // The same intervals the test compared: between processes where measured, else floored.
    let cmp = Cmp::new(floor, timed);
    let r = |a: &str, b: &str| cmp.ratio(&vals[a], &vals[b]);
    match test {
        Test::Order { rows, .. } => rows
            .windows(2)
            .map(|w| Compared {
                iv: r(&w[0], &w[1]),
                bounds: vec![effect::before_bound(test.is_strict(), test.margin())],
            })
            .collect(),
        Test::Least {
            best,
            of,
            direction,
            ..
        } => of
            .iter()
            .map(|o| Compared {
                iv: r(best, o),
                bounds: vec![effect::least_bound(*direction, test.margin())],
            })
            .collect(),
        Test::Equal { tolerance, .. } => derived
            .map(|d| Compared {
                iv: d,
                bounds: vec![1.0 - tolerance, 1.0 + tolerance],
            })
            .into_iter()
            .collect(),
        t => derived
            .and_then(|d| effect::banded(t, d))
            .into_iter()
            .collect(),
    }
}

/// A band test's outcome: the compared quantity `d` (percent when `pct`) in `min..=max`.
pub(super) fn banded(
    d: [f64; 3],
    min: Option<f64>,
    max: Option<f64>,
    pct: bool,
    cmp: &Cmp,
) -> Outcome {
    let verdict = band_verdict(d[0], d[2], min, max);
    let unit = if pct { " %" } else { "" };
    let shown = if cmp.timed {
        format!("{}{unit} [{}, {}]", fmt(d[1]), fmt(d[0]), fmt(d[2]))
    } else {
        format!("{}{unit}", fmt(d[1]))
    };
    let why = match verdict {
        Verdict::Agree => format!("in {}", band_text(min, max)),
        Verdict::Disagree => format!("outside {}", band_text(min, max)),
        Verdict::Inconclusive if cmp.floored() => format!(
            "interval straddles {} (a time's is at least ±{} %: the variation between runs)",
            band_text(min, max),
            fmt(100.0 * cmp.floor)
        ),
        Verdict::Inconclusive | Verdict::Undecidable | Verdict::Stale => {
            format!("interval straddles {}", band_text(min, max))
        }
    };
    (verdict, shown, Some(d), why)
}

/// The `order` test: each row before the next.
pub(super) fn order_test(
    rows: &[String],
    strict: bool,
    margin: f64,
    vals: &BTreeMap<String, Value>,
    cmp: &Cmp,
) -> Outcome {
    let v = |n: &str| &vals[n];
    let timed = cmp.timed;
    let verdicts: Vec<Verdict> = rows
        .windows(2)
        .map(|w| before(v(&w[0]), v(&w[1]), strict, margin, cmp))
        .collect();
    // Each neighbour pair with the relation measured (`<`, `=`, `>`).
    let mut shown = String::new();
    for (i, n) in rows.iter().enumerate() {
        if i > 0 {
            let (a, b) = (v(&rows[i - 1]).v, v(n).v);
            shown.push_str(match a.partial_cmp(&b) {
                Some(std::cmp::Ordering::Less) => " < ",
                Some(std::cmp::Ordering::Equal) => " = ",
                _ => " > ",
            });
        }
        shown.push_str(&format!("{n} {}", fmt_iv(v(n).v, v(n).lo, v(n).hi, timed)));
    }
    let broken: Vec<String> = rows
        .windows(2)
        .zip(&verdicts)
        .filter(|(_, x)| **x != Verdict::Agree)
        .map(|(w, x)| {
            let rel = if *x == Verdict::Disagree {
                "not below"
            } else {
                "overlaps"
            };
            format!("{} {rel} {}", w[0], w[1])
        })
        .collect();
    let why = if broken.is_empty() {
        format!("in order ({} rows)", rows.len())
    } else {
        broken.join("; ")
    };
    let why = format!("{why}{}", by_margin(strict, margin));
    (all_of(verdicts), shown, None, why)
}

/// The `least` test: `best` below (above) every row of `of` by the margin.
pub(super) fn least_test(
    best: &str,
    of: &[String],
    margin: f64,
    direction: Direction,
    vals: &BTreeMap<String, Value>,
    cmp: &Cmp,
) -> Outcome {
    let v = |n: &str| &vals[n];
    let timed = cmp.timed;
    let b = v(best);
    let verdicts: Vec<(Verdict, &String)> = of
        .iter()
        .map(|o| {
            let x = v(o);
            let r = match direction {
                Direction::Lowest => before(b, x, true, margin, cmp),
                Direction::Highest => above(b, x, margin, cmp),
            };
            (r, o)
        })
        .collect();
    // The nearest rival.
    let rival = of
        .iter()
        .min_by(|a, c| {
            let key = |n: &str| match direction {
                Direction::Lowest => v(n).v,
                Direction::Highest => -v(n).v,
            };
            key(a).total_cmp(&key(c))
        })
        .expect("least has rivals");
    let shown = format!(
        "{best} {}; next {rival} {}",
        fmt_iv(b.v, b.lo, b.hi, timed),
        fmt_iv(v(rival).v, v(rival).lo, v(rival).hi, timed)
    );
    let word = match direction {
        Direction::Lowest => "not below",
        Direction::Highest => "not above",
    };
    let why = verdicts
        .iter()
        .filter(|(x, _)| *x != Verdict::Agree)
        .map(|(x, o)| {
            if *x == Verdict::Disagree {
                format!("{best} {word} {o} ({})", fmt(v(o).v))
            } else {
                format!("{best} overlaps {o}")
            }
        })
        .collect::<Vec<_>>()
        .join("; ");
    let why = if why.is_empty() {
        let word = match direction {
            Direction::Lowest => "lowest",
            Direction::Highest => "highest",
        };
        format!("{word} of {}", of.len() + 1)
    } else {
        why
    };
    let why = format!("{why}{}", by_margin(true, margin));
    (all_of(verdicts.into_iter().map(|x| x.0)), shown, None, why)
}

/// An ordering's margin in its reason (`, by 5 %`), nothing without one.
fn by_margin(strict: bool, margin: f64) -> String {
    if strict && margin > 0.0 {
        format!(", by {} %", fmt(100.0 * margin))
    } else {
        String::new()
    }
}

/// The `equal` test: `a` and `b` within the tolerance of each other.
pub(super) fn equal_test(
    a: &str,
    b: &str,
    tolerance: f64,
    vals: &BTreeMap<String, Value>,
    cmp: &Cmp,
) -> Outcome {
    let (x, y) = (&vals[a], &vals[b]);
    let timed = cmp.timed;
    let r = cmp.ratio(x, y);
    let verdict = if timed {
        band_verdict(r[0], r[2], Some(1.0 - tolerance), Some(1.0 + tolerance))
    } else if (x.v - y.v).abs() <= tolerance * x.v.abs().max(y.v.abs()) {
        Verdict::Agree
    } else {
        Verdict::Disagree
    };
    let shown = format!(
        "{a} {}, {b} {} (Δ {} %)",
        fmt_iv(x.v, x.lo, x.hi, timed),
        fmt_iv(y.v, y.lo, y.hi, timed),
        fmt(100.0 * (r[1] - 1.0))
    );
    let why = format!("tolerance {} %", fmt(100.0 * tolerance));
    (verdict, shown, Some(r), why)
}
