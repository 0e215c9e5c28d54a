//! The CPU device: a rayon pool per thread count, batches traced by [`tb_core::par`] (the one
//! way a batch is traced on the CPU).

use super::{Device, Job, Outcome};
use crate::experiment::timing::{timed, Clock};
use crate::experiment::validation::{self, Checked, Sample};
use std::collections::HashMap;
use tb_core::{HitRecord, StatsSummary, TriTestKind};
use tb_results::output::Row;

use tb_core::par::trace_into;
use tb_core::{Answers, Batch};

type Key = (usize, TriTestKind, usize);

/// The CPU: one rayon pool per thread count of the run.
pub struct CpuDevice {
    pools: Vec<(usize, rayon::ThreadPool)>,
    /// Validate only (`trace-bench validate`): no counting, no timing.
    validate_only: bool,
    /// Per build: counters and hit rate per (traversal, test, batch).
    counted: HashMap<Key, (StatsSummary, f64)>,
    /// Per build: validation per (traversal, test, batch).
    checked: HashMap<Key, Checked>,
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
            .collect::<Result<_, _>>()?;
        Ok(CpuDevice {
            pools,
            validate_only,
            counted: HashMap::new(),
            checked: HashMap::new(),
        })
    }

    /// The pool with the most threads (counting, validation and oracle passes run there).
    pub fn widest(&self) -> &rayon::ThreadPool {
        &self
            .pools
            .iter()
            .max_by_key(|(n, _)| *n)
            .expect("at least one pool")
            .1
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
    /// counters compiled out, each with its own start hints. Each job's times in round order.
    pub fn time_interleaved(
        &self,
        jobs: &[Job],
        plan: &crate::experiment::timing::TimingPlan,
    ) -> Vec<Vec<f64>> {
        let hints: Vec<_> = jobs
            .iter()
            .map(|j| {
                self.widest().install(|| {
                    j.accel
                        .batch_hints(j.traversal, j.batch.query, &j.batch.rays)
                })
            })
            .collect();
        let mut hits: Vec<Vec<HitRecord>> = jobs
            .iter()
            .map(|j| vec![HitRecord::MISS; j.batch.rays.len()])
            .collect();
        let r: Result<_, ()> = plan.run_interleaved(jobs.len(), |i| {
            let j = &jobs[i];
            let batch =
                Batch::new(j.batch.query, j.tri, &j.batch.rays).with_hints(hints[i].as_deref());
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
        self.checked.clear();
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
        let key = (ti, tri, job.batch_index);
        if self.validate_only {
            let checked = sample.map(|s| {
                let got = self
                    .widest()
                    .install(|| tb_core::par::trace_with_hints(accel, ti, b.query, tri, &s.rays));
                validation::check(b.query, s, &got, job.max_report)
            });
            return Ok(Outcome::Measured(checked));
        }
        // Start hints (sparse boxes' start nodes): found once per batch, never timed; the
        // counting and the timed passes read the same ones.
        let hints = self
            .widest()
            .install(|| accel.batch_hints(ti, b.query, &b.rays));
        let batch = Batch::new(b.query, tri, &b.rays).with_hints(hints.as_deref());
        // Counting pass: a separate pass, never timed.
        if !self.counted.contains_key(&key) {
            let (hits, stats) = self.widest().install(|| {
                let mut hits = vec![HitRecord::MISS; b.rays.len()];
                let mut stats = vec![tb_core::TraversalStats::default(); b.rays.len()];
                trace_into(accel, ti, batch, Answers::new(&mut hits, Some(&mut stats)));
                (hits, stats)
            });
            self.counted.insert(
                key,
                (
                    StatsSummary::from_stats(&stats),
                    validation::hit_rate(&hits),
                ),
            );
        }
        let (stats, hit_rate) = self.counted[&key];
        row.hit_rate = Some(hit_rate);
        row.set_counters(&stats, job.info.counters);
        if job.info.step_cap {
            row.capped_rays = Some(stats.capped);
        }
        // Timing, counters compiled out (one untimed pass of the same code when the row is
        // timed later, interleaved: its hits are what is validated).
        let pool = self.pool(job.threads);
        let mut hits = vec![HitRecord::MISS; b.rays.len()];
        if job.time {
            let mut times = job.timing.run(|| -> Result<f64, String> {
                let clock = clock_for(job.timing.clock, job.threads);
                let (ms, ()) = pool.install(|| {
                    timed(clock, || {
                        trace_into(accel, ti, batch, Answers::hits(&mut hits))
                    })
                });
                Ok(ms)
            })?;
            crate::experiment::timing::fill(row, &mut times, b.rays.len(), job.timing.target_ci);
        } else {
            pool.install(|| trace_into(accel, ti, batch, Answers::hits(&mut hits)));
        }
        // Validation of what was timed (as on the GPU): the timed pass's hits on the oracle's
        // sample, once per (traversal, test, batch); the report takes the first mismatches
        // once, later rows of the same key keep the counts.
        let checked = sample.map(|s| {
            let c = self.checked.entry(key).or_insert_with(|| {
                let got: Vec<HitRecord> = s.idx.iter().map(|&i| hits[i]).collect();
                validation::check(b.query, s, &got, job.max_report)
            });
            Checked {
                first: std::mem::take(&mut c.first),
                ..c.clone()
            }
        });
        Ok(Outcome::Measured(checked))
    }
}
