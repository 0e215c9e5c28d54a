//! What evaluation yields: verdicts, pooled values with their intervals, the results of a
//! group and of a claim, and the time floor and between-process interval a timing takes.

use super::*;

/// A claim's (or a group's) verdict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// The rows bear the claim out: its test holds.
    Agree,
    /// The rows contradict the claim: its test fails.
    Disagree,
    /// Cannot be told from these rows (rows missing, a time interval across a bound, noisy
    /// or software-rendered timings).
    Inconclusive,
    /// Cannot be decided by construction (the claim's `undecidable`, or a time band narrower
    /// than the floor between runs): shown instead of `inconclusive`, not tallied with it.
    Undecidable,
    /// Every row that would decide it was made by an older method than this binary's (the
    /// rows' `method`, [`Options::methods`]): shown apart with the commit that made them and
    /// the command that would renew them, never tallied.
    Stale,
}

impl Verdict {
    /// The verdict as reports write it (`agree`, `disagree`, `inconclusive`, `undecidable`).
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Agree => "agree",
            Verdict::Disagree => "disagree",
            Verdict::Inconclusive => "inconclusive",
            Verdict::Undecidable => "undecidable",
            Verdict::Stale => "stale",
        }
    }
}

/// One pooled value: `v` with its 95 % interval `[lo, hi]` (a point for counters).
#[derive(Clone, Debug, Serialize)]
pub struct Value {
    /// The pooled value.
    pub v: f64,
    /// Lower end of its 95 % interval (`v` for a counter).
    pub lo: f64,
    /// Upper end of its 95 % interval (`v` for a counter).
    pub hi: f64,
    /// A timing (interval, noise) rather than a deterministic counter.
    pub timed: bool,
    /// Rows pooled.
    pub rows: usize,
    /// Of them, rows flagged `noisy` (timed measures).
    pub noisy: usize,
    /// Of them, GPU rows from a software adapter (timed measures).
    pub software: usize,
    /// Of them, rows timed fewer than `MIN_TIMED_RUNS` times (no interval).
    pub few_runs: usize,
    /// Timed rows timed interleaved (`run.interleave`): the pooled value of each round (the
    /// rows' `trace_ms_runs` summed round by round); empty otherwise.
    #[serde(skip)]
    pub runs: Vec<f64>,
    /// Their `timing_group`s, sorted: two values whose rows were timed together pair round
    /// for round.
    #[serde(skip)]
    pub tgroups: Vec<String>,
    /// The processes of the run the rows come from (`run --processes`; 1 for a run of one).
    pub processes: usize,
    /// `[lo, hi]` is the interval between those processes (`between_processes`), not
    /// widened to the floor.
    pub measured: bool,
    /// A timing's value in each process (by the `process` column) where its rows come from
    /// several: each pooled as the rows of one run are.
    #[serde(skip)]
    pub per_process: Vec<(String, Value)>,
}

/// The smallest relative uncertainty of a compared timing (a ratio of two times, or one time):
/// the variation between processes, which the intervals of one run cannot see. Measured here:
/// the same rows of `configs/multikd.toml` in three `reproduce` processes on one 2-core
/// machine moved by up to 31 % (Bunny `-presorted` path rays, 7.8 vs 10.2 ms, each within
/// ±1-3 % in its own run), their ratio to the SAH row by ±13 % around its mean. A time
/// comparison is decided only when its interval, widened to at least ±this, clears the bound.
pub const TIME_FLOOR: f64 = 0.2;

/// How claims are evaluated.
#[derive(Clone, Debug)]
pub struct Options {
    /// [`TIME_FLOOR`] unless changed (`claims --time-floor`).
    pub time_floor: f64,
    /// The current version of each method a row's `method` column names (the binary's
    /// structure families, `harness`, `gpu`): a results row is read only when each method it
    /// names is at its current version, and a row without the column is of version 0. Empty:
    /// every row is read (no method check).
    pub methods: BTreeMap<String, u32>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            time_floor: TIME_FLOOR,
            methods: BTreeMap::new(),
        }
    }
}

/// `[lo, v, hi]` widened to at least `v / (1 + f) .. v · (1 + f)` (positive values).
pub(super) fn floor_iv(d: [f64; 3], f: f64) -> [f64; 3] {
    if d[1].is_nan() || d[1] <= 0.0 || f <= 0.0 {
        return d;
    }
    [d[0].min(d[1] / (1.0 + f)), d[1], d[2].max(d[1] * (1.0 + f))]
}

/// Timed runs a row needs for its spread to bound the median (with fewer the interval is
/// unknown, not zero).
pub const MIN_TIMED_RUNS: f64 = 3.0;

/// Processes a compared time needs for its interval to be measured between them
/// ([`between_processes`]) instead of assumed ([`TIME_FLOOR`]). The interval is Student's t on
/// the processes' log values, `exp(m ± t(0.975, n − 1) · s / √n)`, whose quantile falls from
/// 12.7 with two processes (the spread of two values times 9: a 5 % difference between them
/// gives ±32 %, wider than the floor, and a standard deviation from two values is not one to
/// rely on) to 4.30 with three (2.5 times the spread); the distribution-free alternative, the
/// range of `n` values, covers the median with `1 − 2^(1 − n)`, 75 % for three, and needs six
/// processes for 95 %, twice the cost. Three is the fewest that measure; more narrow it.
pub const MIN_PROCESSES: usize = 3;

