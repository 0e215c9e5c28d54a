// The prelude of every trace-bench GPU program (tb_core::gpu states the contract): the common
// bindings, the robust slab test and the two triangle tests, written to round exactly as
// tb-core's Rust code does (same operations in the same order; no builtin dot/cross whose
// evaluation order is unspecified), and the entry point, which calls the program's `walk`.
// The host prepends `const STACK_SIZE` (GpuProgram::stack_size), `const WORKGROUP_SIZE` and
// `struct Stats` with `fn zero_stats()` (tb_core::stats::wgsl_stats_struct: one u32 per
// counter, then `capped`), and appends the watertight test's fallbacks `edge_fallback` and
// `watertight_f64` (shaders/edge_f64.wgsl where the adapter has SHADER_F64, else
// edge_f32.wgsl), `fn ray_index` (shaders/unsorted.wgsl, or shaders/arrange.wgsl for a program
// with a ray key), the program's source and its entry point `main` (shaders/entry.wgsl, or
// shaders/persistent.wgsl for a persistent program).

struct Ray { origin: vec3<f32>, tmin: f32, dir: vec3<f32>, tmax: f32 }   // tb_core::Ray, 32 B
struct Hit { t: f32, prim: u32, u: f32, v: f32 }                          // tb_core::HitRecord
// x: triangles, y, z, w: GpuProgram::meta[0..3] (e.g. the node count).
struct Meta { counts: vec4<u32> }

// Pipeline variants (WGSL override constants, fixed at pipeline creation).
override ANY: bool = false;          // Query::Any (stop at the first hit) vs Query::Closest
override COUNT: bool = false;        // counting pass (TraversalStats) vs timed pass
override WATERTIGHT: bool = true;    // Woop et al. 2013 vs Moller-Trumbore 1997
override EXIT_SCALE: f32 = 1.0;      // tb_core::slab::EXIT_SCALE = 1 + 2 gamma(3), set by the host

@group(0) @binding(0) var<storage, read> rays: array<Ray>;
@group(0) @binding(1) var<storage, read_write> hits: array<Hit>;
@group(0) @binding(2) var<storage, read_write> stats: array<Stats>;
@group(0) @binding(3) var<storage, read> tris: array<vec4<f32>>;         // 3 per triangle: v0, v1, v2 (w = 0)
@group(0) @binding(4) var<uniform> meta_: Meta;
// The program's own read-only buffers follow at bindings 5, 6, … (GpuProgram::buffers).

const MISS_PRIM: u32 = 0xffffffffu;

fn miss() -> Hit {
    return Hit(bitcast<f32>(0x7f800000u), MISS_PRIM, 0.0, 0.0);
}

// One 16-byte (vector) load per vertex, not three scalar ones.
fn vertex(i: u32, k: u32) -> vec3<f32> {
    return tris[3u * i + k].xyz;
}

// tb_core::slab::max_num / min_num: ignore a NaN `t` (origin in a slab plane, zero direction).
fn max_num(acc: f32, t: f32) -> f32 { return select(acc, t, t > acc); }
fn min_num(acc: f32, t: f32) -> f32 { return select(acc, t, t < acc); }

// True for +-inf and NaN (WGSL has no isfinite; a bit test survives any fast-math folding).
fn not_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) == 0x7f800000u;
}

// Per-ray data of the slab test (tb_core::slab::RayBox): origin, 1/dir, octant as booleans.
struct RayBox { org: vec3<f32>, inv: vec3<f32>, neg: vec3<bool> }

fn ray_box(r: Ray) -> RayBox {
    let inv = vec3<f32>(1.0 / r.dir.x, 1.0 / r.dir.y, 1.0 / r.dir.z);
    return RayBox(r.origin, inv, inv < vec3<f32>(0.0));
}

// RayBox::slab: (entry, exit) of [bmin, bmax] clipped to [tmin, tmax]; hit when entry <= exit.
fn slab(rb: RayBox, bmin: vec3<f32>, bmax: vec3<f32>, tmin: f32, tmax: f32) -> vec2<f32> {
    let near = select(bmin, bmax, rb.neg);
    let far = select(bmax, bmin, rb.neg);
    let t0 = (near - rb.org) * rb.inv;
    let t1 = (far - rb.org) * rb.inv;
    let tn = max_num(max_num(max_num(tmin, t0.x), t0.y), t0.z);
    let tf = min_num(min_num(min_num(tmax, t1.x), t1.y), t1.z) * EXIT_SCALE;
    return vec2<f32>(tn, tf);
}

// glam's Vec3::cross and Vec3::dot, operation for operation.
fn cross3(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}
fn dot3(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return ((a.x * b.x) + (a.y * b.y)) + (a.z * b.z);
}

