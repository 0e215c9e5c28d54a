//! Sharding a run over several processes or machines (`trace-bench run --shard K/N`, a SLURM
//! job array): a deterministic partition of the run's work units, balanced by an estimate of
//! each unit's cost, decided before any scene is loaded.
//!
//! **A work unit is one scene x one build** (one `[[structure]]` entry x one parameter set) with
//! every row that uses that build: every traversal, triangle test, ray batch, device and thread
//! count. A build is therefore measured once and never repeated in two shards. A scene may be
//! loaded by several shards (each loads it, generates its rays and computes its oracle sample
//! for the builds it runs); that scene-level cost is paid once per shard that needs the scene
//! and the assignment accounts for it. Finer units (one row) would repeat builds; coarser ones
//! (one scene) cannot balance a config of three scenes over four machines.
//!
//! **Cost estimate** (nanoseconds, a rough model of this machine; only ratios matter): a build
//! costs `T log2 T` per repeat, a row `rays x log2 T` per pass (warm-up, timed repeats and the
//! counting pass) divided by its threads, a scene its load (`T`), its ray generation and its
//! brute-force oracle sample (`validated rays x T`). `T` comes from a cheap scan, never a
//! load: the face lines of an OBJ (decompressed as a stream, nothing parsed into memory), the
//! size of a glTF, and the documented triangle formulas of the built-in scenes.
//!
//! **Assignment**: longest processing time first (Graham's LPT): units sorted by cost,
//! descending, ties by their key; each goes to the shard whose load after taking it (with the
//! scene's cost where the shard does not have the scene yet) is lowest, ties to the lowest
//! shard. Costs are integers and the scan is deterministic, so every machine computes the same
//! partition for the same config and binary.

use serde_json::{json, Value};
use std::collections::{BTreeMap, BTreeSet};
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

/// Which shard of how many a run is: `K/N`, `1 <= K <= N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This shard's number, 1-based.
    pub k: usize,
    /// How many shards the run is split into.
    pub n: usize,
}

