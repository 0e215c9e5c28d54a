//! Timed repeats: how many (until the median is known well enough), medians and the confidence
//! interval of the median (their formulas in tb_results::stats, re-exported), and the timing
//! columns of a row.

use std::time::{Duration, Instant};
use tb_results::output::Row;
pub use tb_results::stats::{median, median_ci};

/// How a row is timed: `warmup` untimed runs, then at least `repeat` timed runs, more (up to
/// `max_repeat`) while the relative half-width of the median's 95 % confidence interval is
/// above `target_ci` and the row has run for less than `max_row_seconds`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimingPlan {
    /// Untimed runs before the timed ones.
    pub warmup: usize,
    /// Timed runs at least.
    pub repeat: usize,
    /// Timed runs at most.
    pub max_repeat: usize,
    /// Relative half-width of the median's 95 % CI that ends the repeats.
    pub target_ci: f64,
    /// No further timed run once a row has run this long (beyond `repeat`).
    pub max_row_seconds: f64,
    /// What a one-thread CPU row's timed run measures (`run.clock`).
    pub clock: Clock,
    /// The most rays of a batch a CPU row is timed on (`run.timed_rays`; `None`: all of
    /// them); the counters always come from the whole batch ([`timed_indices`]).
    pub timed_rays: Option<usize>,
    /// The share of each batch a CPU row is timed on (`run.timed_share`, in (0, 1]; `None`:
    /// all of it); with `timed_rays` the smaller of the two counts ([`TimingPlan::timed_max`]).
    pub timed_share: Option<f64>,
}

/// What a timed run of a one-thread CPU row measures (`run.clock`; rows of more threads and
/// GPU rows are always timed by the wall clock).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Clock {
    /// Wall-clock time (the default): what the papers measured, on a machine of their own.
    #[default]
    Wall,
    /// The tracing thread's CPU time (`CLOCK_THREAD_CPUTIME_ID`; the wall clock where the
    /// platform has none): on an idle machine the same as the wall time of this compute-bound
    /// work, on a shared one without the time the thread waited for a core. On the 2-core
    /// machine under other agents' builds it cut the spread of a row's median between processes
    /// from a factor 5.3 to 1.27 and of a round-by-round ratio from ±6.7 to ±3.6 %
    /// (docs/variation.md).
    Thread,
}

impl Clock {
    /// The clock `run.clock` names (`wall`, `thread`).
    pub fn from_name(s: &str) -> Option<Clock> {
        match s {
            "wall" => Some(Clock::Wall),
            "thread" => Some(Clock::Thread),
            _ => None,
        }
    }
}