/// Two-sided 95 % quantiles of Student's t for 1 to 30 degrees of freedom (Fisher and Yates,
/// Statistical Tables, Table III); beyond, `1.96 + 2.5 / df` (within 0.002 of the table's 40,
/// 60 and 120).
pub(super) fn t975(df: usize) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => T[df - 1],
        _ => 1.96 + 2.5 / df as f64,
    }
}

/// The 95 % interval of a quantity measured once per process (`xs`, one value each, all
/// positive): Student's t on their logarithms, `[exp(m − h), exp(m), exp(m + h)]` with `m` the
/// mean log, `h = t(0.975, n − 1) · s / √n`, `s` the logs' standard deviation. Logarithms,
/// because times vary by factors (a process that runs 20 % slow slows every row by a factor)
/// and a ratio and its inverse then get the same interval, mirrored. Each process's value
/// carries its own noise (its rounds), so the spread holds the variation within processes and
/// between them. `None` with fewer than [`MIN_PROCESSES`] values or a value not above 0.
pub(crate) fn between_processes(xs: &[f64]) -> Option<[f64; 3]> {
    let n = xs.len();
    if n < MIN_PROCESSES || xs.iter().any(|x| !(*x > 0.0 && x.is_finite())) {
        return None;
    }
    let logs: Vec<f64> = xs.iter().map(|x| x.ln()).collect();
    let m = logs.iter().sum::<f64>() / n as f64;
    let var = logs.iter().map(|l| (l - m) * (l - m)).sum::<f64>() / (n - 1) as f64;
    let h = t975(n - 1) * (var / n as f64).sqrt();
    Some([(m - h).exp(), m.exp(), (m + h).exp()])
}

impl Value {
    pub(super) fn point(v: f64, rows: usize) -> Value {
        Value {
            v,
            lo: v,
            hi: v,
            timed: false,
            rows,
            noisy: 0,
            software: 0,
            few_runs: 0,
            runs: Vec::new(),
            tgroups: Vec::new(),
            processes: 1,
            measured: false,
            per_process: Vec::new(),
        }
    }

    /// Whether `self` and `o` were timed interleaved, round for round (in every process they
    /// share, where they come from several).
    pub(super) fn paired(&self, o: &Value) -> bool {
        let common = self.common(o);
        if !common.is_empty() {
            return common.iter().all(|(a, b)| a.paired(b));
        }
        !self.runs.is_empty() && self.runs.len() == o.runs.len() && self.tgroups == o.tgroups
    }

    /// The per-process values of `self` and `o` in the processes both come from.
    pub(super) fn common<'v>(&'v self, o: &'v Value) -> Vec<(&'v Value, &'v Value)> {
        self.per_process
            .iter()
            .filter_map(|(k, a)| {
                o.per_process
                    .iter()
                    .find(|(k2, _)| k2 == k)
                    .map(|(_, b)| (a, b))
            })
            .collect()
    }
}

/// One group's outcome.
#[derive(Clone, Debug, Serialize)]
pub struct GroupResult {
    /// The group key (`per` values joined by ` · `; empty without `per`).
    pub group: String,
    /// The group's verdict on the claim's test.
    pub verdict: Verdict,
    /// The compared quantity as shown (`0.93`, `+7.2 %`, `a 1.2 <= b 3.4`).
    pub shown: String,
    /// The compared quantity (band tests), with its interval.
    pub derived: Option<[f64; 3]>,
    /// Why that verdict, in words.
    pub why: String,
    /// A timed comparison's interval: `Some(n)` when it was measured between `n` processes
    /// (`MIN_PROCESSES` or more), `None` when the floor gave it (or nothing is timed).
    pub between: Option<usize>,
    /// A timed group's smallest decidable effect ([`effect`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect: Option<Effect>,
    /// Each selector's pooled value.
    pub values: BTreeMap<String, Value>,
}

/// One claim on one device.
#[derive(Clone, Debug, Serialize)]
pub struct ClaimResult {
    /// The claim's id in its claims file.
    pub id: String,
    /// Where the claim stands in the paper (table, row, column or section).
    #[serde(rename = "where")]
    pub place: String,
    /// The claim in words.
    pub text: String,
    /// The paper's figure(s), as printed.
    pub paper: String,
    /// The paper's figure in a few words, where the claims file gives it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paper_figure: Option<String>,
    /// The device the claim was evaluated on (`cpu`, `gpu`).
    pub device: String,
    /// A claim of the paper (tallied), an observation or an invariant (shown apart).
    pub kind: ClaimKind,
    /// The claim's measure (a column, a sum of columns, `time`, …).
    pub measure: String,
    /// Whether the measure (or a selector's own) is a timing ([`crate::stability`]: time
    /// verdicts may move between runs, counter verdicts may not).
    pub timed: bool,
    /// The groups' verdicts combined by the claim's `need`.
    pub verdict: Verdict,
    /// Why the claim cannot be decided by construction, where it cannot.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub undecidable: Option<String>,
    /// Our value: one group's, or `min..max (n groups)` for several.
    pub ours: String,
    /// Why the verdict: the groups that decided it.
    pub why: String,
    /// The claims file's note on this test and tolerance.
    pub note: Option<String>,
    /// The claim's test, as its file states it.
    pub test: Test,
    /// A timed claim's smallest decidable effect beside the effect its test asks for.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub effect: Option<ClaimEffect>,
    /// Every group's outcome.
    pub groups: Vec<GroupResult>,
}