impl Shard {
    /// Parse `K/N`, or `slurm` (the job array's task, from the environment: [`Shard::slurm`]).
    pub fn parse(s: &str) -> Result<Shard, String> {
        if s == "slurm" {
            return Shard::slurm(&|k| std::env::var(k).ok());
        }
        let (k, n) = s
            .split_once('/')
            .ok_or_else(|| format!("`{s}`: expected K/N (e.g. 2/4) or `slurm`"))?;
        let num = |v: &str| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("`{s}`: `{v}` is not a whole number"))
        };
        let (k, n) = (num(k)?, num(n)?);
        if n == 0 || k == 0 || k > n {
            return Err(format!("`{s}`: K must be in 1..=N and N at least 1"));
        }
        Ok(Shard { k, n })
    }

    /// The shard of a SLURM job array task: `K = (SLURM_ARRAY_TASK_ID - MIN) / STEP + 1`,
    /// `N = SLURM_ARRAY_TASK_COUNT` (or `(MAX - MIN) / STEP + 1`), so `--array=0-3`,
    /// `--array=1-4` and `--array=0-6:2` all give shards 1..=4 of 4. `var` reads the
    /// environment.
    pub fn slurm(var: &dyn Fn(&str) -> Option<String>) -> Result<Shard, String> {
        let get = |k: &str| -> Result<Option<usize>, String> {
            match var(k) {
                None => Ok(None),
                Some(v) => v
                    .trim()
                    .parse::<usize>()
                    .map(Some)
                    .map_err(|_| format!("--shard slurm: {k}={v} is not a whole number")),
            }
        };
        let id = get("SLURM_ARRAY_TASK_ID")?.ok_or(
            "--shard slurm: SLURM_ARRAY_TASK_ID is not set (not a job array task: submit with \
             sbatch --array=1-N)",
        )?;
        let min = get("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        let step = get("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
        let n = match (get("SLURM_ARRAY_TASK_COUNT")?, get("SLURM_ARRAY_TASK_MAX")?) {
            (Some(c), _) => c,
            (None, Some(max)) if max >= min => (max - min) / step + 1,
            _ => {
                return Err("--shard slurm: neither SLURM_ARRAY_TASK_COUNT nor \
                            SLURM_ARRAY_TASK_MAX is set"
                    .into())
            }
        };
        if id < min || (id - min) % step != 0 {
            return Err(format!(
                "--shard slurm: task {id} is not in the array {min}..(step {step})"
            ));
        }
        let k = (id - min) / step + 1;
        if k > n || n == 0 {
            return Err(format!(
                "--shard slurm: task {id} is shard {k} of {n} (an array with gaps? use \
                 --array=1-N)"
            ));
        }
        Ok(Shard { k, n })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

/// What the estimate knows of a scene before loading it.
#[derive(Clone, Debug)]
pub struct SceneEstimate {
    /// The scene table's label, as the rows name it.
    pub label: String,
    /// Estimated triangles (from a scan, see the module doc).
    pub triangles: u64,
    /// Rays of each batch the scene generates.
    pub batch_rays: Vec<u64>,
    /// Rays the oracle traces by brute force, over all batches.
    pub validated_rays: u64,
}

/// What the estimate knows of one build (one structure entry x parameter set).
#[derive(Clone, Debug)]
pub struct BuildEstimate {
    /// Index of the `[[structure]]` entry and of the parameter set.
    pub structure: usize,
    /// Index of the parameter set in the entry's sweep (with `structure`).
    pub param_set: usize,
    /// The structure's registry name.
    pub name: &'static str,
    /// The parameter set, `k=v;k=v`.
    pub params: String,
    /// Traversals x triangle tests of the build's rows per batch and device row.
    pub variants: usize,
}

/// The run settings the estimate uses.
#[derive(Clone, Debug)]
pub struct RunEstimate {
    /// The (device, threads) of each row per batch: `threads = 0` for the GPU.
    pub device_rows: Vec<usize>,
    /// Passes over the rays per row: warm-up, timed repeats and the counting pass.
    pub passes: u64,
    /// Builds per structure x parameter set (`run.build_repeat`).
    pub build_repeat: u64,
}

/// One work unit of the plan.
#[derive(Clone, Debug, PartialEq)]
pub struct Unit {
    /// The scene table's label.
    pub scene: String,
    /// Index of the `[[structure]]` entry.
    pub structure: usize,
    /// Index of the parameter set in the entry's sweep.
    pub param_set: usize,
    /// The structure's registry name.
    pub name: &'static str,
    /// The parameter set, `k=v;k=v`.
    pub params: String,
    /// Rows the unit writes.
    pub rows: usize,
    /// Estimated cost, ns (build and rows; not the scene's own cost).
    pub cost: u64,
    /// The shard (1-based) that runs it.
    pub shard: usize,
}

impl Unit {
    /// `scene structure [params]`, as messages name it.
    pub fn label(&self) -> String {
        format!("{} {} [{}]", self.scene, self.name, self.params)
    }
}

/// The partition of a run: every unit in run order (the unsharded order) with its shard.
#[derive(Clone, Debug)]
pub struct ShardPlan {
    /// The shard this plan is for.
    pub shard: Shard,
    /// Every unit of the run, in run order, each with its shard.
    pub units: Vec<Unit>,
    /// Per scene label: its own cost (load, rays, oracle), ns.
    pub scene_cost: BTreeMap<String, u64>,
}

// Rough costs of this machine, ns (see the module doc).
const NS_LOAD_PER_TRIANGLE: u64 = 400;
const NS_RAYGEN_PER_RAY: u64 = 60;
/// Per ray x triangle of the brute-force oracle (vectorised, on every core).
const NS_ORACLE: f64 = 0.4;
/// Per triangle x log2 T of a build.
const NS_BUILD: u64 = 40;
/// Per ray x log2 T of one pass of a row.
const NS_TRACE: u64 = 25;
/// A GPU row against a one-thread CPU row.
const GPU_SPEEDUP: u64 = 20;

/// log2(x) in 1/1024 steps, integer arithmetic only (the same on every machine).
fn log2_fixed(x: u64) -> u64 {
    let x = x.max(2);
    let e = 63 - x.leading_zeros() as u64;
    // The mantissa's top 10 bits below the leading one interpolate linearly.
    let frac = if e >= 10 {
        (x >> (e - 10)) & 1023
    } else {
        (x << (10 - e)) & 1023
    };
    e * 1024 + frac
}

/// Cost of a scene itself, ns.
fn scene_cost(s: &SceneEstimate) -> u64 {
    let rays: u64 = s.batch_rays.iter().sum();
    s.triangles * NS_LOAD_PER_TRIANGLE
        + rays * NS_RAYGEN_PER_RAY
        + (s.validated_rays as f64 * s.triangles as f64 * NS_ORACLE) as u64
}

/// Cost of one build of `b` on scene `s` with all its rows, ns.
fn unit_cost(s: &SceneEstimate, b: &BuildEstimate, run: &RunEstimate) -> u64 {
    let t = s.triangles.max(2);
    let lg = log2_fixed(t);
    let build = t * lg / 1024 * NS_BUILD * run.build_repeat;
    let rays: u64 = s.batch_rays.iter().sum();
    let per_pass = rays * lg / 1024 * NS_TRACE;
    let rows: u64 = run
        .device_rows
        .iter()
        .map(|&threads| match threads {
            0 => per_pass / GPU_SPEEDUP,
            n => per_pass / n as u64,
        })
        .sum();
    build + rows * run.passes * b.variants as u64
}

/// Partition the units of `scenes` x `builds` over `shard.n` shards (see the module doc).
pub fn plan(
    shard: Shard,
    scenes: &[SceneEstimate],
    builds: &[BuildEstimate],
    run: &RunEstimate,
) -> ShardPlan {
    let mut units = Vec::new();
    for s in scenes {
        for b in builds {
            units.push(Unit {
                scene: s.label.clone(),
                structure: b.structure,
                param_set: b.param_set,
                name: b.name,
                params: b.params.clone(),
                rows: b.variants * s.batch_rays.len() * run.device_rows.len(),
                cost: unit_cost(s, b, run),
                shard: 0,
            });
        }
    }
    let scene_cost: BTreeMap<String, u64> = scenes
        .iter()
        .map(|s| (s.label.clone(), scene_cost(s)))
        .collect();
    // Units with the same key (two entries giving the same parameter set) write the same rows:
    // they go together.
    let mut groups: BTreeMap<(&str, &str, &str), Vec<usize>> = BTreeMap::new();
    for (i, u) in units.iter().enumerate() {
        groups
            .entry((u.scene.as_str(), u.name, u.params.as_str()))
            .or_default()
            .push(i);
    }
    type Group<'a> = (u64, (&'a str, &'a str, &'a str), Vec<usize>);
    let mut order: Vec<Group> = groups
        .into_iter()
        .map(|(key, idx)| (idx.iter().map(|&i| units[i].cost).sum(), key, idx))
        .collect();
    // Most expensive first; ties by key (stable, the BTreeMap's order).
    order.sort_by(|a, b| b.0.cmp(&a.0).then_with(|| a.1.cmp(&b.1)));
    let mut load = vec![0u64; shard.n];
    let mut has: Vec<BTreeSet<&str>> = vec![BTreeSet::new(); shard.n];
    let mut assign = vec![0usize; units.len()];
    for (cost, (scene, _, _), idx) in &order {
        let extra = |j: usize| {
            if has[j].contains(scene) {
                0
            } else {
                scene_cost[*scene]
            }
        };
        let j = (0..shard.n)
            .min_by_key(|&j| (load[j] + cost + extra(j), j))
            .expect("at least one shard");
        load[j] += cost + extra(j);
        has[j].insert(scene);
        for &i in idx {
            assign[i] = j + 1;
        }
    }
    for (u, s) in units.iter_mut().zip(assign) {
        u.shard = s;
    }
    ShardPlan {
        shard,
        units,
        scene_cost,
    }
}

