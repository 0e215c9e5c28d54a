//! The smallest effect a run could decide, beside the effect a claim's band asks for.
//!
//! A timed comparison is decided when its interval clears a bound: a ratio's whole interval
//! below 1 for "faster", inside `[min, max]` for a band. So a run decides only effects larger
//! than its intervals' relative half-width, which is the group's *smallest decidable effect*
//! ([`Effect::smallest`]). A claim's test states the effect it asks about
//! ([`paper_effect`]): a two-sided band its relative half-width (the interval must fit in it),
//! a one-sided bound or a margin its distance from no effect (a ratio of 1), a plain ordering
//! none (a direction only). Where the claim's effect is below the smallest decidable one the
//! run cannot decide it, and REPORT.md lists it with the processes that would: a time
//! interval's log half-width taken to shrink as `1/sqrt(processes)` (the spread of a mean of
//! independent processes), from the processes this run's intervals came from (one: the
//! floor between runs).

use super::schema::{Direction, Test};
use serde::Serialize;

/// One compared quantity of a group: its interval as a positive ratio-like quantity (a gain
/// turned back into `1 − gain`) and the bounds it must clear.
#[derive(Clone, Debug)]
pub(crate) struct Compared {
    pub iv: [f64; 3],
    pub bounds: Vec<f64>,
}

/// A timed group's smallest decidable effect.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Effect {
    /// The smallest relative effect the group's intervals can decide: the largest relative
    /// half-width among its compared quantities, `sqrt(hi / lo) − 1` (0.2: ±20 %).
    pub smallest: f64,
    /// How far our compared value lies from the bound it has to clear (relative, the nearest
    /// of the group's comparisons, `exp(|ln(v / bound)|) − 1`); `None` without a bound.
    pub from_bound: Option<f64>,
    /// The processes the intervals come from (1: one run, its intervals widened to the floor
    /// between runs).
    pub processes: usize,
}

/// A timed claim's smallest decidable effect against the effect its test asks for.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ClaimEffect {
    /// The largest of its groups' smallest decidable effects.
    pub smallest: f64,
    /// The effect the claim's test asks for (relative); 0 for a direction only.
    pub paper: f64,
    /// How [`ClaimEffect::paper`] is derived: `band` (a two-sided band's half-width), `bound`
    /// (a one-sided bound's or a margin's distance from no effect) or `direction` (none).
    pub paper_from: &'static str,
    /// The processes the intervals came from.
    pub processes: usize,
    /// Processes that would decide the claim's effect ([`processes_for`]; `None` for a
    /// direction only, or where this run's already do).
    pub processes_for_paper: Option<usize>,
    /// Processes that would decide our measured value (the group that needs the most; `None`
    /// where our value lies on a bound, or the groups are decided already).
    pub processes_for_ours: Option<usize>,
}

impl ClaimEffect {
    /// Whether the claim's effect is below what the run could decide.
    pub fn below(&self) -> bool {
        self.paper < self.smallest
    }
}

/// `sqrt(hi / lo) − 1`: the relative half-width of a positive interval, geometrically.
pub(crate) fn half_width(d: [f64; 3]) -> Option<f64> {
    (d[0] > 0.0 && d[2].is_finite() && d[2] >= d[0]).then(|| (d[2] / d[0]).sqrt() - 1.0)
}

/// A band test's compared interval as a positive ratio-like quantity (a gain's `1 − g/100`,
/// so its bounds swap) with its bounds.
pub(crate) fn banded(test: &Test, d: [f64; 3]) -> Option<Compared> {
    let (min, max) = test.band()?;
    Some(match test {
        Test::Gain { .. } => {
            let r = |g: f64| 1.0 - g / 100.0;
            Compared {
                iv: [r(d[2]), r(d[1]), r(d[0])],
                bounds: [min, max].into_iter().flatten().map(r).collect(),
            }
        }
        _ => Compared {
            iv: d,
            bounds: [min, max].into_iter().flatten().collect(),
        },
    })
}

/// The threshold of `x / y` in an ordering (`x` before `y`): `1 − margin` when strict, else 1.
pub(crate) fn before_bound(strict: bool, margin: f64) -> f64 {
    if strict {
        1.0 - margin
    } else {
        1.0
    }
}

