// What the grid programs share (tb_grid's `common` module in WGSL, on tb-gpu's prelude,
// contract in tb_core::gpu): the lattice, the ray clipped to it, the cell walk's steps (voxel
// of a point, exits through the far planes, the monotone advance of Pérard-Gayot et al. 2017
// §5), the reference tests and the brute-force answer of rays from far away. Positions and
// plane distances are computed in `real`, the grid's precision (tb_grid::Precision): the
// program source starts with `alias real = f32;` (the default, as the paper's walk; any
// adapter) or `alias real = f64;` (GpuProgram::needs_f64), operation for operation as the
// CPU walk does. In f64 the cells visited, and so the counters, equal the CPU's ray for ray;
// in f32 a driver that contracts into FMAs may place a boundary crossing an ulp away, which
// the reference margin covers (the hits stay exact; a counter may differ on a grazing ray).
//
// Every program's first buffer is the header `hdr` (binding 5), a uniform buffer (the same
// for every ray: a GPU serves it from its constant caches, as the authors' code keeps its grid
// in CUDA constant memory): 16 values in `real`, four to an element (a uniform array's
// elements are 16-byte aligned), read by `hw`. Its lattice is read by `lattice`: 15 values,
// min (3), size (3), 1/size (3), resolution (3), the least margin delta, mag and the
// far-origin factor (tb_grid::Lattice); value 15 is the program's own (uniform: macro
// regions; irregular: the deepest octree level).
@group(0) @binding(5) var<uniform> hdr: array<vec4<real>, 4>;

// Value `k` of the header.
fn hw(k: u32) -> real {
    return hdr[k >> 2u][k & 3u];
}

struct Lat {
    lo: vec3<real>,
    size: vec3<real>,
    inv: vec3<real>,
    res: vec3<u32>,
    dmin: real,
    mag: real,
    far_scale: real,
}

// tb_grid::common::WalkRay: origin, direction, 1/direction in `real` and the interval inside
// the lattice's box.
struct WalkRay {
    o: vec3<real>,
    d: vec3<real>,
    inv: vec3<real>,
    t0: real,
    t1: real,
    ok: bool,
}

// One step of the walk: the next voxel, `ok = false` when it would leave the lattice.
struct Next {
    v: vec3<u32>,
    ok: bool,
}

// The lattice stored from value `k` of `hdr`.
fn lattice(k: u32) -> Lat {
    let h = k;
    return Lat(
        vec3<real>(hw(h), hw(h + 1u), hw(h + 2u)),
        vec3<real>(hw(h + 3u), hw(h + 4u), hw(h + 5u)),
        vec3<real>(hw(h + 6u), hw(h + 7u), hw(h + 8u)),
        vec3<u32>(u32(hw(h + 9u)), u32(hw(h + 10u)), u32(hw(h + 11u))),
        hw(h + 12u),
        hw(h + 13u),
        hw(h + 14u),
    );
}

// +inf in `real`, made at run time (a constant would be folded, and infinite constants are
// rejected): the f32 infinity of the `meta_` uniform's first word's unused high bits.
fn inf_real() -> real {
    return real(bitcast<f32>(0x7f800000u | (meta_.counts.x & 0u)));
}

// NaN test through f32 (NaN converts to NaN; no bitcast of f64 in WGSL).
fn is_nan_real(x: real) -> bool {
    return (bitcast<u32>(f32(x)) & 0x7fffffffu) > 0x7f800000u;
}

// Rust's max / min of floats: a NaN operand yields the other.
fn max_real(a: real, b: real) -> real {
    if is_nan_real(a) {
        return b;
    }
    if is_nan_real(b) {
        return a;
    }
    return select(a, b, b > a);
}
fn min_real(a: real, b: real) -> real {
    if is_nan_real(a) {
        return b;
    }
    if is_nan_real(b) {
        return a;
    }
    return select(a, b, b < a);
}

// Lattice::plane: position of plane `i` of axis `a`.
fn plane(l: Lat, a: u32, i: u32) -> real {
    return l.lo[a] + real(i) * l.size[a];
}

// Lattice::index: linear index of voxel `v` (x fastest).
fn index(l: Lat, v: vec3<u32>) -> u32 {
    return v.x + l.res.x * (v.y + l.res.y * v.z);
}

// Lattice::voxel: voxel along `a` of coordinate `p`, clamped to the lattice (a NaN gives 0,
// as Rust's `f as u32` then `min`).
fn voxel(l: Lat, a: u32, p: real) -> u32 {
    return voxel_scaled(l, a, (p - l.lo[a]) * l.inv[a]);
}

// Lattice::voxel_scaled: the same for a coordinate already in voxel units.
fn voxel_scaled(l: Lat, a: u32, f: real) -> u32 {
    if f >= real(0.0) {
        let top = l.res[a] - 1u;
        if f >= real(top) {
            return top;
        }
        return u32(f);
    }
    return 0u;
}

// f32::max as glam's Vec3::max_element uses it (NaN ignored).
fn max32(a: f32, b: f32) -> f32 {
    if (bitcast<u32>(a) & 0x7fffffffu) > 0x7f800000u {
        return b;
    }
    return select(a, b, b > a);
}

