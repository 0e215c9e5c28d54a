//! Validation against the brute-force oracle, shared by every device: the sample of a batch
//! that is validated, the oracle's answers for it (computed once per batch and shared by every
//! row), the comparison of a device's answers ([`tb_core::compare`](mod@tb_core::compare)) and the report of the
//! first mismatching rays.

use crate::experiment::cache::BuildCache;
use crate::experiment::config::spec::Validate;
use std::collections::HashMap;
use std::sync::Arc;
use tb_core::compare::{compare, hex_f32, Mismatch};
use tb_core::{BruteForce, HitRecord, Query, Ray, TriTestKind, Triangle};

/// The validated rays of one batch and the oracle's answers for them.
pub struct Sample {
    /// Indices of the validated rays in the batch.
    pub idx: Vec<usize>,
    /// Those rays.
    pub rays: Vec<Ray>,
    /// Brute force's answers (watertight test).
    pub expected: Vec<HitRecord>,
}

/// The oracle of one scene: brute force with the watertight test, the truth for every row (so
/// a Möller–Trumbore row's mismatches include the rays that test lets slip through edges,
/// reported rather than hidden). Answers are computed on first use, per batch.
pub struct Oracle {
    brute: BruteForce,
    samples: HashMap<usize, Sample>,
    /// Where answers computed once are kept for the run's other processes and later runs
    /// ([`crate::experiment::cache::oracle_key`]); `None`: computed every time.
    cache: Option<BuildCache>,
    /// What the cache did: samples whose answers were loaded, computed (and saved), and one
    /// line per entry refused or not saved.
    pub loaded: usize,
    /// Samples whose answers were computed (and saved to the cache).
    pub computed: usize,
    /// One line per cache entry refused or not saved.
    pub notes: Vec<String>,
}

/// Validation outcome of one structure x traversal x triangle test x batch.
#[derive(Clone, Debug)]
pub struct Checked {
    /// Rays compared with the oracle.
    pub validated: u64,
    /// Of them, rays whose answer differs from the oracle's.
    pub mismatches: u64,
    /// The first mismatching rays (at most the run's `max_report`).
    pub first: Vec<Mismatch>,
}

impl Oracle {
    /// The oracle of the scene `tris`, keeping its answers in `cache` where one is given.
    pub fn new(tris: Arc<[Triangle]>, cache: Option<BuildCache>) -> Self {
        Oracle {
            brute: BruteForce::shared(tris),
            samples: HashMap::new(),
            cache,
            loaded: 0,
            computed: 0,
            notes: Vec::new(),
        }
    }

    /// The sample of batch number `bi` (`rays`, asking `query`) under `validate`, with the
    /// oracle's answers; `on_compute` is called before they are computed (progress).
    pub fn sample(
        &mut self,
        bi: usize,
        rays: &[Ray],
        query: Query,
        validate: Validate,
        on_compute: impl FnOnce(usize),
    ) -> &Sample {
        if !self.samples.contains_key(&bi) {
            let idx = sample_indices(validate, rays.len());
            let sub: Vec<Ray> = idx.iter().map(|&i| rays[i]).collect();
            let expected = self.answers(query, &sub, on_compute);
            let s = Sample {
                idx,
                rays: sub,
                expected,
            };
            self.samples.insert(bi, s);
        }
        &self.samples[&bi]
    }

    /// Brute force's answers for `rays`: from the cache where it holds them, else computed
    /// (`on_compute` first) and saved there.
    fn answers(
        &mut self,
        query: Query,
        rays: &[Ray],
        on_compute: impl FnOnce(usize),
    ) -> Vec<HitRecord> {
        let key = self
            .cache
            .as_ref()
            .filter(|_| !rays.is_empty())
            .map(|_| crate::experiment::cache::oracle_key(query, self.brute.triangles(), rays));
        if let (Some(c), Some(k)) = (&self.cache, &key) {
            match c.load_answers(k, rays.len()) {
                Some(Ok(v)) => {
                    self.loaded += 1;
                    return v;
                }
                Some(Err(why)) => self.notes.push(format!("{why}: computed again")),
                None => {}
            }
        }
        on_compute(rays.len());
        let t = std::time::Instant::now();
        let expected = tb_core::par::trace(&self.brute, 0, query, TriTestKind::Watertight, rays);
        self.computed += 1;
        if let (Some(c), Some(k)) = (&self.cache, &key) {
            let ms = t.elapsed().as_secs_f64() * 1e3;
            if let Err(why) = c.store_answers(k, &expected, ms) {
                self.notes.push(format!("oracle answers not saved: {why}"));
            }
        }
        expected
    }
}

/// Indices of the rays validated under `v` (all, or an even stride).
pub fn sample_indices(v: Validate, n: usize) -> Vec<usize> {
    match v {
        Validate::Off => Vec::new(),
        Validate::All => (0..n).collect(),
        Validate::Sample(k) if k >= n => (0..n).collect(),
        Validate::Sample(k) => {
            let step = n.div_ceil(k);
            (0..n).step_by(step).collect()
        }
    }
}

/// The share of `hits` that hit (any hit for any-hit queries).
pub fn hit_rate(hits: &[HitRecord]) -> f64 {
    hits.iter().filter(|h| h.is_hit()).count() as f64 / hits.len().max(1) as f64
}

/// Compare `got[k]`, the device's answer for ray `s.rays[k]`, with the oracle's.
pub fn check(query: Query, s: &Sample, got: &[HitRecord], max_report: usize) -> Checked {
    let mut first = Vec::new();
    let mut n = 0u64;
    for (k, (e, g)) in s.expected.iter().zip(got).enumerate() {
        if let Some(kind) = compare(query, &s.rays[k], e, g) {
            n += 1;
            if first.len() < max_report {
                first.push(Mismatch {
                    index: s.idx[k],
                    ray: s.rays[k],
                    expected: *e,
                    got: *g,
                    kind,
                });
            }
        }
    }
    Checked {
        validated: s.rays.len() as u64,
        mismatches: n,
        first,
    }
}

/// `head` followed by one line per mismatching ray (origin, direction as exact hex floats,
/// expected, got).
pub fn report(head: String, first: &[Mismatch]) -> String {
    let mut rep = head;
    for m in first {
        rep.push_str("\n    ");
        rep.push_str(&fmt_mismatch(m));
    }
    rep
}

fn fmt_mismatch(m: &Mismatch) -> String {
    let r = &m.ray;
    let v = |x: tb_core::Vec3| format!("({}, {}, {})", hex_f32(x.x), hex_f32(x.y), hex_f32(x.z));
    let h = |h: &HitRecord| {
        if h.is_hit() {
            format!("prim {} t {} ({})", h.prim, h.t, hex_f32(h.t))
        } else {
            "miss".to_string()
        }
    };
    format!(
        "ray {}: origin {} dir {} tmin {} tmax {}: expected {}, got {} [{:?}]",
        m.index,
        v(r.origin),
        v(r.dir),
        hex_f32(r.tmin),
        hex_f32(r.tmax),
        h(&m.expected),
        h(&m.got),
        m.kind
    )
}