/// The threshold of `best / other` in a `least` test.
pub(crate) fn least_bound(direction: Direction, margin: f64) -> f64 {
    match direction {
        Direction::Lowest => 1.0 - margin,
        Direction::Highest => 1.0 + margin,
    }
}

/// A group's smallest decidable effect from its compared quantities (`None` when none has a
/// finite positive interval), the intervals coming from `processes` processes.
pub(crate) fn of_group(cs: &[Compared], processes: usize) -> Option<Effect> {
    let hw: Vec<f64> = cs.iter().filter_map(|c| half_width(c.iv)).collect();
    if hw.is_empty() {
        return None;
    }
    let from_bound = cs
        .iter()
        .filter(|c| c.iv[1] > 0.0)
        .flat_map(|c| {
            c.bounds
                .iter()
                .filter(|b| **b > 0.0)
                .map(move |b| (c.iv[1] / b).ln().abs())
        })
        .min_by(f64::total_cmp)
        .map(|l| l.exp() - 1.0);
    Some(Effect {
        smallest: hw.into_iter().fold(0.0, f64::max),
        from_bound,
        processes: processes.max(1),
    })
}

/// The effect `t` asks for, relative, and how it is derived (`band`, `bound`, `direction`);
/// `None` for a one-sided value band (no ratio, so no point of no effect).
pub fn paper_effect(t: &Test) -> Option<(f64, &'static str)> {
    let away = |b: f64| (b > 0.0).then(|| b.max(1.0 / b) - 1.0);
    let one_sided = |b: f64| match away(b) {
        Some(e) if e > 1e-12 => Some((e, "bound")),
        Some(_) => Some((0.0, "direction")),
        None => None,
    };
    match t {
        Test::Value {
            min: Some(a),
            max: Some(b),
            ..
        }
        | Test::Ratio {
            min: Some(a),
            max: Some(b),
            ..
        }
        | Test::Speedup {
            min: Some(a),
            max: Some(b),
            ..
        } => (*a > 0.0).then(|| ((b / a).sqrt() - 1.0, "band")),
        Test::Gain {
            min: Some(a),
            max: Some(b),
            ..
        } => {
            let (lo, hi) = (1.0 - b / 100.0, 1.0 - a / 100.0);
            (lo > 0.0).then(|| ((hi / lo).sqrt() - 1.0, "band"))
        }
        Test::Value { .. } => None,
        Test::Ratio { min, max, .. } | Test::Speedup { min, max, .. } => one_sided(min.or(*max)?),
        Test::Gain { min, max, .. } => one_sided(1.0 - min.or(*max)? / 100.0),
        Test::Order { .. } => one_sided(before_bound(t.is_strict(), t.margin())),
        Test::Least { direction, .. } => one_sided(least_bound(*direction, t.margin())),
        Test::Equal { tolerance, .. } if *tolerance < 1.0 => {
            Some((((1.0 + tolerance) / (1.0 - tolerance)).sqrt() - 1.0, "band"))
        }
        Test::Equal { .. } => None,
    }
}

/// Processes whose intervals would decide an effect `effect` where `processes` gave the
/// relative half-width `smallest`: the log half-width taken to shrink as `1/sqrt(n)`, so
/// `n = processes · (ln(1 + smallest) / ln(1 + effect))²`, rounded up. `None` for no effect.
pub fn processes_for(smallest: f64, effect: f64, processes: usize) -> Option<usize> {
    if !(effect > 0.0 && smallest > 0.0) {
        return None;
    }
    let n = processes.max(1) as f64 * ((1.0 + smallest).ln() / (1.0 + effect).ln()).powi(2);
    Some(n.ceil().max(1.0) as usize)
}