// Lattice::far: the f32 triangle test's rounding at this origin may exceed the reference
// margin; such rays test every triangle.
fn far(l: Lat, r: Ray) -> bool {
    let a = abs(r.origin);
    let o = real(max32(a.x, max32(a.y, a.z)));
    let e = (o + l.mag) * l.far_scale;
    return e > l.dmin;
}

// WalkRay::clip_box: `w` clipped to the box lo..hi inside its current interval.
fn clip_box(w: WalkRay, box_lo: vec3<real>, box_hi: vec3<real>) -> WalkRay {
    var t0 = w.t0;
    var t1 = w.t1;
    var out = w;
    out.ok = false;
    for (var a = 0u; a < 3u; a++) {
        let lo = box_lo[a];
        let hi = box_hi[a];
        let o = w.o[a];
        let d = w.d[a];
        if d == real(0.0) {
            if o < lo || o > hi {
                return out;
            }
        } else {
            var n = hi;
            var f = lo;
            if d > real(0.0) {
                n = lo;
                f = hi;
            }
            t0 = max_real(t0, (n - o) / d);
            t1 = min_real(t1, (f - o) / d);
        }
    }
    if t0 > t1 || is_nan_real(t0) || is_nan_real(t1) {
        return out;
    }
    out.t0 = t0;
    out.t1 = t1;
    out.ok = true;
    return out;
}

// WalkRay::clip_to: `w` clipped to the lattice's box inside its current interval.
fn clip_to(w: WalkRay, l: Lat) -> WalkRay {
    let hi = vec3<real>(plane(l, 0u, l.res.x), plane(l, 1u, l.res.y), plane(l, 2u, l.res.z));
    return clip_box(w, l.lo, hi);
}

// WalkRay::clip_near: `w` clipped to the lattice's box grown by its least margin (a top
// cell's grid in the two-level walk).
fn clip_near(w: WalkRay, l: Lat) -> WalkRay {
    let g = vec3<real>(l.dmin);
    let hi = vec3<real>(plane(l, 0u, l.res.x), plane(l, 1u, l.res.y), plane(l, 2u, l.res.z));
    return clip_box(w, l.lo - g, hi + g);
}

// WalkRay::clip: the ray in `real`, clipped to the lattice's box.
fn clip(r: Ray, l: Lat) -> WalkRay {
    let d = vec3<real>(r.dir);
    let one = real(1.0);
    let w = WalkRay(
        vec3<real>(r.origin),
        d,
        vec3<real>(one / d.x, one / d.y, one / d.z),
        real(r.tmin),
        real(r.tmax),
        true,
    );
    return clip_to(w, l);
}

// WalkRay::voxel_at: the voxel holding the ray's point at `t`.
fn voxel_at(w: WalkRay, l: Lat, t: real) -> vec3<u32> {
    var v = vec3<u32>(0u);
    for (var a = 0u; a < 3u; a++) {
        if w.d[a] == real(0.0) {
            v[a] = voxel(l, a, w.o[a]);
        } else {
            v[a] = voxel(l, a, w.o[a] + t * w.d[a]);
        }
    }
    return v;
}

// WalkRay::exits and argmin3: the axis and distance of the nearest far plane of the box of
// voxels lo..hi (ties to the lower axis; +inf on axes the ray is parallel to), and every
// axis's far-plane distance (`ts`, for advance_ties).
struct Exit {
    axis: u32,
    t: real,
    ts: vec3<real>,
}

fn exit(w: WalkRay, l: Lat, lo: vec3<u32>, hi: vec3<u32>) -> Exit {
    var t = vec3<real>(real(0.0));
    for (var a = 0u; a < 3u; a++) {
        if w.d[a] > real(0.0) {
            t[a] = (plane(l, a, hi[a]) - w.o[a]) * w.inv[a];
        } else if w.d[a] < real(0.0) {
            t[a] = (plane(l, a, lo[a]) - w.o[a]) * w.inv[a];
        } else {
            t[a] = inf_real();
        }
    }
    var k = 0u;
    for (var a = 1u; a < 3u; a++) {
        if t[a] < t[k] {
            k = a;
        }
    }
    return Exit(k, t[k], t);
}

// tb_grid::common::VoxelLine: the ray in voxel units of lattice `l`, `base + t·slope` per
// axis, computed once per walk of a lattice (WalkRay::voxel_line).
struct Line {
    base: vec3<real>,
    slope: vec3<real>,
}

fn voxel_line(w: WalkRay, l: Lat) -> Line {
    return Line((w.o - l.lo) * l.inv, w.d * l.inv);
}