// tb_core::tri::WatertightPre.
struct Pre { kx: u32, ky: u32, kz: u32, s: vec3<f32> }

fn prepare(r: Ray) -> Pre {
    let a = abs(r.dir);
    var kz = 2u;
    if a.x >= a.y && a.x >= a.z {
        kz = 0u;
    } else if a.y >= a.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if r.dir[kz] < 0.0 {
        let k = kx;
        kx = ky;
        ky = k;
    }
    let dz = r.dir[kz];
    return Pre(kx, ky, kz, vec3<f32>(r.dir[kx] / dz, r.dir[ky] / dz, 1.0 / dz));
}

// Result of a triangle test: x = t, y = u, z = v, w = 1 for a hit, 0 for none.
// γ(n) = n·ε/(1 − n·ε), ε = 2^-24 (tb_core::tri::gamma).
const GAMMA2: f32 = 1.192093e-7;
const GAMMA3: f32 = 1.7881396e-7;
const GAMMA5: f32 = 2.980233e-7;
const GAMMA9: f32 = 5.364421e-7;

// The vertices relative to the ray's origin, permuted and sheared (tb_core::tri::Sheared):
// x, y sheared, z not yet scaled by `Pre.s.z`.
struct Sheared { a: vec3<f32>, b: vec3<f32>, c: vec3<f32> }

// tb_core::tri::in_f32_range: |det| within [2^-64, 2^64] (bit patterns 0x1f800000 and
// 0x5f800000; NaN is above), where the f32 products keep their precision.
fn in_f32_range(det: f32) -> bool {
    let b = bitcast<u32>(det) & 0x7fffffffu;
    return b >= 0x1f800000u && b <= 0x5f800000u;
}

// What `solve` found: the answer `h`, or `wide` where f32's products left their range.
struct Solved { h: vec4<f32>, wide: bool }

fn done(h: vec4<f32>) -> Solved { return Solved(h, false); }

// tb_core::tri::Sheared::solve: the test from the sheared vertices on, for [tmin, tmax).
fn solve(sz: f32, s: Sheared, tmin: f32, tmax: f32) -> Solved {
    let none = vec4<f32>(0.0);
    let ax = s.a.x;
    let ay = s.a.y;
    let bx = s.b.x;
    let by = s.b.y;
    let cx = s.c.x;
    let cy = s.c.y;
    var u = cx * by - cy * bx;
    var v = ax * cy - ay * cx;
    var w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let e = edge_fallback(ax, ay, bx, by, cx, cy);
        u = e.x;
        v = e.y;
        w = e.z;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return done(none);
    }
    let det = u + v + w;
    if !in_f32_range(det) {
        return Solved(none, true);
    }
    let az = sz * s.a.z;
    let bz = sz * s.b.z;
    let cz = sz * s.c.z;
    let tt = (u * az + v * bz) + w * cz;
    if not_finite(tt) {
        return Solved(none, true);
    }
    var tt_s = tt;
    var det_s = det;
    if det < 0.0 {
        tt_s = -tt;
        det_s = -det;
    }
    if tt_s < tmin * det_s || tt_s >= tmax * det_s {
        return done(none);
    }
    let inv = 1.0 / det;
    let t = tt * inv;
    if t < tmin || t >= tmax {
        return done(none);
    }
    // tb_core::tri::t_error_bound: a t within the rounding-error bound may belong to a plane
    // behind the origin (PBR 4th ed. §6.8.7).
    let max_x = max(max(abs(ax), abs(bx)), abs(cx));
    let max_y = max(max(abs(ay), abs(by)), abs(cy));
    let max_z = max(max(abs(az), abs(bz)), abs(cz));
    let delta_z = GAMMA3 * max_z;
    let delta_x = GAMMA5 * (max_x + max_z);
    let delta_y = GAMMA5 * (max_y + max_z);
    let ainv = abs(inv);
    let delta_e = 2.0 * ((GAMMA2 * max_x * max_y + delta_y * max_x) + delta_x * max_y);
    let e = max(max(abs(u), abs(v)), abs(w)) * ainv;
    let bound = 3.0 * ((GAMMA3 * max_z * e + (delta_e * ainv) * max_z) + delta_z * e);
    if not_finite(bound) {
        return Solved(none, true);
    }
    if !(t > bound) {
        return done(none);
    }
    return done(vec4<f32>(t, v * inv, w * inv, 1.0));
}

