//! The GPU device on its own, with brute force's program (tb-core) and small test programs:
//! empty scenes and batches, dispatch splitting within the adapter's limits, the program
//! contract of `tb_core::gpu` (bindings, meta words, constants, counters) and its refusals,
//! and the prelude's slab and triangle tests against the CPU's on the stress scene of shared
//! edges and vertices. The structures' programs are checked against their CPU traversals by
//! `crates/harness/tests/gpu_oracle.rs` (every registered structure). Without an adapter the
//! tests print a notice and pass, unless `TRACE_BENCH_REQUIRE_GPU=1`, which makes them fail.

use std::borrow::Cow;
use std::path::Path;
use tb_core::{
    Accel, BruteForce, HitRecord, Query, Ray, TraversalStats, TriTestKind, Triangle, Vec3,
};
use tb_gpu::{open_or_skip, Gpu, GpuError, GpuProgram};

fn program(b: &BruteForce) -> GpuProgram<'_> {
    b.gpu_program(0).expect("brute force has a GPU program")
}

fn triangle() -> Triangle {
    Triangle::new(
        Vec3::new(-1.0, -1.0, 1.0),
        Vec3::new(1.0, -1.0, 1.0),
        Vec3::new(0.0, 1.0, 1.0),
    )
}

#[test]
fn empty_scene_and_empty_batch() {
    let Some(gpu) = open_or_skip() else { return };
    let brute = BruteForce::new(&[]);
    let gs = gpu.upload(&program(&brute)).unwrap();
    let rays = [Ray::new(Vec3::ZERO, Vec3::X)];
    for query in [Query::Closest, Query::Any] {
        let (hits, stats) = gpu
            .trace_once(&gs, &rays, query, TriTestKind::Watertight, true)
            .unwrap();
        assert!(!hits[0].is_hit());
        let (_, want) = tb_core::par::count(&brute, 0, query, TriTestKind::Watertight, &rays);
        assert_eq!(stats.unwrap(), want);
        let (hits, _) = gpu
            .trace_once(&gs, &[], query, TriTestKind::Watertight, false)
            .unwrap();
        assert!(hits.is_empty());
    }
}

#[test]
fn batches_split_into_dispatches_within_limits() {
    let Some(mut gpu) = open_or_skip() else {
        return;
    };
    let n = gpu.max_rays_per_dispatch();
    assert!(n >= 256 && n % 256 == 0, "{n}");
    gpu.limit_dispatch(1000);
    let n = gpu.max_rays_per_dispatch();
    assert_eq!(n, 768);
    let brute = BruteForce::new(&[triangle()]);
    let gs = gpu.upload(&program(&brute)).unwrap();
    let rays = vec![Ray::new(Vec3::ZERO, Vec3::Z); 2 * n as usize + 3];
    let r = gpu.upload_rays(&rays).unwrap();
    let t = gpu
        .trace(&gs, &r, Query::Closest, TriTestKind::Watertight, false)
        .unwrap();
    assert_eq!(t.dispatches, 3);
    let (hits, _) = gpu.read_hits(&r).unwrap();
    assert_eq!(hits.len(), rays.len());
    assert!(hits.iter().all(|h| h.prim == 0 && h.t == 1.0));
}

/// A program that echoes what it is bound: its two buffers, the meta words, its own override
/// constant, the prelude's `ANY`, `STACK_SIZE` and triangles, and writes every counter (so
/// their order is checked too).
const ECHO: &str = "
@group(0) @binding(5) var<storage, read> first: array<u32>;
@group(0) @binding(6) var<storage, read> second: array<f32>;
override SCALE: f32 = 0.0;

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    (*st).interior = meta_.counts.x;
    (*st).leaves = meta_.counts.y;
    (*st).prims = meta_.counts.z;
    (*st).boxes = meta_.counts.w;
    (*st).planes = first[2];
    (*st).restarts = first[1];
    (*st).steps = STACK_SIZE;
    (*st).capped = select(0u, 1u, ANY);
    return Hit(second[0] * SCALE, first[0], r.tmax, vertex(1u, 2u).y);
}
";

fn echo<'a>(tris: &'a [Triangle], first: &[u32]) -> GpuProgram<'a> {
    GpuProgram::new("test/echo", ECHO, Cow::Borrowed(tris))
        .buffer(
            "the first test array",
            Cow::Owned(first.iter().flat_map(|w| w.to_ne_bytes()).collect()),
        )
        .buffer(
            "the second test array",
            Cow::Owned(2.5f32.to_ne_bytes().to_vec()),
        )
        .meta([7, 8, 9])
        .stack(5)
        .constant("SCALE", 3.0)
}

