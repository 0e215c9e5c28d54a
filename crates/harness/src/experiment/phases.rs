//! Where a run's wall time went, phase by phase, written to `results.json` as `meta.phases`
//! (summed over the processes of `run --processes K`) and shown per run in `reproduce`'s
//! REPORT.md: what a budget buys, and what the build cache saves.

use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Seconds spent in each phase of a run. `other_s` is the rest of `total_s`: writing rows,
/// progress, heat maps and convergence renders, opening the GPU, the load-average probes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Phases {
    /// Reading, loading and checking the config's scenes.
    pub load_s: f64,
    /// Generating the ray batches (the secondary rays' set-up traces the primary rays).
    pub rays_s: f64,
    /// Building the structures, or loading them from the build cache.
    pub build_s: f64,
    /// The oracle's answers (brute force) for the validated rays.
    pub oracle_s: f64,
    /// The CPU's counting passes (with the start hints of every pass).
    pub count_s: f64,
    /// The CPU's timed passes, warm-ups included (alone or interleaved).
    pub trace_s: f64,
    /// The CPU's untimed passes and the comparisons that validate rows.
    pub validate_s: f64,
    /// Every GPU row: uploads, timed kernels, read-backs, counting kernels.
    pub gpu_s: f64,
    /// The rest of `total_s`.
    pub other_s: f64,
    /// The run's wall time (this session's; `meta.duration_s` adds earlier sessions').
    pub total_s: f64,
}

impl Phases {
    /// These phases with `b`'s added (`other_s` and `total_s` too).
    pub fn add(&mut self, b: &Phases) {
        self.load_s += b.load_s;
        self.rays_s += b.rays_s;
        self.build_s += b.build_s;
        self.oracle_s += b.oracle_s;
        self.count_s += b.count_s;
        self.trace_s += b.trace_s;
        self.validate_s += b.validate_s;
        self.gpu_s += b.gpu_s;
        self.other_s += b.other_s;
        self.total_s += b.total_s;
    }

    /// Close the account of a run that took `total_s`: `other_s` is what the phases leave.
    pub fn close(&mut self, total_s: f64) {
        self.total_s = total_s;
        let named = self.load_s
            + self.rays_s
            + self.build_s
            + self.oracle_s
            + self.count_s
            + self.trace_s
            + self.validate_s
            + self.gpu_s;
        self.other_s = (total_s - named).max(0.0);
    }

    /// As `meta.phases` holds it: every figure rounded to the millisecond.
    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(self).unwrap_or_default();
        if let Some(m) = v.as_object_mut() {
            for x in m.values_mut() {
                if let Some(f) = x.as_f64() {
                    *x = serde_json::json!((f * 1e3).round() / 1e3);
                }
            }
        }
        v
    }
}

/// Run `f`, adding its wall time in seconds to `*into`.
pub fn timed<R>(into: &mut f64, f: impl FnOnce() -> R) -> R {
    let t = Instant::now();
    let r = f();
    *into += t.elapsed().as_secs_f64();
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rest_is_other_and_sums_add_up() {
        let mut p = Phases {
            load_s: 1.0,
            build_s: 2.0,
            trace_s: 3.0,
            ..Phases::default()
        };
        p.close(10.0);
        assert_eq!((p.other_s, p.total_s), (4.0, 10.0));
        let mut sum = p;
        sum.add(&p);
        assert_eq!((sum.build_s, sum.other_s, sum.total_s), (4.0, 8.0, 20.0));
        // A clock that runs past the phases' sum never gives a negative rest.
        p.close(1.0);
        assert_eq!(p.other_s, 0.0);
        let back: Phases = serde_json::from_value(p.to_json()).unwrap();
        assert_eq!(back, p);
        let mut x = 0.0;
        assert_eq!(timed(&mut x, || 7), 7);
        assert!(x >= 0.0);
    }
}