// WalkRay::advance: the monotone advance of §5 from voxel `v` leaving the box lo..hi at `t`
// through the far plane of `axis`, the other axes placed on the walk's `line`.
fn advance(w: WalkRay, l: Lat, line: Line, t: real, axis: u32, v: vec3<u32>, lo: vec3<u32>, hi: vec3<u32>) -> Next {
    var n = v;
    for (var a = 0u; a < 3u; a++) {
        if a == axis {
            if w.d[a] > real(0.0) {
                if hi[a] >= l.res[a] {
                    return Next(n, false);
                }
                n[a] = hi[a];
            } else {
                if lo[a] == 0u {
                    return Next(n, false);
                }
                n[a] = lo[a] - 1u;
            }
        } else if w.d[a] != real(0.0) {
            let p = clamp(voxel_scaled(l, a, line.base[a] + t * line.slope[a]), lo[a], hi[a] - 1u);
            if w.d[a] > real(0.0) {
                n[a] = max(p, v[a]);
            } else {
                n[a] = min(p, v[a]);
            }
        }
    }
    return Next(n, true);
}

// WalkRay::advance_ties: the authors' step (hagrid) from voxel `v` leaving the box lo..hi at
// `e.t`: every axis whose far plane lies at `e.t` steps past the box, the others take the exit
// point's voxel (clamped to the lattice, not to the box) and never go back.
fn advance_ties(w: WalkRay, l: Lat, line: Line, e: Exit, v: vec3<u32>, lo: vec3<u32>, hi: vec3<u32>) -> Next {
    var n = v;
    var out = false;
    for (var a = 0u; a < 3u; a++) {
        let forward = w.d[a] > real(0.0);
        var layer = lo[a] - 1u;
        var outside = lo[a] == 0u;
        if forward {
            layer = hi[a];
            outside = hi[a] >= l.res[a];
        }
        var along = v[a];
        if w.d[a] != real(0.0) {
            let p = voxel_scaled(l, a, line.base[a] + e.t * line.slope[a]);
            along = select(min(p, v[a]), max(p, v[a]), forward);
        }
        let tie = e.ts[a] == e.t;
        n[a] = select(along, layer, tie);
        out = out || (tie && outside);
    }
    return Next(n, !out);
}

// Whether the walk goes on after a cell whose box exits at `e`: the closest hit so far lies
// beyond the exit and the ray's interval does too (the test of tb_grid::common::walk).
fn goes_on(best: f32, e: Exit, w: WalkRay) -> bool {
    return !(real(best) <= e.t || e.t >= w.t1);
}

// The walk's next voxel after voxel `v` whose cell is the box lo..hi (tb_grid::common::walk_by's
// step): out through the box's nearest far plane (`exit`, `advance`); `ok = false` when the
// closest hit so far (`best`) or the ray's interval ends first (`goes_on`), or the walk would
// leave the lattice.
fn next_voxel(w: WalkRay, l: Lat, line: Line, best: f32, v: vec3<u32>, lo: vec3<u32>, hi: vec3<u32>) -> Next {
    let x = exit(w, l, lo, hi);
    if !goes_on(best, x, w) {
        return Next(v, false);
    }
    return advance(w, l, line, x.t, x.axis, v, lo, hi);
}

// The closest hit so far (`best.t` is the ray's tmax until one is found).
fn no_hit(r: Ray) -> Hit {
    return Hit(r.tmax, MISS_PRIM, 0.0, 0.0);
}

// The hit as the CPU returns it: a miss keeps HitRecord::MISS.
fn record(h: Hit) -> Hit {
    if h.prim == MISS_PRIM {
        return miss();
    }
    return h;
}

// test_refs: the references `begin..end` (scene indices in `refs`), closest hit into `best`;
// true when ANY and one was found.
fn test_refs(p: Pre, r: Ray, begin: u32, end: u32, best: ptr<function, Hit>, st: ptr<function, Stats>) -> bool {
    for (var k = begin; k < end; k++) {
        (*st).prims += 1u;
        let id = refs[k];
        let h = intersect(p, r, id, (*best).t);
        if h.w != 0.0 {
            *best = Hit(h.x, id, h.y, h.z);
            if ANY {
                return true;
            }
        }
    }
    return false;
}

// One triangle of brute_force.
fn brute_one(k: u32, p: Pre, r: Ray, best: ptr<function, Hit>, st: ptr<function, Stats>, done: ptr<function, bool>) {
    if *done || k >= meta_.counts.x {
        return;
    }
    (*st).prims += 1u;
    let h = intersect(p, r, k, (*best).t);
    if h.w != 0.0 {
        *best = Hit(h.x, k, h.y, h.z);
        if ANY {
            *done = true;
        }
    }
}

// brute_force: every triangle in index order (rays from far away, Lattice::far). Unrolled 8
// times: llvmpipe ends an invocation's loops after 65535 iterations in all.
fn brute_force(r: Ray, st: ptr<function, Stats>) -> Hit {
    let p = prepare(r);
    var best = no_hit(r);
    var done = false;
    let n = meta_.counts.x;
    for (var k = 0u; k < n && !done; k += 8u) {
        brute_one(k, p, r, &best, st, &done);
        brute_one(k + 1u, p, r, &best, st, &done);
        brute_one(k + 2u, p, r, &best, st, &done);
        brute_one(k + 3u, p, r, &best, st, &done);
        brute_one(k + 4u, p, r, &best, st, &done);
        brute_one(k + 5u, p, r, &best, st, &done);
        brute_one(k + 6u, p, r, &best, st, &done);
        brute_one(k + 7u, p, r, &best, st, &done);
    }
    return record(best);
}