#[test]
fn programs_get_their_buffers_meta_and_constants() {
    let Some(gpu) = open_or_skip() else { return };
    let tris = [triangle(), triangle()];
    let gs = gpu.upload(&echo(&tris, &[41, 42, 43])).unwrap();
    assert_eq!(gs.program(), "test/echo");
    assert_eq!(gs.bytes, 2 * 48 + 12 + 4); // three vec4 per triangle
    let rays = [Ray::segment(Vec3::ZERO, Vec3::X, 0.0, 6.0)];
    for query in [Query::Closest, Query::Any] {
        let (hits, stats) = gpu
            .trace_once(&gs, &rays, query, TriTestKind::Watertight, true)
            .unwrap();
        let want = HitRecord {
            t: 7.5,
            prim: 41,
            u: 6.0,
            v: 1.0,
        };
        assert_eq!(hits, [want]);
        let want = TraversalStats {
            interior: 2,
            leaves: 7,
            prims: 8,
            boxes: 9,
            planes: 43,
            restarts: 42,
            steps: 5,
            capped: (query == Query::Any) as u32,
            ..Default::default()
        };
        assert_eq!(stats.unwrap(), [want]);
    }
}

/// Upload `p`, which must be refused: the error (printed).
fn refusal(gpu: &Gpu, p: &GpuProgram<'_>) -> GpuError {
    let Err(e) = gpu.upload(p) else {
        panic!("{} was accepted", p.name)
    };
    println!("refused: {e}");
    e
}

#[test]
fn malformed_programs_are_refused() {
    let Some(gpu) = open_or_skip() else { return };
    let tris = [triangle()];
    let mut p = echo(&tris, &[1, 2]);
    p.buffers[1].bytes = Cow::Owned(vec![0; 3]);
    let e = refusal(&gpu, &p);
    assert!(
        matches!(&e, GpuError::Program(m) if m.contains("the second test array")),
        "{e}"
    );

    // WGSL that does not compile is reported and not cached: the same name then compiles.
    let mut p = echo(&tris, &[1, 2]);
    p.source = "fn walk(r: Ray, st: ptr<function, Stats>) -> Hit { return nonsense; }";
    let e = refusal(&gpu, &p);
    assert!(
        matches!(&e, GpuError::Program(m) if m.contains("test/echo")),
        "{e}"
    );
    gpu.upload(&echo(&tris, &[1, 2])).unwrap();

    // A name is one program: other code under it is refused.
    let mut p = echo(&tris, &[1, 2]);
    p.stack_size = 6;
    let e = refusal(&gpu, &p);
    assert!(
        matches!(&e, GpuError::Program(m) if m.contains("unique")),
        "{e}"
    );
}

#[test]
fn f64_programs_are_refused_without_shader_f64() {
    let Some(mut gpu) = open_or_skip() else {
        return;
    };
    let tris = [triangle()];
    let mut p = echo(&tris, &[1, 2]);
    p.needs_f64 = true;
    if gpu.adapter().f64 {
        gpu.upload(&p).unwrap();
        gpu.forgo_f64();
    }
    let e = refusal(&gpu, &p);
    assert!(
        matches!(&e, GpuError::Unsupported(m) if m.contains("test/echo") && m.contains("SHADER_F64")),
        "{e}"
    );
    // A program without f64 still runs.
    p.needs_f64 = false;
    gpu.upload(&p).unwrap();
}

#[test]
fn unrolled_loops_are_refused_beyond_llvmpipes_limit() {
    let Some(gpu) = open_or_skip() else { return };
    if !gpu.adapter().driver.contains("llvmpipe") {
        println!("skipped: not llvmpipe");
        return;
    }
    let brute = BruteForce::new(&vec![triangle(); 8 * 65_000 + 1]);
    let e = refusal(&gpu, &program(&brute));
    assert!(
        matches!(&e, GpuError::Unsupported(m) if m.contains("at most 520000")),
        "{e}"
    );
}

