//! What a run tells about itself at its end: where its time went (`meta.phases`) and what the
//! build cache did for its builds and its oracle (`meta.build_cache`, and the notes).

use super::*;

impl Run<'_> {
    /// The run's phases (its own and the CPU device's, closed at the time since the runner
    /// opened, plus the scenes' load) and the build cache's figures, as `meta.phases` and
    /// `meta.build_cache` hold them.
    pub(super) fn account(&self) -> (Phases, serde_json::Value) {
        let mut p = self.phases;
        p.add(&self.cpu.phases);
        p.close(self.exp.load_s + self.started.elapsed().as_secs_f64());
        let u = &self.cache_use;
        let cache = serde_json::json!({
            "used": self.opts.cache.is_some(),
            "loaded": u.loaded,
            "built": self.builds.saturating_sub(u.loaded),
            "refused": u.notes.len(),
            "stages_loaded": u.stages_loaded,
            "counters_copied": self.cpu.copied,
            "oracle_loaded": u.oracle_loaded,
            "oracle_computed": u.oracle_computed,
        });
        (p, cache)
    }

    /// The build cache's hits and misses, and every entry it refused, as notes.
    pub(super) fn cache_notes(&mut self) {
        if self.cpu.copied > 0 {
            self.summary.notes.push(format!(
                "count once: the counters and hit rates of {} rows copied from the run's first \
                 process (same binary and config; counters are deterministic), their oracle \
                 samples checked here",
                self.cpu.copied
            ));
        }
        let Some(c) = &self.opts.cache else {
            return;
        };
        let u = std::mem::take(&mut self.cache_use);
        if u.loaded + u.saved > 0 || !u.notes.is_empty() {
            let stages = if u.stages_loaded > 0 {
                format!(
                    ", {} built over a first stage loaded from it (the kd-tree under sparse boxes)",
                    u.stages_loaded
                )
            } else {
                String::new()
            };
            self.summary.notes.push(format!(
                "build cache {}: {} structures loaded, {} built and saved{stages} (rows: \
                 build_cached)",
                c.dir().display(),
                u.loaded,
                u.saved
            ));
        }
        if u.oracle_loaded + u.oracle_computed > 0 {
            self.summary.notes.push(format!(
                "oracle answers: {} ray samples loaded from the build cache, {} computed and saved",
                u.oracle_loaded, u.oracle_computed
            ));
        }
        for n in u.notes {
            self.summary.notes.push(format!("build cache: {n}"));
        }
    }
}