/// A claim's effect from its groups' (the groups with an interval; `None` without any) and
/// `undecided`, whether the groups not yet decided are the ones `processes_for_ours` covers.
pub(crate) fn of_claim(t: &Test, groups: &[(Option<&Effect>, bool)]) -> Option<ClaimEffect> {
    let effects: Vec<(&Effect, bool)> = groups
        .iter()
        .filter_map(|(e, undecided)| e.map(|e| (e, *undecided)))
        .collect();
    let worst = effects
        .iter()
        .map(|(e, _)| e)
        .max_by(|a, b| a.smallest.total_cmp(&b.smallest))?;
    let (paper, paper_from) = paper_effect(t)?;
    let processes = effects.iter().map(|(e, _)| e.processes).min().unwrap_or(1);
    let for_paper = if paper < worst.smallest {
        processes_for(worst.smallest, paper, processes)
    } else {
        None
    };
    let for_ours = effects
        .iter()
        .filter(|(_, undecided)| *undecided)
        .map(|(e, _)| {
            e.from_bound
                .and_then(|f| processes_for(e.smallest, f, e.processes))
        })
        .try_fold(0usize, |m, n| n.map(|n| m.max(n)))
        .filter(|n| *n > 0);
    Some(ClaimEffect {
        smallest: worst.smallest,
        paper,
        paper_from,
        processes,
        processes_for_paper: for_paper,
        processes_for_ours: for_ours,
    })
}

/// A relative figure as a percentage with one decimal (`0.2` → `20`, `0.0526` → `5.3`).
pub fn pct(x: f64) -> String {
    let s = format!("{:.1}", 100.0 * x);
    s.strip_suffix(".0").map_or(s.clone(), str::to_owned)
}