impl ShardPlan {
    /// Whether this shard runs build `param_set` of structure entry `structure` on `scene`.
    pub fn runs(&self, scene: &str, structure: usize, param_set: usize) -> bool {
        self.units.iter().any(|u| {
            u.shard == self.shard.k
                && u.scene == scene
                && u.structure == structure
                && u.param_set == param_set
        })
    }

    /// Whether this shard needs `scene` at all.
    pub fn needs_scene(&self, scene: &str) -> bool {
        self.units
            .iter()
            .any(|u| u.shard == self.shard.k && u.scene == scene)
    }

    /// Estimated cost of shard `k` (1-based), ns: its units and the scenes they need.
    pub fn cost_of(&self, k: usize) -> u64 {
        let mine = self.units.iter().filter(|u| u.shard == k);
        let scenes: BTreeSet<&str> = mine.clone().map(|u| u.scene.as_str()).collect();
        mine.map(|u| u.cost).sum::<u64>() + scenes.iter().map(|s| self.scene_cost[*s]).sum::<u64>()
    }

    /// Rows this shard writes.
    pub fn rows(&self) -> usize {
        self.units
            .iter()
            .filter(|u| u.shard == self.shard.k)
            .map(|u| u.rows)
            .sum()
    }

    /// The scenes left out of this shard, with the shards that run them.
    pub fn left_out(&self) -> Vec<String> {
        let mut by_scene: BTreeMap<&str, BTreeSet<usize>> = BTreeMap::new();
        for u in &self.units {
            by_scene.entry(&u.scene).or_default().insert(u.shard);
        }
        // In run order.
        let mut seen = BTreeSet::new();
        let mut out = Vec::new();
        for u in &self.units {
            if seen.insert(u.scene.as_str()) && !by_scene[u.scene.as_str()].contains(&self.shard.k)
            {
                let shards: Vec<String> = by_scene[u.scene.as_str()]
                    .iter()
                    .map(|s| s.to_string())
                    .collect();
                let s = if shards.len() == 1 { "" } else { "s" };
                out.push(format!("{} (shard{s} {})", u.scene, shards.join(", ")));
            }
        }
        out
    }