/// The prelude's slab and triangle tests repeat tb-core's bit for bit where the adapter has
/// `SHADER_F64` (watertight test; see docs/GPU.md): brute force on the stress
/// scene whose rays aim at shared edges and vertices, plus random rays.
#[test]
fn prelude_matches_the_cpu_on_shared_edges() {
    let Some(gpu) = open_or_skip() else { return };
    let scene = tb_scene::load("builtin:stress/watertight", Path::new(".")).unwrap();
    let brute = BruteForce::new(&scene.triangles);
    let gs = gpu.upload(&program(&brute)).unwrap();
    let mut rays = scene.own_rays.clone();
    rays.extend(tb_scene::rays::random(&scene.bounds, 2000, 11));
    let tri = TriTestKind::Watertight;
    for query in [Query::Closest, Query::Any] {
        let (want_hits, want_stats) = tb_core::par::count(&brute, 0, query, tri, &rays);
        let (hits, stats) = gpu.trace_once(&gs, &rays, query, tri, true).unwrap();
        let stats = stats.unwrap();
        let hit_diffs = (0..rays.len()).filter(|&i| hits[i] != want_hits[i]).count();
        let stat_diffs = (0..rays.len())
            .filter(|&i| stats[i] != want_stats[i])
            .count();
        println!(
            "{query:?}: {} rays, {} hits, hit diffs {hit_diffs}, counter diffs {stat_diffs}",
            rays.len(),
            hits.iter().filter(|h| h.is_hit()).count()
        );
        if gpu.adapter().f64 {
            assert_eq!((hit_diffs, stat_diffs), (0, 0));
        }
    }
}

/// A program with a ray key: ray `i` is `origin = (c, i, 0)`, its key `table[c]` (a program
/// buffer, so `ray_key` reads the program's own data; values at or over `keys` clamp); `walk`
/// answers with the ray's own number and counts it, so a hit or counter written at another
/// ray's place shows.
const KEYED: &str = "
@group(0) @binding(5) var<storage, read> table: array<u32>;

fn ray_key(r: Ray) -> u32 {
    return table[u32(r.origin.x)];
}

fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    (*st).leaves = u32(r.origin.y);
    return Hit(r.tmax, u32(r.origin.y), r.origin.x, 0.0);
}
";

/// Key table of the keyed test programs: class `c` of a ray has key `KEY_TABLE[c]`.
const KEY_TABLE: [u32; 6] = [2, 0, 1, 2, 7, 1];

fn keyed(name: &'static str, keys: u32) -> GpuProgram<'static> {
    GpuProgram::new(name, KEYED, Cow::Owned(Vec::new()))
        .buffer(
            "the key table",
            Cow::Owned(KEY_TABLE.iter().flat_map(|w| w.to_ne_bytes()).collect()),
        )
        .arranged(tb_gpu::GpuArrange { keys, timed: true })
}

/// `n` rays of pseudo-random classes (0..6, fixed seed): ray `i` at `(class, i, 0)`.
fn keyed_rays(n: usize) -> Vec<Ray> {
    let mut x = 0x9e37_79b9u32;
    (0..n)
        .map(|i| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let c = (x % KEY_TABLE.len() as u32) as f32;
            Ray::segment(Vec3::new(c, i as f32, 0.0), Vec3::X, 0.0, 1.0 + i as f32)
        })
        .collect()
}

/// The CPU's arrangement of `rays` in dispatches of `step`: each dispatch's indices stably
/// sorted by key (clamped to `keys - 1`).
fn cpu_order(rays: &[Ray], keys: u32, step: usize) -> Vec<u32> {
    let key = |r: &Ray| KEY_TABLE[r.origin.x as usize].min(keys - 1);
    let mut order = Vec::new();
    for first in (0..rays.len()).step_by(step) {
        let mut idx: Vec<u32> = (first..rays.len().min(first + step))
            .map(|i| i as u32)
            .collect();
        idx.sort_by_key(|&i| key(&rays[i as usize]));
        order.extend(idx);
    }
    order
}

