//! The CPU device: a rayon pool per thread count, batches traced by [`tb_core::par`] (the one
//! way a batch is traced on the CPU).

use super::{Device, Job, Outcome};
use crate::experiment::phases::Phases;
use crate::experiment::timing::{timed, Clock};
use crate::experiment::validation::{self, Checked, Sample};
use std::collections::HashMap;
use std::time::Instant;
use tb_core::{HitRecord, Ray, StatsSummary, TriTestKind};
use tb_results::output::{CountedKey, Row};

use tb_core::par::trace_into;
use tb_core::{Answers, Batch};

type Key = (usize, TriTestKind, usize);

/// The CPU: one rayon pool per thread count of the run.
pub struct CpuDevice {
    /// One pool per thread count the rows are timed on.
    pools: Vec<(usize, rayon::ThreadPool)>,
    /// The pool of the untimed passes (counting, validation, the oracle, start hints): every
    /// core (rayon's default: `RAYON_NUM_THREADS` or the machine's cores), or the widest
    /// timed pool where that is wider. Their answers and counters are the same on any number
    /// of threads (each ray is traced alone, in chunks of a fixed size).
    untimed: rayon::ThreadPool,
    /// Validate only (`trace-bench validate`): no counting, no timing.
    validate_only: bool,
    /// Per build: what the counting pass of each (traversal, test, batch) found.
    counted: HashMap<Key, Counted>,
    /// The counting pass's hits on the timed rays of the last key counted.
    reference: Option<(Key, Vec<HitRecord>)>,
    /// The CPU rows of the run's first process (`run --processes`), whose counters the later
    /// processes copy instead of counting again ([`CpuDevice::count_once`]).
    first: HashMap<CountedKey, Row>,
    /// Rows whose counters were copied from the first process.
    pub copied: usize,
    /// Where its time went: `count_s`, `trace_s` and `validate_s` (the runner adds the rest).
    pub phases: Phases,
}

/// The counting pass of one (traversal, test, batch) of a build.
struct Counted {
    stats: StatsSummary,
    hit_rate: f64,
    /// Its hits against the oracle's sample (when the batch is validated).
    checked: Option<Checked>,
}

/// The clock a row of `threads` is timed by: `run.clock` for one thread (the whole trace
/// runs on the pool's one worker, where the clock is read), the wall clock for more.
fn clock_for(clock: Clock, threads: usize) -> Clock {
    if threads == 1 {
        clock
    } else {
        Clock::Wall
    }
}