// tb_core::tri::Sheared::finish, where f32's products leave their range (a scene at 1e-30 or
// 1e30): the sheared vertices scaled by the power of two 2^k that brings the largest
// coordinate to [0.5, 1) (exact), `solve` on them with the interval scaled alike and the
// distance scaled back; where even that leaves f32's range, `watertight_f64` (in f64 on
// adapters with SHADER_F64, shaders/edge_f64.wgsl; a miss without, edge_f32.wgsl).
fn finish(p: Pre, r: Ray, sh: Sheared, tmax: f32) -> vec4<f32> {
    let none = vec4<f32>(0.0);
    let m = max(max(abs(sh.a), abs(sh.b)), abs(sh.c));
    let big = max(max(m.x, m.y), m.z);
    if !(big > 0.0) || not_finite(big) {
        return none;
    }
    let k = -frexp(big).exp;
    let kv = vec3<i32>(k);
    let sc = Sheared(ldexp(sh.a, kv), ldexp(sh.b, kv), ldexp(sh.c, kv));
    let s = solve(p.s.z, sc, ldexp(r.tmin, k), ldexp(tmax, k));
    if !s.wide {
        if s.h.w == 0.0 {
            return none;
        }
        return vec4<f32>(ldexp(s.h.x, -k), s.h.y, s.h.z, 1.0);
    }
    return watertight_f64(p, r, sh, tmax);
}

fn watertight(p: Pre, r: Ray, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, tmax: f32) -> vec4<f32> {
    let a = v0 - r.origin;
    let b = v1 - r.origin;
    let c = v2 - r.origin;
    let az = a[p.kz];
    let bz = b[p.kz];
    let cz = c[p.kz];
    let sh = Sheared(
        vec3<f32>(a[p.kx] - p.s.x * az, a[p.ky] - p.s.y * az, az),
        vec3<f32>(b[p.kx] - p.s.x * bz, b[p.ky] - p.s.y * bz, bz),
        vec3<f32>(c[p.kx] - p.s.x * cz, c[p.ky] - p.s.y * cz, cz),
    );
    let s = solve(p.s.z, sh, r.tmin, tmax);
    if !s.wide {
        return s.h;
    }
    return finish(p, r, sh, tmax);
}

fn moller_trumbore(r: Ray, v0: vec3<f32>, v1: vec3<f32>, v2: vec3<f32>, tmax: f32) -> vec4<f32> {
    let none = vec4<f32>(0.0);
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let p = cross3(r.dir, e2);
    let det = dot3(e1, p);
    if det == 0.0 || not_finite(det) {
        return none;
    }
    let inv = 1.0 / det;
    let s = r.origin - v0;
    let u = dot3(s, p) * inv;
    if !(u >= 0.0 && u <= 1.0) {
        return none;
    }
    let q = cross3(s, e1);
    let v = dot3(r.dir, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return none;
    }
    let t = dot3(e2, q) * inv;
    // tb_core::tri::mt_error_bound: no hit within the rounding-error bound of t.
    let sa = abs(s);
    let e1a = abs(e1);
    let acr = vec3<f32>(
        sa.y * e1a.z + sa.z * e1a.y,
        sa.z * e1a.x + sa.x * e1a.z,
        sa.x * e1a.y + sa.y * e1a.x,
    );
    let bound = GAMMA9 * dot3(abs(e2), acr) * abs(inv);
    if t >= r.tmin && t < tmax && t > bound {
        return vec4<f32>(t, u, v, 1.0);
    }
    return none;
}

fn intersect(p: Pre, r: Ray, i: u32, tmax: f32) -> vec4<f32> {
    let v0 = vertex(i, 0u);
    let v1 = vertex(i, 1u);
    let v2 = vertex(i, 2u);
    if WATERTIGHT {
        return watertight(p, r, v0, v1, v2, tmax);
    }
    return moller_trumbore(r, v0, v1, v2, tmax);
}

// The invocation's index in its workgroup (0 .. WORKGROUP_SIZE), for programs that keep
// per-invocation data in workgroup memory (the kd-tree's on-chip short stack).
var<private> LANE: u32;

// Ray `i` of the dispatch: the program's `walk` traces ray `ray_index(i)` (`i` itself, or the
// i-th of the sorted order for a program with a ray key: shaders/arrange.wgsl) (counters start
// at zero; `capped` stays 0 unless the program sets it), its hit is written at the ray's own
// index, and its counters in the counting variant. The entry point `main` (shaders/entry.wgsl,
// one thread per ray, or shaders/persistent.wgsl) calls it.
fn trace_ray(i: u32) {
    let j = ray_index(i);
    var st = zero_stats();
    hits[j] = walk(rays[j], &st);
    if COUNT {
        stats[j] = st;
    }
}
