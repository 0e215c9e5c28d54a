//! `run.interleave`: a view's builds made first and kept, then their rows timed together round
//! by round (CPU rows per view x batch x triangle test x thread count, GPU rows per batch),
//! so that a slow spell of the machine falls on every row of a round alike.

use super::*;

impl Run<'_> {
    /// `run.interleave`: every build of the table is made first and kept, its GPU rows
    /// measured and its CPU rows counted and validated as it is built; then the CPU rows of
    /// each view x batch x triangle test x thread count are timed together, round by round
    /// ([`Run::time_interleaved`]), and the table's rows are written in the usual order.
    pub(super) fn scene_interleaved(
        &mut self,
        g: &Group,
        tris: &Arc<[Triangle]>,
        oracle: &mut Oracle,
    ) -> Result<(), HarnessError> {
        let exp = self.exp;
        let first = &g.views[0];
        if let Some(gpu) = self.gpu.as_mut() {
            gpu.keep_builds(true);
        }
        let mut builds: Vec<(&StructureSpec, Built)> = Vec::new();
        let mut rows: Vec<PendingRow> = Vec::new();
        for (si, st) in exp.structures.iter().enumerate() {
            for (pi, params) in st.param_sets.iter().enumerate() {
                if exp
                    .shard
                    .as_ref()
                    .is_some_and(|p| !p.runs(&first.table, si, pi))
                {
                    continue;
                }
                let params_s = params.to_string();
                let todo = self.todo(g, st, &params_s);
                if todo.iter().all(Vec::is_empty) {
                    continue;
                }
                let Some(built) = self.build_or_fail(g, tris, st, params, &todo)? else {
                    continue;
                };
                for (vi, (spec, t)) in g.views.iter().zip(todo).enumerate() {
                    if t.is_empty() {
                        continue;
                    }
                    let src = self.view_source(spec, g.batches, tris, st, &built, &params_s)?;
                    for c in t {
                        let row = self.measure_row(&src, oracle, c, false)?;
                        let awaits = row.hit_rate.is_some();
                        rows.push((row, awaits.then_some((builds.len(), vi, c))));
                    }
                }
                builds.push((st, built));
            }
        }
        self.time_interleaved(g, &builds, &mut rows);
        if let Some(gpu) = self.gpu.as_mut() {
            gpu.keep_builds(false);
        }
        for (row, _) in rows {
            self.emit(row)?;
        }
        Ok(())
    }

    /// Time the rows awaiting it, per view x batch x triangle test x thread count, round by
    /// round over every build ([`CpuDevice::time_interleaved`]); each group's rows share a
    /// `timing_group` id and its `cpu_others`.
    pub(super) fn time_interleaved(
        &mut self,
        g: &Group,
        builds: &[(&StructureSpec, Built)],
        rows: &mut [PendingRow],
    ) {
        type GroupKey = (usize, usize, tb_core::TriTestKind, usize, DeviceKind);
        let mut groups: Vec<(GroupKey, Vec<usize>)> = Vec::new();
        for (i, (_, w)) in rows.iter().enumerate() {
            if let Some((_, vi, c)) = w {
                let key = (*vi, c.bi, c.tri, c.threads, c.dev);
                match groups.iter_mut().find(|(k, _)| *k == key) {
                    Some((_, v)) => v.push(i),
                    None => groups.push((key, vec![i])),
                }
            }
        }
        let stamp = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let plan = self.exp.run.timing;
        for (k, ((vi, bi, tri, threads, dev), idx)) in groups.iter().enumerate() {
            let b = &g.batches[*bi];
            self.progress.step(&format!(
                "{}: timing {} rows interleaved ({} {} {threads}t)",
                g.views[*vi].label,
                idx.len(),
                b.name,
                tri.name()
            ));
            let jobs: Vec<Job> = idx
                .iter()
                .map(|&i| {
                    let (bn, _, c) = rows[i].1.expect("grouped rows await timing");
                    let (st, built) = &builds[bn];
                    Job {
                        accel: built.accel.as_ref(),
                        traversal: c.ti,
                        info: st.infos[c.ti],
                        tri: c.tri,
                        batch_index: c.bi,
                        batch: b,
                        threads: c.threads,
                        timing: plan,
                        time: true,
                        max_report: self.opts.max_report,
                    }
                })
                .collect();
            // Rounds pair within a group, never across processes.
            let tg = match self.exp.process {
                Some(p) => format!("{}-{stamp}-p{}-{k}", g.views[0].table, p.index),
                None => format!("{}-{stamp}-{k}", g.views[0].table),
            };
            let before = crate::experiment::timing::CpuSample::now();
            let timing = Instant::now();
            if *dev == DeviceKind::Gpu {
                self.time_gpu_interleaved(&jobs, &plan, idx, rows, before, tg);
                self.phases.gpu_s += timing.elapsed().as_secs_f64();
                continue;
            }
            let times = self.cpu.time_interleaved(&jobs, &plan);
            self.phases.trace_s += timing.elapsed().as_secs_f64();
            let others = before
                .zip(crate::experiment::timing::CpuSample::now())
                .and_then(|(a, b)| b.others_since(&a));
            for (j, &i) in idx.iter().enumerate() {
                let row = &mut rows[i].0;
                let mut t = times.get(j).cloned().unwrap_or_default();
                if t.is_empty() {
                    continue;
                }
                let n = crate::experiment::timing::timed_count(
                    b.rays.len(),
                    plan.timed_max(b.rays.len()),
                );
                crate::experiment::timing::fill(row, &mut t, n, plan.target_ci);
                row.timing_group = tg.clone();
                row.cpu_others = others;
                self.note_load(row);
            }
        }
    }

    /// [`Run::time_interleaved`]'s GPU groups ([`GpuDevice::time_interleaved`]): a failure
    /// leaves the rows untimed, said once as other GPU failures are.
    pub(super) fn time_gpu_interleaved(
        &mut self,
        jobs: &[Job],
        plan: &crate::experiment::timing::TimingPlan,
        idx: &[usize],
        rows: &mut [PendingRow],
        before: Option<crate::experiment::timing::CpuSample>,
        timing_group: String,
    ) {
        let Some(gpu) = self.gpu.as_mut() else {
            return;
        };
        let mut group: Vec<&mut Row> = Vec::with_capacity(idx.len());
        for (i, (row, _)) in rows.iter_mut().enumerate() {
            if idx.contains(&i) {
                group.push(row);
            }
        }
        // `idx` is increasing, so `group` is in the jobs' order.
        let r = gpu.time_interleaved(jobs, plan, &mut group);
        let others = before
            .zip(crate::experiment::timing::CpuSample::now())
            .and_then(|(a, b)| b.others_since(&a));
        match r {
            Ok(()) => {
                for row in group {
                    row.timing_group = timing_group.clone();
                    row.cpu_others = others;
                }
                for &i in idx {
                    let mut row = std::mem::take(&mut rows[i].0);
                    self.note_load(&mut row);
                    rows[i].0 = row;
                }
            }
            Err(e) => {
                drop(group);
                self.gpu_failure(&e);
                for &i in idx {
                    rows[i].0.note = format!("gpu failed: {e}");
                }
            }
        }
    }
}