impl CpuDevice {
    /// Pools for `threads` (each ≥ 1). `Err` when a pool cannot start.
    pub fn new(threads: &[usize], validate_only: bool) -> Result<Self, String> {
        let pools = threads
            .iter()
            .map(|&n| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .map(|p| (n, p))
                    .map_err(|e| format!("cannot start {n} threads: {e}"))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let widest = threads.iter().copied().max().unwrap_or(1);
        let untimed = rayon::ThreadPoolBuilder::new()
            .num_threads(widest.max(rayon::current_num_threads()))
            .build()
            .map_err(|e| format!("cannot start the untimed passes' threads: {e}"))?;
        Ok(CpuDevice {
            pools,
            untimed,
            validate_only,
            counted: HashMap::new(),
            reference: None,
            first: HashMap::new(),
            copied: 0,
            phases: Phases::default(),
        })
    }

    /// The pool the untimed passes run on (counting, validation, the oracle, start hints):
    /// every core, whatever thread counts the rows are timed on.
    pub fn untimed(&self) -> &rayon::ThreadPool {
        &self.untimed
    }

    /// Count once across a run's processes: `rows`, the CPU rows of its first process (same
    /// binary, same config: the counters are deterministic), give the later processes'
    /// counters and hit rates. Such a row is not counted again over its whole batch; its
    /// oracle sample is traced (by the timed code) and checked, and it is timed as before.
    pub fn count_once(&mut self, rows: Vec<Row>) {
        self.first = rows
            .into_iter()
            .filter(|r| r.device == "cpu" && r.hit_rate.is_some())
            .map(|r| (r.counted_key(), r))
            .collect();
    }

    fn pool(&self, threads: usize) -> &rayon::ThreadPool {
        &self
            .pools
            .iter()
            .find(|(n, _)| *n == threads)
            .expect("a pool per thread count")
            .1
    }
}

impl CpuDevice {
    /// Time `jobs` (rows of one batch, triangle test and thread count, of one or several
    /// builds) interleaved under `plan`: [`crate::experiment::timing::TimingPlan::run_interleaved`],
    /// counters compiled out, each with its own start hints, on the timed rays
    /// (`run.timed_rays`). Each job's times in round order.
    pub fn time_interleaved(
        &self,
        jobs: &[Job],
        plan: &crate::experiment::timing::TimingPlan,
    ) -> Vec<Vec<f64>> {
        let hints: Vec<_> = jobs
            .iter()
            .map(|j| {
                self.untimed().install(|| {
                    j.accel
                        .batch_hints(j.traversal, j.batch.query, &j.batch.rays)
                })
            })
            .collect();
        let subsets: Vec<Timed> = jobs
            .iter()
            .zip(&hints)
            .map(|(j, h)| {
                Timed::of(
                    j,
                    &j.batch.rays,
                    h.as_deref(),
                    plan.timed_max(j.batch.rays.len()),
                    self.untimed(),
                )
            })
            .collect();
        let mut hits: Vec<Vec<HitRecord>> = subsets
            .iter()
            .map(|t| vec![HitRecord::MISS; t.rays().len()])
            .collect();
        let r: Result<_, ()> = plan.run_interleaved(jobs.len(), |i| {
            let j = &jobs[i];
            let (rays, hints) = (subsets[i].rays(), subsets[i].hints());
            let batch = Batch::new(j.batch.query, j.tri, rays).with_hints(hints);
            let pool = self.pool(j.threads);
            let clock = clock_for(plan.clock, j.threads);
            let (ms, ()) = pool.install(|| {
                timed(clock, || {
                    trace_into(j.accel, j.traversal, batch, Answers::hits(&mut hits[i]))
                })
            });
            Ok(ms)
        });
        r.unwrap_or_default()
    }
}

impl Device for CpuDevice {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn begin_build(&mut self) {
        self.counted.clear();
        self.reference = None;
    }

