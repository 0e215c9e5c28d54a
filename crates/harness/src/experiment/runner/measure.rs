//! Measuring one row of a build: the oracle sample, the device's timed and counted passes,
//! the comparison with the oracle, and the report of the first rays that mismatch.

use super::*;

/// What the rows of one build are measured from ([`Run::measure_row`]): the scene table and
/// view, its ray batches, the structure table, the build and the row its rows start from.
pub(super) struct RowSource<'a> {
    pub(super) spec: &'a SceneSpec,
    pub(super) batches: &'a [RayBatch],
    pub(super) st: &'a StructureSpec,
    pub(super) built: &'a Built,
    pub(super) base: Row,
}

impl Run<'_> {
    /// The source of the rows of build `built` on view `spec` (its base row from `tris`,
    /// `st` and `params_s`), after the build's heat maps and renders for that view.
    pub(super) fn view_source<'a>(
        &mut self,
        spec: &'a SceneSpec,
        batches: &'a [RayBatch],
        tris: &Arc<[Triangle]>,
        st: &'a StructureSpec,
        built: &'a Built,
        params_s: &str,
    ) -> Result<RowSource<'a>, HarnessError> {
        self.after_build(spec, st, built, params_s)?;
        Ok(RowSource {
            spec,
            batches,
            st,
            built,
            base: base_row(spec, tris, st, params_s),
        })
    }
}

impl Run<'_> {
    /// Measure one row of `src` (`time`: time it too; else count and validate only, for
    /// [`Run::time_interleaved`]).
    pub(super) fn measure_row(
        &mut self,
        src: &RowSource<'_>,
        oracle: &mut Oracle,
        c: Combo,
        time: bool,
    ) -> Result<Row, HarnessError> {
        let RowSource {
            spec,
            batches,
            st,
            built,
            base,
        } = src;
        let b = &batches[c.bi];
        let info = st.infos[c.ti];
        let mut row = row_of(base, st, &c, b);
        built.fill(&mut row, c.ti);
        if let Some(own) = info.own_triangle_test {
            row.note = format!("uses its own triangle test ({own})");
        }
        if let Some(why) = &b.skipped {
            row.note = why.clone();
            return Ok(row);
        }
        self.progress.step(&format!(
            "{} {} {} {} {} {}t",
            spec.label,
            st.family.name,
            info.name,
            c.tri.name(),
            b.name,
            c.threads
        ));
        let oracle_started = Instant::now();
        let sample = (spec.validate != Validate::Off).then(|| {
            let progress = &self.progress;
            let cpu = &self.cpu;
            cpu.untimed().install(|| {
                oracle.sample(c.bi, &b.rays, b.query, spec.validate, |n| {
                    progress.step(&format!("{}: oracle for {} ({n} rays)", spec.label, b.name))
                })
            })
        });
        self.phases.oracle_s += oracle_started.elapsed().as_secs_f64();
        let job = Job {
            accel: built.accel.as_ref(),
            traversal: c.ti,
            info,
            tri: c.tri,
            batch_index: c.bi,
            batch: b,
            threads: c.threads,
            timing: self.exp.run.timing,
            time,
            max_report: self.opts.max_report,
        };
        let device: &mut dyn Device = match c.dev {
            DeviceKind::Cpu => &mut self.cpu,
            DeviceKind::Gpu => self
                .gpu
                .as_mut()
                .expect("the GPU is opened when a device is gpu"),
        };
        let before = crate::experiment::timing::CpuSample::now();
        let measuring = Instant::now();
        let measured = device.measure(&job, sample, &mut row);
        if c.dev == DeviceKind::Gpu {
            self.phases.gpu_s += measuring.elapsed().as_secs_f64();
        }
        row.cpu_others = before
            .zip(crate::experiment::timing::CpuSample::now())
            .and_then(|(a, b)| b.others_since(&a));
        match measured {
            Ok(Outcome::Measured(Some(checked))) => {
                row.validated_rays = Some(checked.validated);
                row.mismatches = Some(checked.mismatches);
                if !checked.first.is_empty() {
                    self.report_mismatches(spec, st, base, &c, b, &checked);
                }
                if checked.mismatches > 0 && must_conform(info, c.tri, &row) {
                    self.summary.wrong_rows.push(wrong_row(&row));
                }
            }
            Ok(Outcome::Measured(None)) => {}
            Ok(Outcome::Unsupported(note)) => row.note = note,
            Err(e) => {
                self.gpu_failure(&e);
                row = row_of(base, st, &c, b);
                row.note = format!("gpu failed: {e}");
            }
        }
        note_all_missed(&mut row, &b.name);
        if row.mrays_per_s.is_some() {
            self.note_load(&mut row);
        }
        Ok(row)
    }

    /// Keep a report of the first rays of a row that mismatch the oracle.
    fn report_mismatches(
        &mut self,
        spec: &SceneSpec,
        st: &StructureSpec,
        base: &Row,
        c: &Combo,
        b: &RayBatch,
        checked: &validation::Checked,
    ) {
        let info = st.infos[c.ti];
        let on = if c.dev == DeviceKind::Gpu { " gpu" } else { "" };
        let head = format!(
            "{} {} [{}] {} {} {}{on}: {} of {} rays mismatch",
            spec.label,
            st.family.name,
            base.params,
            info.name,
            c.tri.name(),
            b.name,
            checked.mismatches,
            checked.validated
        );
        self.summary
            .mismatch_reports
            .push(validation::report(head, &checked.first));
    }
}