/// The sort pass of a program with a ray key (Torres et al. 2012 §6's counting sort by tree
/// index, as compute passes): per dispatch, the GPU's permutation is the CPU's stable sort of
/// the same keys (a stable sort is unique), with batches split into several dispatches, sizes
/// not a multiple of the workgroup, a single key, keys clamped, an empty batch; hits and
/// counters come back at the rays' own places, and the sort is timed on its own.
#[test]
fn sort_pass_is_the_stable_counting_sort_per_dispatch() {
    let Some(mut gpu) = open_or_skip() else {
        return;
    };
    let full = gpu.max_rays_per_dispatch() as usize;
    gpu.limit_dispatch(300);
    let step = gpu.max_rays_per_dispatch() as usize;
    assert_eq!(step, 256);
    for (name, keys) in [("test/keyed3", 3), ("test/keyed1", 1), ("test/keyed16", 16)] {
        let gs = gpu.upload(&keyed(name, keys)).unwrap();
        for n in [0, 1, 63, 2 * step + 77, 5 * step] {
            let rays = keyed_rays(n);
            let r = gpu.upload_rays(&rays).unwrap();
            for count in [false, true] {
                let t = gpu
                    .trace(&gs, &r, Query::Closest, TriTestKind::Watertight, count)
                    .unwrap();
                assert!(t.sort_ms.is_some_and(|ms| ms >= 0.0), "{t:?}");
                assert_eq!(t.dispatches as usize, n.div_ceil(step));
                let order = gpu.read_order(&r).unwrap();
                assert_eq!(order, cpu_order(&rays, keys, step), "{name}, {n} rays");
                let (hits, _) = gpu.read_hits(&r).unwrap();
                for (i, h) in hits.iter().enumerate() {
                    assert_eq!((h.prim, h.t), (i as u32, rays[i].tmax), "{name} ray {i}");
                }
                if count {
                    let (stats, _) = gpu.read_stats(&r).unwrap();
                    assert!(stats.iter().enumerate().all(|(i, s)| s.leaves == i as u32));
                }
            }
        }
    }
    // One dispatch of the adapter's own size (more workgroups than the scan's 64 threads).
    let mut gpu = open_or_skip().unwrap();
    gpu.limit_dispatch(full as u64);
    let gs = gpu.upload(&keyed("test/keyed3", 3)).unwrap();
    let rays = keyed_rays(40_000.min(full) + 5);
    let r = gpu.upload_rays(&rays).unwrap();
    gpu.trace(&gs, &r, Query::Any, TriTestKind::Watertight, false)
        .unwrap();
    assert_eq!(gpu.read_order(&r).unwrap(), cpu_order(&rays, 3, full));
}

#[test]
fn programs_without_a_key_have_no_sort() {
    let Some(gpu) = open_or_skip() else { return };
    let brute = BruteForce::new(&[triangle()]);
    let gs = gpu.upload(&program(&brute)).unwrap();
    let r = gpu.upload_rays(&[Ray::new(Vec3::ZERO, Vec3::Z)]).unwrap();
    let t = gpu
        .trace(&gs, &r, Query::Closest, TriTestKind::Watertight, false)
        .unwrap();
    assert_eq!(t.sort_ms, None);
    assert!(gpu.read_order(&r).is_err());
    // Keys out of range are refused.
    for keys in [0, tb_gpu::GpuArrange::MAX_KEYS + 1] {
        let e = refusal(&gpu, &keyed("test/keyed-bad", keys));
        assert!(
            matches!(&e, GpuError::Program(m) if m.contains("ray keys")),
            "{e}"
        );
    }
}

/// A new pipeline's first dispatch may include the driver's shader compilation
/// (567 ms against 0.8 ms on lavapipe), so the first trace of each variant runs one untimed
/// pass first, whatever warm-up the caller asked for; later traces do not.
#[test]
fn first_trace_of_a_variant_is_warmed_up() {
    let Some(gpu) = open_or_skip() else { return };
    let brute = BruteForce::new(&[triangle()]);
    let gs = gpu.upload(&program(&brute)).unwrap();
    let rays = gpu
        .upload_rays(&[Ray::new(Vec3::ZERO, Vec3::Z); 1000])
        .unwrap();
    let tri = TriTestKind::Watertight;
    let mut times = Vec::new();
    for (i, count) in [false, false, false, true, true].into_iter().enumerate() {
        let t = gpu.trace(&gs, &rays, Query::Closest, tri, count).unwrap();
        let first = i == 0 || i == 3;
        // A timed trace's sustained sample adds the pass that sized it.
        let sized = !count && t.passes > 1;
        assert_eq!(t.warm_up_passes, first as u32 + sized as u32, "trace {i}");
        times.push(t.kernel_ms);
    }
    // The first timed pass is not the compiling one: within reach of the later ones (the
    // compilation alone took hundreds of times a pass).
    let later = times[1].max(times[2]);
    assert!(times[0] <= 20.0 * later + 50.0, "{times:?}");
}