    fn measure(
        &mut self,
        job: &Job,
        sample: Option<&Sample>,
        row: &mut Row,
    ) -> Result<Outcome, String> {
        if let Some(walk) = job.info.cpu_as {
            return Ok(Outcome::Unsupported(format!(
                "on the CPU {} is `{walk}`'s walk: see that traversal's rows",
                job.info.name
            )));
        }
        let (accel, ti, tri, b) = (job.accel, job.traversal, job.tri, job.batch);
        let start = Instant::now();
        if self.validate_only {
            let checked = sample.map(|s| self.check_sample(job, s));
            self.phases.validate_s += start.elapsed().as_secs_f64();
            return Ok(Outcome::Measured(checked));
        }
        if let Some(first) = self.first.get(&row.counted_key()) {
            row.copy_counters(first);
            self.copied += 1;
            return self.measure_copied(job, sample, row);
        }
        // Start hints (sparse boxes' start nodes): found once per batch, never timed; the
        // counting and the timed passes read the same ones.
        let hints = self
            .untimed()
            .install(|| accel.batch_hints(ti, b.query, &b.rays));
        let subset = Timed::of(
            job,
            &b.rays,
            hints.as_deref(),
            job.timing.timed_max(b.rays.len()),
            self.untimed(),
        );
        let key = (ti, tri, job.batch_index);
        self.count(job, hints.as_deref(), &subset, sample);
        let counted = &self.counted[&key];
        row.hit_rate = Some(counted.hit_rate);
        row.set_counters(&counted.stats, job.info.counters);
        if job.info.step_cap {
            row.capped_rays = Some(counted.stats.capped);
        }
        // Timing, counters compiled out (one untimed pass of the same code when the row is
        // timed later, interleaved), on the timed rays (`run.timed_rays`, all by default).
        let batch = Batch::new(b.query, tri, subset.rays()).with_hints(subset.hints());
        self.phases.count_s += start.elapsed().as_secs_f64();
        let start = Instant::now();
        let mut hits = vec![HitRecord::MISS; subset.rays().len()];
        if job.time {
            self.time_on(job, batch, &mut hits, row)?;
            self.phases.trace_s += start.elapsed().as_secs_f64();
        } else {
            // Untimed: the timed code's answers, checked below, on every core (the answers do
            // not depend on the number of threads).
            self.untimed()
                .install(|| trace_into(accel, ti, batch, Answers::hits(&mut hits)));
            self.phases.validate_s += start.elapsed().as_secs_f64();
        }
        let start = Instant::now();
        let checked = sample.map(|_| self.checked(job, &subset, &hits));
        self.phases.validate_s += start.elapsed().as_secs_f64();
        Ok(Outcome::Measured(checked))
    }
}

impl CpuDevice {
    /// [`Device::measure`] of a row whose counters came from the run's first process: its
    /// oracle sample traced by the timed code and checked, then timed on its timed rays (when
    /// the row is timed here; interleaved rows are timed later).
    fn measure_copied(
        &mut self,
        job: &Job,
        sample: Option<&Sample>,
        row: &mut Row,
    ) -> Result<Outcome, String> {
        let b = job.batch;
        let start = Instant::now();
        let checked = sample.map(|s| self.check_sample(job, s));
        self.phases.validate_s += start.elapsed().as_secs_f64();
        if !job.time {
            return Ok(Outcome::Measured(checked));
        }
        let start = Instant::now();
        let hints = self
            .untimed()
            .install(|| job.accel.batch_hints(job.traversal, b.query, &b.rays));
        let subset = Timed::of(
            job,
            &b.rays,
            hints.as_deref(),
            job.timing.timed_max(b.rays.len()),
            self.untimed(),
        );
        let batch = Batch::new(b.query, job.tri, subset.rays()).with_hints(subset.hints());
        self.phases.count_s += start.elapsed().as_secs_f64();
        let start = Instant::now();
        let mut hits = vec![HitRecord::MISS; subset.rays().len()];
        self.time_on(job, batch, &mut hits, row)?;
        self.phases.trace_s += start.elapsed().as_secs_f64();
        Ok(Outcome::Measured(checked))
    }

    /// The oracle sample `s` traced by the timed code (counters compiled out) on every core,
    /// checked against the oracle's answers.
    fn check_sample(&self, job: &Job, s: &Sample) -> Checked {
        let (accel, ti, q) = (job.accel, job.traversal, job.batch.query);
        let got = self
            .untimed()
            .install(|| tb_core::par::trace_with_hints(accel, ti, q, job.tri, &s.rays));
        validation::check(q, s, &got, job.max_report)
    }

    /// Time `batch` (the row's timed rays) as `job.timing` says, counters compiled out, on the
    /// row's pool and clock; its hits in `hits`, its times in `row`.
    fn time_on(
        &self,
        job: &Job,
        batch: Batch<'_>,
        hits: &mut [HitRecord],
        row: &mut Row,
    ) -> Result<(), String> {
        let pool = self.pool(job.threads);
        let clock = clock_for(job.timing.clock, job.threads);
        let mut times = job.timing.run(|| -> Result<f64, String> {
            let (ms, ()) = pool.install(|| {
                timed(clock, || {
                    trace_into(job.accel, job.traversal, batch, Answers::hits(hits))
                })
            });
            Ok(ms)
        })?;
        let n = batch.rays.len();
        crate::experiment::timing::fill(row, &mut times, n, job.timing.target_ci);
        Ok(())
    }
}

/// The rays a row is timed on ([`crate::experiment::timing::timed_indices`]): the whole batch,
/// or a subset copied out with its start hints.
struct Timed<'a> {
    all: &'a [Ray],
    all_hints: Option<&'a [u32]>,
    subset: Option<Subset>,
}

/// A subset of a batch: the rays' indices in the batch, the rays and their start hints.
type Subset = (Vec<usize>, Vec<Ray>, Option<Vec<u32>>);