/// The calling thread's CPU time in ms (`None` where the platform does not give it).
pub fn thread_cpu_ms() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: clock_gettime writes only the timespec it is given.
        let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
        ok.then_some(ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Time `f` run on the current thread: its ms by `clock` (the wall clock for
/// [`Clock::Wall`], or where the thread's CPU time is not available), and its result.
pub fn timed<T>(clock: Clock, f: impl FnOnce() -> T) -> (f64, T) {
    let t0 = Instant::now();
    let c0 = (clock == Clock::Thread).then(thread_cpu_ms).flatten();
    let out = f();
    let ms = match c0.zip(thread_cpu_ms()) {
        Some((a, b)) => b - a,
        None => t0.elapsed().as_secs_f64() * 1e3,
    };
    (ms, out)
}

impl TimingPlan {
    /// The most rays of a batch of `n` a CPU row is timed on: the smaller of `run.timed_rays`
    /// and `run.timed_share` of `n` (rounded up, so at least one ray); `None` when neither is
    /// set.
    pub fn timed_max(&self, n: usize) -> Option<usize> {
        let by_share = self
            .timed_share
            .map(|s| ((s * n as f64).ceil() as usize).clamp(1, n.max(1)));
        match (self.timed_rays, by_share) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Time `once` (one pass, returning its ms) under this plan; the timed runs' ms.
    pub fn run<E>(&self, mut once: impl FnMut() -> Result<f64, E>) -> Result<Vec<f64>, E> {
        for _ in 0..self.warmup {
            once()?;
        }
        let start = Instant::now();
        let budget = Duration::from_secs_f64(self.max_row_seconds.max(0.0));
        let mut times = Vec::with_capacity(self.repeat);
        loop {
            times.push(once()?);
            let n = times.len();
            if n >= self.max_repeat.max(self.repeat) {
                break;
            }
            if n >= self.repeat.max(1)
                && (relative_ci(&times) <= self.target_ci || start.elapsed() >= budget)
            {
                break;
            }
        }
        Ok(times)
    }
}

impl TimingPlan {
    /// Time `n` rows interleaved: `warmup` untimed rounds, then rounds of one timed pass of
    /// each row in turn (`once(i)` returns row `i`'s ms), so drift and other load fall on
    /// every row alike. At least `repeat` rounds; more (up to `max_repeat`) while the 95 %
    /// interval of any pair's ratio, taken round by round, is wider than `target_ci` (a lone
    /// row: its own median's), and the rounds have run for less than `max_row_seconds` per
    /// row. Returns each row's times in round order.
    pub fn run_interleaved<E>(
        &self,
        n: usize,
        mut once: impl FnMut(usize) -> Result<f64, E>,
    ) -> Result<Vec<Vec<f64>>, E> {
        for _ in 0..self.warmup {
            for i in 0..n {
                once(i)?;
            }
        }
        let start = Instant::now();
        let budget = Duration::from_secs_f64(self.max_row_seconds.max(0.0) * n as f64);
        let mut times = vec![Vec::with_capacity(self.repeat); n];
        loop {
            for (i, t) in times.iter_mut().enumerate() {
                t.push(once(i)?);
            }
            let rounds = times.first().map_or(0, Vec::len);
            if n == 0 || rounds >= self.max_repeat.max(self.repeat) {
                break;
            }
            if rounds >= self.repeat.max(1)
                && (widest_pair_ci(&times) <= self.target_ci || start.elapsed() >= budget)
            {
                break;
            }
        }
        Ok(times)
    }
}

/// The widest relative 95 % interval of the round-by-round ratio of any two rows (of the one
/// row's median when alone).
pub fn widest_pair_ci(times: &[Vec<f64>]) -> f64 {
    if times.len() == 1 {
        return relative_ci(&times[0]);
    }
    let mut w: f64 = 0.0;
    for i in 0..times.len() {
        for j in i + 1..times.len() {
            let r: Vec<f64> = times[i]
                .iter()
                .zip(&times[j])
                .map(|(a, b)| a / b.max(1e-12))
                .collect();
            w = w.max(relative_ci(&r));
        }
    }
    w
}

/// Half the width of [`median_ci`] relative to the median.
pub fn relative_ci(v: &[f64]) -> f64 {
    let (lo, hi) = median_ci(v);
    let med = median(&mut v.to_vec());
    if med > 0.0 {
        (hi - lo) / (2.0 * med)
    } else {
        0.0
    }
}

/// CPU time of the whole machine and of this process at one moment (Linux `/proc/stat` and
/// `/proc/self/stat`, clock ticks), to measure what other processes took during a row.
#[derive(Clone, Copy, Debug)]
pub struct CpuSample {
    /// Busy ticks of all CPUs (user, nice, system, irq, softirq, steal).
    busy: u64,
    /// All ticks of all CPUs (busy, idle, iowait).
    total: u64,
    /// This process's user and system ticks.
    own: u64,
}

impl CpuSample {
    /// Now; `None` where `/proc` does not tell.
    pub fn now() -> Option<CpuSample> {
        let stat = std::fs::read_to_string("/proc/stat").ok()?;
        let f: Vec<u64> = stat
            .lines()
            .next()?
            .split_whitespace()
            .skip(1)
            .take(8)
            .map(|x| x.parse().unwrap_or(0))
            .collect();
        if f.len() < 8 {
            return None;
        }
        let busy = f[0] + f[1] + f[2] + f[5] + f[6] + f[7];
        let total = busy + f[3] + f[4];
        let own_stat = std::fs::read_to_string("/proc/self/stat").ok()?;
        // Fields after the command name (which may hold spaces) start at `) `: utime and
        // stime are the 14th and 15th fields, the 12th and 13th after it.
        let rest = &own_stat[own_stat.rfind(')')? + 2..];
        let g: Vec<u64> = rest
            .split_whitespace()
            .map(|x| x.parse().unwrap_or(0))
            .collect();
        let own = g.get(11)? + g.get(12)?;
        Some(CpuSample { busy, total, own })
    }

    /// CPU cores that other processes kept busy on average since `earlier`; `None` when too
    /// little time passed to tell (under two clock ticks per CPU).
    pub fn others_since(&self, earlier: &CpuSample) -> Option<f64> {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get()) as f64;
        let total = self.total.saturating_sub(earlier.total) as f64;
        if total < 2.0 * cpus {
            return None;
        }
        let busy = self.busy.saturating_sub(earlier.busy) as f64;
        let own = self.own.saturating_sub(earlier.own) as f64;
        Some(((busy - own).max(0.0) / total * cpus * 100.0).round() / 100.0)
    }
}

/// Other processes' average CPU use (cores) above which a row is flagged `noisy`.
pub const OTHERS_NOISY: f64 = 0.5;

/// The 1-minute load average (Linux `/proc/loadavg`); `None` elsewhere.
pub fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Times in ms as a `;`-separated list, in order (`trace_ms_runs`, `build_ms_runs`).
pub fn ms_list(times: &[f64]) -> String {
    times
        .iter()
        .map(|t| format!("{t:.6}"))
        .collect::<Vec<_>>()
        .join(";")
}

/// Fill `trace_ms_{min,median,max}`, `mrays_per_s`, `timed_runs`, `timed_rays`,
/// `trace_ms_ci` and `noisy` (the confidence interval wider than `target_ci`) from the times
/// (ms) of the timed runs over `rays` rays. One timed run has no interval: `trace_ms_ci` and
/// `noisy` stay empty ("not measured").
pub fn fill(row: &mut Row, times: &mut [f64], rays: usize, target_ci: f64) {
    row.timed_runs = Some(times.len() as u32);
    row.timed_rays = Some(rays as u64);
    row.trace_ms_runs = ms_list(times);
    if times.len() >= 2 {
        let ci = relative_ci(times);
        row.trace_ms_ci = Some(ci);
        row.noisy = Some(ci > target_ci);
    }
    let med = median(times);
    row.trace_ms_min = times.first().copied();
    row.trace_ms_max = times.last().copied();
    row.trace_ms_median = Some(med);
    row.mrays_per_s = Some(rays as f64 / (med * 1e3).max(1e-12));
}

/// The rays of a batch of `n` that a CPU row is timed on under `run.timed_rays = max`, in
/// batch order; `None` when that is every ray (no `max`, or `max >= n`). They are runs of
/// consecutive rays (`max / 16`, between 1 and 1,024: one image row at the papers' 1024
/// wide), evenly spaced over the batch, so that the timed rays keep the coherence their
/// neighbours give them in the whole batch (an even stride of single rays would not) and
/// still see every part of the image; exactly `max` of them.
pub fn timed_indices(n: usize, max: Option<usize>) -> Option<Vec<usize>> {
    let m = max.filter(|&m| m < n)?;
    let run = (m / 16).clamp(1, 1024);
    let runs = n.div_ceil(run);
    let take = m.div_ceil(run);
    let mut out = Vec::with_capacity(m + run);
    for i in 0..take {
        let start = i * runs / take * run;
        out.extend(start..(start + run).min(n));
    }
    out.truncate(m);
    Some(out)
}

/// How many rays [`timed_indices`] times of a batch of `n`.
pub fn timed_count(n: usize, max: Option<usize>) -> usize {
    max.map_or(n, |m| m.min(n))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_and_columns() {
        assert_eq!(median(&mut [3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&mut [4.0, 1.0, 2.0, 3.0]), 2.5);
        let mut row = Row::default();
        fill(&mut row, &mut [2.0, 1.0, 4.0], 1000, 0.05);
        assert_eq!(row.trace_ms_min, Some(1.0));
        assert_eq!(row.trace_ms_max, Some(4.0));
        assert_eq!(row.mrays_per_s, Some(0.5));
        assert_eq!(row.trace_ms_ci, Some(0.75));
        assert_eq!((row.noisy, row.timed_runs), (Some(true), Some(3)));
        let mut one = Row::default();
        fill(&mut one, &mut [2.0], 1000, 0.05);
        assert_eq!((one.trace_ms_ci, one.noisy), (None, None));
        assert_eq!(one.timed_rays, Some(1000));
    }

    #[test]
    fn the_timed_share_and_the_timed_rays_cap_together() {
        let plan = |rays: Option<usize>, share: Option<f64>| TimingPlan {
            warmup: 0,
            repeat: 1,
            max_repeat: 1,
            target_ci: 0.05,
            max_row_seconds: 1.0,
            clock: Clock::Wall,
            timed_rays: rays,
            timed_share: share,
        };
        assert_eq!(plan(None, None).timed_max(1000), None);
        assert_eq!(plan(Some(300), None).timed_max(1000), Some(300));
        assert_eq!(plan(None, Some(0.25)).timed_max(1000), Some(250));
        // Rounded up, never below one ray, never above the batch.
        assert_eq!(plan(None, Some(0.25)).timed_max(1001), Some(251));
        assert_eq!(plan(None, Some(1e-9)).timed_max(1000), Some(1));
        assert_eq!(plan(None, Some(1.0)).timed_max(7), Some(7));
        // Both set: the smaller count.
        assert_eq!(plan(Some(300), Some(0.25)).timed_max(1000), Some(250));
        assert_eq!(plan(Some(200), Some(0.25)).timed_max(1000), Some(200));
    }

    #[test]
    fn timed_rays_are_evenly_spaced_runs_of_neighbours() {
        assert_eq!(timed_indices(100, None), None);
        assert_eq!(timed_indices(100, Some(100)), None);
        assert_eq!(timed_indices(100, Some(1000)), None);
        assert_eq!(timed_count(100, Some(1000)), 100);
        // 1024 x 1024 primary rays timed on 65,536: 64 image rows of 1,024, every 16th.
        let n = 1 << 20;
        let idx = timed_indices(n, Some(1 << 16)).unwrap();
        assert_eq!(idx.len(), 1 << 16);
        assert_eq!(idx.len(), timed_count(n, Some(1 << 16)));
        assert_eq!(&idx[..3], &[0, 1, 2]);
        assert_eq!(idx[1024], 16 * 1024);
        assert_eq!(*idx.last().unwrap(), 63 * 16 * 1024 + 1023);
        // Every size: exactly `max` distinct rays, increasing, inside the batch.
        for n in [2usize, 17, 100, 1000, 1030, 4097, 100_003] {
            for m in [1usize, 2, 15, 16, 17, 99, 999, 1029, 4096, 50_000] {
                let Some(idx) = timed_indices(n, Some(m)) else {
                    assert!(m >= n);
                    continue;
                };
                assert_eq!(idx.len(), m, "n {n} max {m}");
                assert!(idx.windows(2).all(|w| w[0] < w[1]), "n {n} max {m}");
                assert!(*idx.last().unwrap() < n);
                // Spread over the batch: from its start into its second half.
                let run = (m / 16).clamp(1, 1024);
                assert_eq!(idx[0], 0);
                assert!(
                    m < 2 || *idx.last().unwrap() + run >= n / 2,
                    "n {n} max {m}"
                );
            }
        }
    }

    #[test]
    fn interleaved_rounds_pair_the_rows_and_stop_on_the_ratio() {
        let plan = TimingPlan {
            warmup: 1,
            repeat: 3,
            max_repeat: 40,
            target_ci: 0.01,
            max_row_seconds: 60.0,
            clock: Clock::Wall,
            timed_rays: None,
            timed_share: None,
        };
        // Row 1 always takes twice row 0's time, under a drift that changes both alike:
        // the ratio is exact from the first rounds, so the minimum of rounds is enough.
        let mut calls = Vec::new();
        let t = plan
            .run_interleaved(2, |i| -> Result<f64, ()> {
                let round = calls.len() / 2;
                calls.push(i);
                Ok((1.0 + round as f64) * (i + 1) as f64)
            })
            .unwrap();
        assert_eq!(calls[..6], [0, 1, 0, 1, 0, 1]);
        assert_eq!(t[0].len(), 3);
        assert_eq!(t[1].len(), 3);
        assert_eq!(widest_pair_ci(&t), 0.0);
        // A ratio that keeps changing runs to max_repeat.
        let mut k = 0u32;
        let t = plan
            .run_interleaved(2, |i| -> Result<f64, ()> {
                k += 1;
                Ok(if i == 0 { 1.0 } else { 1.0 + (k % 7) as f64 })
            })
            .unwrap();
        assert_eq!(t[0].len(), 40);
    }

    /// The thread clock counts the thread's work, not the time it waits: a sleep costs wall
    /// time and next to no CPU time.
    #[cfg(unix)]
    #[test]
    fn the_thread_clock_leaves_out_waiting() {
        let nap = || std::thread::sleep(std::time::Duration::from_millis(30));
        let (wall, ()) = timed(Clock::Wall, nap);
        let (cpu, ()) = timed(Clock::Thread, nap);
        assert!(wall >= 30.0, "{wall}");
        assert!(cpu < 10.0, "{cpu}");
        // Work is counted alike.
        let spin = || {
            let t = Instant::now();
            let mut x = 0u64;
            while t.elapsed().as_millis() < 20 {
                x = std::hint::black_box(x.wrapping_add(1));
            }
        };
        let (cpu, ()) = timed(Clock::Thread, spin);
        assert!(cpu >= 5.0, "{cpu}");
        assert_eq!(Clock::from_name("thread"), Some(Clock::Thread));
        assert_eq!(Clock::from_name("cpu"), None);
    }

    #[test]
    fn median_confidence_intervals() {
        // Fewer than 6 values: the whole range.
        assert_eq!(median_ci(&[3.0, 1.0, 2.0]), (1.0, 3.0));
        // 20 values 1..=20: ranks 10 ∓ 4.38 → the 5th and 16th.
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        assert_eq!(median_ci(&v), (5.0, 16.0));
        assert!(relative_ci(&[10.0; 8]) == 0.0);
    }

    #[test]
    fn repeats_until_the_median_is_known_or_the_cap() {
        let plan = TimingPlan {
            warmup: 1,
            repeat: 3,
            max_repeat: 12,
            target_ci: 0.05,
            max_row_seconds: 60.0,
            clock: Clock::Wall,
            timed_rays: None,
            timed_share: None,
        };
        // Steady times: stop at the minimum.
        let mut calls = 0;
        let t = plan
            .run(|| -> Result<f64, ()> {
                calls += 1;
                Ok(10.0)
            })
            .unwrap();
        assert_eq!((t.len(), calls), (3, 4));
        // Alternating 10 and 20: the interval never narrows, so the cap ends it.
        let mut k = 0;
        let t = plan
            .run(|| -> Result<f64, ()> {
                k += 1;
                Ok(if k % 2 == 0 { 10.0 } else { 20.0 })
            })
            .unwrap();
        assert_eq!(t.len(), 12);
        // Without max_repeat above repeat: exactly `repeat` runs, as before.
        let fixed = TimingPlan {
            max_repeat: 3,
            ..plan
        };
        assert_eq!(
            fixed.run(|| -> Result<f64, ()> { Ok(1.0) }).unwrap().len(),
            3
        );
    }
}