/// A timed trace is a sample of back-to-back passes lasting at least the sample's
/// minimum (at most its maximum of passes), `kernel_ms` per pass; the counting trace and
/// `trace_once` run one pass. With a minimum no pass reaches, the sample holds exactly the
/// maximum (no timing is asserted: the count is sized by a measured pass).
#[test]
fn a_timed_trace_is_a_sustained_sample() {
    let Some(mut gpu) = open_or_skip() else {
        return;
    };
    let brute = BruteForce::new(&[triangle()]);
    let gs = gpu.upload(&program(&brute)).unwrap();
    let batch = [Ray::new(Vec3::ZERO, Vec3::Z); 64];
    let rays = gpu.upload_rays(&batch).unwrap();
    let tri = TriTestKind::Watertight;
    // With the defaults the count depends on the adapter's speed: at least one pass.
    let t = gpu.trace(&gs, &rays, Query::Closest, tri, false).unwrap();
    assert!((1..=tb_gpu::MAX_PASSES).contains(&t.passes), "{t:?}");
    gpu.set_timed_sample(1e9, 5);
    let t = gpu.trace(&gs, &rays, Query::Closest, tri, false).unwrap();
    assert_eq!((t.passes, t.warm_up_passes), (5, 1), "{t:?}");
    let c = gpu.trace(&gs, &rays, Query::Closest, tri, true).unwrap();
    assert_eq!(c.passes, 1, "{c:?}");
    // The repeated passes leave the same answers as one.
    let (hits, _) = gpu.read_hits(&rays).unwrap();
    let (one, _) = gpu
        .trace_once(&gs, &batch, Query::Closest, tri, false)
        .unwrap();
    assert_eq!(one, hits);
}

/// The probe does fixed work: its pass count is fixed at the first probe and stays so, and
/// every probe takes a positive time.
#[test]
fn the_probe_does_fixed_work() {
    let Some(gpu) = open_or_skip() else { return };
    assert_eq!(gpu.probe_passes(), 1);
    let first = gpu.probe_ms().unwrap();
    let passes = gpu.probe_passes();
    assert!((1..=tb_gpu::MAX_PASSES).contains(&passes), "{passes}");
    assert!(first > 0.0 && first.is_finite(), "{first}");
    for _ in 0..3 {
        assert!(gpu.probe_ms().unwrap() > 0.0);
        assert_eq!(gpu.probe_passes(), passes);
    }
}

/// A persistent program that records, in each ray's hit, the ray (`t`) and the value of its
/// dispatch's fetch counter when the ray was traced (`u`; tb-gpu's shaders/persistent.wgsl).
const POOLED: &str = "
fn walk(r: Ray, st: ptr<function, Stats>) -> Hit {
    (*st).steps = 1u;
    return Hit(r.tmax, 0u, f32(atomicLoad(&tb_pool)), 0.0);
}
";

/// Persistent threads (`GpuProgram::persistent`): with 3 workgroups per dispatch, each
/// fetches many runs of rays, and every ray is traced by each pass of a sustained sample (the
/// counter it saw lies in the last pass's range of fetches: the counter counts on across the
/// passes of one sample, as the shader assumes) and by the single pass of the counting
/// variant, with its own counter per dispatch chunk.
#[test]
fn persistent_threads_trace_every_ray_in_every_pass() {
    let Some(mut gpu) = open_or_skip() else {
        return;
    };
    gpu.limit_dispatch(1000);
    gpu.set_persistent_groups(3);
    gpu.set_timed_sample(1e9, 5);
    let tris = [triangle()];
    let p = GpuProgram::new("test/pooled", POOLED, Cow::Borrowed(&tris[..])).persistent();
    let gs = gpu.upload(&p).unwrap();
    let batch: Vec<Ray> = (0..2000)
        .map(|i| Ray::segment(Vec3::ZERO, Vec3::X, 0.0, 1.0 + i as f32))
        .collect();
    let rays = gpu.upload_rays(&batch).unwrap();
    let chunk = gpu.max_rays_per_dispatch() as usize;
    assert_eq!(chunk, 768);
    // Fetches per pass of a dispatch of `len` rays: its runs of 64, one more per workgroup.
    let fetches = |i: usize| {
        let first = i / chunk * chunk;
        let runs = (batch.len() - first).min(chunk).div_ceil(64);
        (runs + runs.min(3)) as f32
    };
    let tri = TriTestKind::Watertight;
    for count in [false, true] {
        let t = gpu.trace(&gs, &rays, Query::Closest, tri, count).unwrap();
        assert_eq!(t.dispatches, 3);
        let passes = t.passes as f32;
        assert_eq!(passes, if count { 1.0 } else { 5.0 });
        let (hits, _) = gpu.read_hits(&rays).unwrap();
        for (i, h) in hits.iter().enumerate() {
            assert_eq!(h.t, batch[i].tmax, "ray {i} traced");
            let f = fetches(i);
            let seen = (passes - 1.0) * f..passes * f;
            assert!(
                seen.contains(&h.u),
                "ray {i}: counter {} not in {seen:?}",
                h.u
            );
        }
        if count {
            let (stats, _) = gpu.read_stats(&rays).unwrap();
            assert!(stats.iter().all(|s| s.steps == 1));
        }
    }
}