impl<'a> Timed<'a> {
    /// The timed rays of `rays` under `max`, with start hints for them: `hints` (the whole
    /// batch's) when they are every ray, else found again for the subset (hints may belong to
    /// a batch as a whole, e.g. multi-kd's arrangement of the rays, found once, never timed).
    fn of(
        job: &Job,
        rays: &'a [Ray],
        hints: Option<&'a [u32]>,
        max: Option<usize>,
        pool: &rayon::ThreadPool,
    ) -> Self {
        let subset = crate::experiment::timing::timed_indices(rays.len(), max).map(|idx| {
            let r: Vec<Ray> = idx.iter().map(|&i| rays[i]).collect();
            let h = hints.and_then(|_| {
                pool.install(|| job.accel.batch_hints(job.traversal, job.batch.query, &r))
            });
            (idx, r, h)
        });
        Timed {
            all: rays,
            all_hints: hints,
            subset,
        }
    }

    fn rays(&self) -> &[Ray] {
        self.subset.as_ref().map_or(self.all, |s| &s.1)
    }

    fn hints(&self) -> Option<&[u32]> {
        match &self.subset {
            Some(s) => s.2.as_deref(),
            None => self.all_hints,
        }
    }

    /// The index in the batch of timed ray `k`.
    fn index(&self, k: usize) -> usize {
        self.subset.as_ref().map_or(k, |s| s.0[k])
    }

    /// `all[i]` for each timed ray.
    fn pick<T: Copy>(&self, all: &[T]) -> Vec<T> {
        match &self.subset {
            Some(s) => s.0.iter().map(|&i| all[i]).collect(),
            None => all.to_vec(),
        }
    }
}

impl CpuDevice {
    /// The counting pass of `job`'s (traversal, test, batch), over the whole batch, once per
    /// build: its counters and hit rate, its hits validated against the oracle's `sample`,
    /// and its hits on the timed rays, which every timed pass of the key must repeat (kept
    /// for the last key counted: a build's rows of one key come one after another, and a
    /// key met again is counted again, deterministically the same).
    fn count(&mut self, job: &Job, hints: Option<&[u32]>, subset: &Timed, sample: Option<&Sample>) {
        let (accel, ti, tri, b) = (job.accel, job.traversal, job.tri, job.batch);
        let key = (ti, tri, job.batch_index);
        if self.counted.contains_key(&key) && self.reference.as_ref().is_some_and(|r| r.0 == key) {
            return;
        }
        let batch = Batch::new(b.query, tri, &b.rays).with_hints(hints);
        let (hits, stats) = self.untimed().install(|| {
            let mut hits = vec![HitRecord::MISS; b.rays.len()];
            let mut stats = vec![tb_core::TraversalStats::default(); b.rays.len()];
            trace_into(accel, ti, batch, Answers::new(&mut hits, Some(&mut stats)));
            (hits, stats)
        });
        self.counted.entry(key).or_insert_with(|| Counted {
            stats: StatsSummary::from_stats(&stats),
            hit_rate: validation::hit_rate(&hits),
            checked: sample.map(|s| {
                let got: Vec<HitRecord> = s.idx.iter().map(|&i| hits[i]).collect();
                validation::check(b.query, s, &got, job.max_report)
            }),
        });
        self.reference = Some((key, subset.pick(&hits)));
    }

    /// The row's validation: the counting pass's against the oracle (its first mismatches
    /// reported by the key's first row, later rows keep the counts), plus every timed ray
    /// whose answer differs from the counting pass's.
    fn checked(&mut self, job: &Job, subset: &Timed, hits: &[HitRecord]) -> Checked {
        let key = (job.traversal, job.tri, job.batch_index);
        let c = self
            .counted
            .get_mut(&key)
            .and_then(|c| c.checked.as_mut())
            .expect("a key validated when counted");
        let mut out = Checked {
            first: std::mem::take(&mut c.first),
            ..c.clone()
        };
        let reference = &self.reference.as_ref().expect("counted just before").1;
        for (k, (e, g)) in reference.iter().zip(hits).enumerate() {
            let ray = &subset.rays()[k];
            if let Some(kind) = tb_core::compare::compare(job.batch.query, ray, e, g) {
                out.mismatches += 1;
                if out.first.len() < job.max_report {
                    out.first.push(tb_core::compare::Mismatch {
                        index: subset.index(k),
                        ray: *ray,
                        expected: *e,
                        got: *g,
                        kind,
                    });
                }
            }
        }
        out
    }
}