    /// `meta.shard` of results.json: this shard, its estimate, and the whole plan (which
    /// `trace-bench merge` checks the shards against).
    pub fn meta(&self) -> Value {
        let secs = |ns: u64| (ns as f64 / 1e6).round() / 1e3;
        let k = self.shard.k;
        let costs: Vec<f64> = (1..=self.shard.n).map(|j| secs(self.cost_of(j))).collect();
        json!({
            "k": k,
            "n": self.shard.n,
            "units": self.units.iter().filter(|u| u.shard == k).count(),
            "rows": self.rows(),
            "cost_est_s": secs(self.cost_of(k)),
            "cost_est_s_all": costs,
            "plan": self.units.iter().map(|u| json!({
                "scene": u.scene,
                "structure": u.name,
                "params": u.params,
                "rows": u.rows,
                "cost_est_s": secs(u.cost),
                "shard": u.shard,
            })).collect::<Vec<_>>(),
        })
    }
}

/// Estimated triangles of scene `source` under `root`, without loading it: built-in scenes from
/// their parameters, OBJ files by counting the triangles of their face lines (a polygon of `v`
/// vertices gives `v - 2`), glTF by size (40 bytes a triangle). `None` when the file cannot be
/// read (the config check reports it).
pub fn triangles_of(source: &str, root: &Path) -> Option<u64> {
    if let Some(spec) = source.strip_prefix("builtin:") {
        return Some(builtin_triangles(spec));
    }
    let p = Path::new(source);
    let path = if p.is_absolute() {
        p.to_path_buf()
    } else {
        root.join(p)
    };
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    let file = std::fs::File::open(&path).ok()?;
    if name.ends_with(".obj.gz") {
        obj_triangles(flate2::read::MultiGzDecoder::new(file))
    } else if name.ends_with(".obj") {
        obj_triangles(file)
    } else {
        let bytes = file.metadata().ok()?.len();
        Some((bytes / 40).max(1))
    }
}

/// Triangles of the face lines of an OBJ stream.
fn obj_triangles(r: impl Read) -> Option<u64> {
    let mut r = BufReader::with_capacity(1 << 16, r);
    let mut line = Vec::new();
    let mut tris = 0u64;
    loop {
        line.clear();
        match r.read_until(b'\n', &mut line) {
            Ok(0) => break,
            Ok(_) => {}
            Err(_) => return None,
        }
        if line.starts_with(b"f ") || line.starts_with(b"f\t") {
            let v = line[2..]
                .split(|c| c.is_ascii_whitespace())
                .filter(|t| !t.is_empty())
                .count() as u64;
            tris += v.saturating_sub(2);
        }
    }
    Some(tris.max(1))
}