/// The claim's effect in words, for its long reasons: `decides effects beyond ±20 % (1
/// process); the band asks for ±12 %: 3 processes would decide it`.
pub fn said(e: &ClaimEffect) -> String {
    let procs = |n: usize| format!("{n} process{}", if n == 1 { "" } else { "es" });
    let mut s = format!(
        "smallest decidable effect ±{} % ({})",
        pct(e.smallest),
        procs(e.processes)
    );
    match e.paper_from {
        "direction" => s.push_str("; the test asks for a direction only"),
        from => s.push_str(&format!(
            "; the {} asks for {}{} %",
            if from == "band" { "band" } else { "bound" },
            if from == "band" { "±" } else { "" },
            pct(e.paper)
        )),
    }
    if let Some(n) = e.processes_for_paper {
        s.push_str(&format!(", below it: {} would decide it", procs(n)));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ratio(min: Option<f64>, max: Option<f64>) -> Test {
        Test::Ratio {
            num: "a".into(),
            den: "b".into(),
            min,
            max,
        }
    }

    #[test]
    fn half_widths_are_geometric() {
        // The floor's interval v / 1.2 .. v · 1.2 has half-width 0.2 whatever v.
        let hw = half_width([5.0 / 1.2, 5.0, 5.0 * 1.2]).unwrap();
        assert!((hw - 0.2).abs() < 1e-12, "{hw}");
        assert_eq!(half_width([0.0, 1.0, 2.0]), None);
        assert_eq!(half_width([1.0, 1.0, f64::INFINITY]), None);
        assert_eq!(
            (pct(0.2), pct(0.0526), pct(0.11904)),
            ("20".into(), "5.3".into(), "11.9".into())
        );
    }

    #[test]
    fn the_paper_effect_follows_the_band() {
        // Two-sided: the interval must fit, so the band's half-width.
        let (e, from) = paper_effect(&ratio(Some(0.888), Some(1.112))).unwrap();
        assert_eq!(from, "band");
        assert!((e - (1.112f64 / 0.888).sqrt() + 1.0).abs() < 1e-12);
        // One-sided: the bound's distance from a ratio of 1, either side.
        let (e, from) = paper_effect(&ratio(Some(3.5), None)).unwrap();
        assert!((e - 2.5).abs() < 1e-12 && from == "bound");
        let (e, _) = paper_effect(&ratio(None, Some(0.8))).unwrap();
        assert!((e - 0.25).abs() < 1e-12);
        // A gain's band is one on 1 − gain; `gain >= 0` and an ordering state a direction.
        let gain = |min, max| Test::Gain {
            of: "a".into(),
            base: "b".into(),
            min,
            max,
        };
        assert_eq!(
            paper_effect(&gain(Some(0.0), None)),
            Some((0.0, "direction"))
        );
        let (e, _) = paper_effect(&gain(Some(2.0), Some(8.0))).unwrap();
        assert!((e - (0.98f64 / 0.92).sqrt() + 1.0).abs() < 1e-12);
        let order = |strict, margin, gap| Test::Order {
            rows: vec!["a".into(), "b".into()],
            strict,
            margin,
            gap,
        };
        assert_eq!(
            paper_effect(&order(true, Some(0.0), None)),
            Some((0.0, "direction"))
        );
        assert_eq!(
            paper_effect(&order(false, None, None)),
            Some((0.0, "direction"))
        );
        let (e, from) = paper_effect(&order(true, Some(0.2), None)).unwrap();
        assert!((e - 0.25).abs() < 1e-12 && from == "bound");
        // A printed gap: strict with the margin GAP_SHARE · gap.
        let (e, from) = paper_effect(&order(false, None, Some(0.4))).unwrap();
        let m = crate::schema::GAP_SHARE * 0.4;
        assert!((e - (1.0 / (1.0 - m) - 1.0)).abs() < 1e-12 && from == "bound");
        // No point of no effect for a one-sided value band.
        let value = Test::Value {
            of: "a".into(),
            min: Some(3.0),
            max: None,
        };
        assert_eq!(paper_effect(&value), None);
    }

    #[test]
    fn processes_scale_as_the_square_of_the_ratio_of_logs() {
        // ±20 % from one process, an effect of ±10 %: (ln 1.2 / ln 1.1)² = 3.64 → 4.
        assert_eq!(processes_for(0.2, 0.1, 1), Some(4));
        // Half the effect, four times the processes.
        let (a, b) = (processes_for(0.2, 0.05, 3).unwrap(), 3.0 * 3.74f64.powi(2));
        assert!((a as f64 - b).abs() <= 1.0, "{a} vs {b}");
        assert_eq!(processes_for(0.2, 0.0, 1), None);
    }

    #[test]
    fn a_claim_lists_below_only_when_its_effect_is_smaller() {
        let g = Effect {
            smallest: 0.2,
            from_bound: Some(0.05),
            processes: 1,
        };
        let tie = of_claim(&ratio(Some(0.888), Some(1.112)), &[(Some(&g), true)]).unwrap();
        assert!(tie.below());
        assert_eq!(tie.processes_for_paper, Some(3));
        // ln 1.2 / ln 1.05 = 3.74: 14 processes to decide our value.
        assert_eq!(tie.processes_for_ours, Some(14));
        assert!(
            said(&tie).contains("3 processes would decide it"),
            "{}",
            said(&tie)
        );
        let wide = of_claim(&ratio(Some(3.5), None), &[(Some(&g), false)]).unwrap();
        assert!(!wide.below());
        assert_eq!(
            (wide.processes_for_paper, wide.processes_for_ours),
            (None, None)
        );
        // Groups without an interval give no effect.
        assert_eq!(of_claim(&ratio(Some(1.0), None), &[(None, true)]), None);
    }

    #[test]
    fn groups_take_their_widest_interval_and_nearest_bound() {
        let cs = [
            Compared {
                iv: [0.9, 1.0, 1.1],
                bounds: vec![1.2],
            },
            Compared {
                iv: [0.5, 0.8, 2.0],
                bounds: vec![0.79],
            },
        ];
        let e = of_group(&cs, 1).unwrap();
        assert!((e.smallest - 1.0).abs() < 1e-12, "{e:?}");
        let near = (0.8f64 / 0.79).ln().exp() - 1.0;
        assert!((e.from_bound.unwrap() - near).abs() < 1e-12);
        // A gain's interval turns into 1 − gain with the bounds swapped.
        let g = Test::Gain {
            of: "a".into(),
            base: "b".into(),
            min: Some(0.0),
            max: None,
        };
        let c = banded(&g, [-10.0, 5.0, 20.0]).unwrap();
        assert_eq!(c.iv, [0.8, 0.95, 1.1]);
        assert_eq!(c.bounds, vec![1.0]);
    }
}