/// Triangles of a built-in scene from its parameters: the scene crate's estimate
/// ([`tb_scene::builtin::estimate_triangles`], the formulas and defaults of its listing).
fn builtin_triangles(spec: &str) -> u64 {
    tb_scene::builtin::estimate_triangles(spec)
        .unwrap_or(tb_scene::builtin::STRESS_TRIANGLES_ESTIMATE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shard_specs() {
        assert_eq!(Shard::parse("2/4"), Ok(Shard { k: 2, n: 4 }));
        for bad in ["0/4", "5/4", "1/0", "a/2", "3"] {
            assert!(Shard::parse(bad).is_err(), "{bad}");
        }
        let env = |vars: &'static [(&'static str, &'static str)]| {
            move |k: &str| {
                vars.iter()
                    .find(|(n, _)| *n == k)
                    .map(|(_, v)| v.to_string())
            }
        };
        // --array=0-3 and --array=1-4: shards 1..=4 of 4; --array=0-6:2 likewise.
        let a = env(&[
            ("SLURM_ARRAY_TASK_ID", "0"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "3"),
        ]);
        assert_eq!(Shard::slurm(&a), Ok(Shard { k: 1, n: 4 }));
        let b = env(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ]);
        assert_eq!(Shard::slurm(&b), Ok(Shard { k: 4, n: 4 }));
        let c = env(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "6"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
        ]);
        assert_eq!(Shard::slurm(&c), Ok(Shard { k: 3, n: 4 }));
        assert!(Shard::slurm(&env(&[])).is_err());
    }

    #[test]
    fn log2_in_fixed_point() {
        assert_eq!(log2_fixed(1024), 10 * 1024);
        assert_eq!(log2_fixed(3), 1024 + 512);
        assert!(log2_fixed(1_000_000) / 1024 == 19);
    }

    #[test]
    fn lpt_balances_and_keeps_builds_whole() {
        let scene = |label: &str, triangles| SceneEstimate {
            label: label.into(),
            triangles,
            batch_rays: vec![1 << 16, 1 << 16],
            validated_rays: 1024,
        };
        let scenes = [scene("a", 70_000), scene("b", 75_000), scene("c", 280_000)];
        let builds: Vec<BuildEstimate> = (0..12)
            .map(|i| BuildEstimate {
                structure: i / 3,
                param_set: i % 3,
                name: "rtree",
                params: format!("m={i}"),
                variants: 2,
            })
            .collect();
        let run = RunEstimate {
            device_rows: vec![1],
            passes: 5,
            build_repeat: 1,
        };
        let p = plan(Shard { k: 2, n: 4 }, &scenes, &builds, &run);
        assert_eq!(p.units.len(), 36);
        assert!(p.units.iter().all(|u| (1..=4).contains(&u.shard)));
        let costs: Vec<u64> = (1..=4).map(|k| p.cost_of(k)).collect();
        let (lo, hi) = (costs.iter().min().unwrap(), costs.iter().max().unwrap());
        assert!(*hi as f64 <= 1.5 * *lo as f64, "{costs:?}");
        // The same partition for every shard index (every machine).
        let q = plan(Shard { k: 4, n: 4 }, &scenes, &builds, &run);
        let shards = |p: &ShardPlan| p.units.iter().map(|u| u.shard).collect::<Vec<_>>();
        assert_eq!(shards(&p), shards(&q));
        assert_eq!(
            (1..=4)
                .map(|k| plan(Shard { k, n: 4 }, &scenes, &builds, &run).rows())
                .sum::<usize>(),
            36 * 2 * 2
        );
        // More shards than units: the extra shards are empty.
        let one = plan(Shard { k: 1, n: 40 }, &scenes[..1], &builds[..1], &run);
        assert_eq!(one.units.len(), 1);
        assert_eq!(one.rows(), 4);
    }

    #[test]
    fn builtin_triangle_formulas() {
        assert_eq!(builtin_triangles("cornell"), 32);
        assert_eq!(builtin_triangles("sphereflake"), 65_602);
        assert_eq!(builtin_triangles("teapot-stadium"), 16_256 + 130);
        assert_eq!(builtin_triangles("soup?count=20000&seed=7"), 20_000);
        assert_eq!(builtin_triangles("arena"), 1_399_314);
        assert_eq!(builtin_triangles("hairball"), 2_880_000);
    }
}
