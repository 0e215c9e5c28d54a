//! `sltr` is the paper's Algorithm 3 (Havran and Bittner 2007 §5.3): checked ray for ray
//! against a literal transcription of the pseudocode written here (a fixed epsilon shift,
//! distances compared as printed), on rays where that epsilon cannot matter; and the box's
//! bytes as Table 1 prices them.

use tb_core::{Accel, HitRecord, Query, Ray, Structure, TraversalStats, TriTest, TriTestKind};
use tb_sparse::{SparseBoxes, SparseParams, PAPER_BOX_BYTES, TEXT_BOX_BYTES};

fn index(name: &str) -> usize {
    SparseBoxes::TRAVERSALS
        .iter()
        .position(|t| t.info.name == name)
        .unwrap()
}

/// What the literal Algorithm 3 did with one ray.
#[derive(Debug, PartialEq)]
struct Walked {
    hit: HitRecord,
    /// Interior nodes: `TraverseDown` steps and parent links followed.
    interior: u32,
    leaves: u32,
    prims: u32,
    ups: u32,
}

/// Algorithm 3 as printed, from augmented record `start`: `None` where a distance compared
/// with the shifted origin lies within `tol` of it (other than the exit plane just crossed),
/// where a leaf's other exit planes tie with its exit, or for a ray lying in a plane: there
/// the epsilon decides, and the kernel's exact shift may rightly differ.
fn algorithm3(s: &SparseBoxes, ray: &Ray, start: usize) -> Option<Walked> {
    let v = s.kd().view();
    let (nodes, aug) = (v.nodes(), s.augmented());
    let o = ray.origin.to_array();
    let inv = ray.inv_dir().to_array();
    let neg = [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0];
    let pre = tb_core::Watertight::prepare(ray);
    let root = v.bounds();
    let mut w = Walked {
        hit: HitRecord::MISS,
        interior: 0,
        leaves: 0,
        prims: 0,
        ups: 0,
    };
    // ComputeMaxT / ComputeMinMaxT: the ray's interval in a box, each plane's distance by the
    // split planes' formula.
    let clip = |min: [f32; 3], max: [f32; 3]| {
        let (mut tn, mut tf) = (ray.tmin, ray.tmax);
        for a in 0..3 {
            let (np, fp) = if neg[a] {
                (max[a], min[a])
            } else {
                (min[a], max[a])
            };
            tn = tn.max((np - o[a]) * inv[a]);
            tf = tf.min((fp - o[a]) * inv[a]);
        }
        (tn <= tf).then_some((tn, tf))
    };
    let Some((_, r1)) = clip(root.min.to_array(), root.max.to_array()) else {
        return Some(w);
    };
    let mut last = start;
    let Some((mut tentry, mut texit)) = clip(aug[start].min, aug[start].max) else {
        return Some(w);
    };
    let mut tup = texit;
    let mut node = aug[start].node as usize;
    let (mut min, mut max) = (aug[start].min, aug[start].max);
    let mut best_t = ray.tmax;
    // The exit plane just crossed (compared bitwise: the same plane gives the same distance).
    let mut crossed = f32::NAN;
    let mut tol = 0.0;
    let near = |t: f32, te: f32, crossed: f32, tol: f32| t != crossed && (t - te).abs() <= tol;
    loop {
        // TraverseDown to the leaf holding the origin.
        while !nodes[node].is_leaf() {
            let n = nodes[node];
            w.interior += 1;
            let a = n.axis();
            let t = (n.split() - o[a]) * inv[a];
            if t.is_nan() || near(t, tentry, crossed, tol) {
                return None;
            }
            let (l, r) = (node + 1, n.link());
            let (nc, fc) = if neg[a] { (r, l) } else { (l, r) };
            // The first intersected child: the near one when the plane lies ahead.
            node = if t > tentry {
                texit = texit.min(t);
                nc
            } else {
                fc
            };
            if node == l {
                max[a] = n.split();
            } else {
                min[a] = n.split();
            }
            if let Some(k) = s.aug_of(node) {
                last = k;
                tup = texit;
            }
        }
        // ComputeIntersections.
        let n = nodes[node];
        w.leaves += 1;
        w.prims += n.count();
        for &id in &v.refs()[n.offset()..n.offset() + n.count() as usize] {
            let tri = &v.triangles()[id as usize];
            if let Some((t, u, vv)) = tb_core::Watertight::intersect(&pre, ray, tri, best_t) {
                best_t = t;
                w.hit = HitRecord {
                    t,
                    prim: id,
                    u,
                    v: vv,
                };
            }
        }
        if w.hit.is_hit() && best_t <= texit {
            return Some(w);
        }
        // A leaf left through an edge or corner: the epsilon decides which cell is next.
        for a in 0..3 {
            let far = if neg[a] { min[a] } else { max[a] };
            let t = (far - o[a]) * inv[a];
            if t != texit && (t - texit).abs() <= 4.0 * f32::EPSILON * texit.abs().max(1.0) {
                return None;
            }
        }
        // tentry = texit + eps.
        crossed = texit;
        let eps = 1e-5 * texit.abs().max(1.0);
        tol = 2.0 * eps;
        tentry = texit + eps;
        if near(r1, tentry, crossed, tol) {
            return None;
        }
        // RestartTraversal.
        if near(tup, tentry, crossed, tol) {
            return None;
        }
        if tentry < tup {
            texit = tup;
        } else {
            // TraverseUp.
            loop {
                if last == 0 {
                    return Some(w);
                }
                last = aug[last].parent as usize;
                w.ups += 1;
                w.interior += 1;
                let (_, tmax) = clip(aug[last].min, aug[last].max)?;
                if near(tmax, tentry, crossed, tol) {
                    return None;
                }
                if tentry < tmax {
                    texit = tmax;
                    tup = tmax;
                    break;
                }
            }
        }
        node = aug[last].node as usize;
        (min, max) = (aug[last].min, aug[last].max);
    }
}

/// `sltr` and `sltr-root` follow Algorithm 3 ray for ray (hit, N_I with the parent climbs,
/// N_L, r_ITM, climbs) on every ray where the epsilon cannot matter, from the root and from
/// the start node, primary rays from a view outside and random rays from inside, for dense
/// and sparse boxes, on a triangle soup (no planes shared by many triangles, where a fixed
/// epsilon decides for many rays); most rays are compared and some of them climb.
#[test]
fn sltr_is_algorithm_3() {
    let scene = tb_scene::load("builtin:soup?count=3000", std::path::Path::new(".")).unwrap();
    let mut cam = scene.view.clone().unwrap().camera;
    (cam.width, cam.height) = (48, 36);
    let primary = tb_scene::rays::primary(&cam);
    let bounds =
        tb_core::Aabb::from_points(scene.triangles.iter().flat_map(|t| [t.v0, t.v1, t.v2]));
    let random = tb_scene::rays::random(&bounds, 2000, 7);
    let (mut compared, mut total, mut climbs) = (0usize, 0usize, 0u32);
    for d_min in [1, 3] {
        let s = SparseBoxes::build(
            &scene.triangles,
            &SparseParams {
                d_min,
                ..Default::default()
            },
        );
        for (name, rays) in [
            ("sltr", &primary),
            ("sltr-root", &primary),
            ("sltr", &random),
            ("sltr-root", &random),
        ] {
            let mut st = vec![TraversalStats::default(); rays.len()];
            let hits = tb_sparse::trace_hinted(
                &s,
                index(name),
                Query::Closest,
                TriTestKind::Watertight,
                rays,
                Some(&mut st),
            );
            for (i, r) in rays.iter().enumerate() {
                let start = if name == "sltr" && r.tmin == 0.0 {
                    s.start_node(r.origin) as usize
                } else {
                    0
                };
                total += 1;
                let Some(w) = algorithm3(&s, r, start) else {
                    continue;
                };
                let k = &st[i];
                let got = Walked {
                    hit: hits[i],
                    interior: k.interior,
                    leaves: k.leaves,
                    prims: k.prims,
                    ups: k.ups,
                };
                assert_eq!(got, w, "d_min {d_min}, {name}, ray {i}: {r:?}");
                climbs += w.ups;
                compared += 1;
            }
        }
    }
    println!("{compared} of {total} rays compared, {climbs} climbs");
    assert!(compared * 10 >= total * 9, "{compared} of {total}");
    assert!(climbs > 0);
}

/// SLTR visits the leaves of SEQ (Table 1: N_L 10.80 / 10.81, r_ITM equal), not those of HTR:
/// on the stress and small scenes of the suite, from the root and from the start node, every
/// ray whose leaves or triangle tests differ from SEQ's is one that SLTR or SEQ handed to its
/// fallback walk (`handovers`: a point that rounding cannot place; its restarts then reach
/// HTR's leaves), rays lying in a split plane included (walked once per side, as SEQ walks
/// them); `sltr-handover`, which hands those over too, hands over more rays and differs from
/// SEQ on more; SLTR differs from HTR on some rays where `sltr-mask` (HTR's leaves by
/// construction) does not, and agrees with SEQ on more rays than with HTR.
#[test]
fn sltr_visits_seq_leaves() {
    let (seq, htr, mask) = (index("seq"), index("htr"), index("sltr-mask-root"));
    let (mut same_seq, mut same_htr, mut n) = (0usize, 0usize, 0usize);
    let mut mask_differs = 0usize;
    // Per reading (sltr, sltr-handover): rays handed over, rays differing from SEQ.
    let (mut handed, mut differ) = ([0usize; 2], [0usize; 2]);
    for scene in tb_scene::conformance::suite_scenes() {
        let s = SparseBoxes::build(&scene.triangles, &SparseParams::default());
        for b in tb_scene::conformance::batches(&scene, TriTestKind::Watertight) {
            if b.kind.query() != Query::Closest {
                continue;
            }
            let count = |ti: usize| {
                tb_core::par::count(&s, ti, Query::Closest, TriTestKind::Watertight, &b.rays).1
            };
            let (q, h, m) = (count(seq), count(htr), count(mask));
            let key = |x: &TraversalStats| (x.leaves, x.prims);
            for (k, name) in ["sltr-root", "sltr", "sltr-handover"].iter().enumerate() {
                let a = count(index(name));
                for i in 0..b.rays.len() {
                    let same = key(&a[i]) == key(&q[i]);
                    assert!(a[i].handovers <= 1 && q[i].handovers <= 1);
                    if !same {
                        assert!(
                            a[i].handovers == 1 || q[i].handovers == 1,
                            "{}: {name}, ray {i} differs from SEQ without a hand-over: {:?} vs {:?}",
                            scene.source,
                            a[i],
                            q[i]
                        );
                    }
                    if k == 0 {
                        same_seq += same as usize;
                        same_htr += (key(&a[i]) == key(&h[i])) as usize;
                        mask_differs += (key(&m[i]) != key(&h[i])) as usize;
                        n += 1;
                    } else {
                        handed[k - 1] += a[i].handovers as usize;
                        differ[k - 1] += !same as usize;
                    }
                }
            }
        }
    }
    println!("of {n} rays: SLTR's leaves are SEQ's on {same_seq}, HTR's on {same_htr}");
    println!("sltr / sltr-handover: {handed:?} rays handed over, {differ:?} differ from SEQ");
    assert_eq!(mask_differs, 0);
    assert!(same_htr < n, "SLTR visits exactly HTR's leaves");
    assert!(same_seq > same_htr, "{same_seq} vs {same_htr}");
    assert!(handed[1] > handed[0], "{handed:?}");
    assert!(differ[1] > differ[0], "{differ:?}");
}

/// A ray lying in the root's split plane (a zero direction component, the origin in the
/// plane): `sltr-handover` hands it to `sltr-mask` (one hand-over counted); `sltr` walks it on
/// both sides as SEQ does, with SEQ's leaves and triangle tests and no hand-over; both find
/// HTR's hit. A ray beside the plane is handed over by neither.
#[test]
fn a_split_plane_ray_is_walked_on_both_sides() {
    let tris = tb_scene::load("builtin:teapot?tess=6", std::path::Path::new("."))
        .unwrap()
        .triangles;
    let s = SparseBoxes::build(
        &tris,
        &SparseParams {
            d_min: 1,
            ..Default::default()
        },
    );
    let v = s.kd().view();
    let root = v.nodes()[0];
    assert!(!root.is_leaf());
    let (a, sp) = (root.axis(), root.split());
    let (b, c) = ((a + 1) % 3, (a + 2) % 3);
    let bounds = v.bounds();
    // Across the scene's middle in the plane: from outside the box toward its centre.
    let mut dir = tb_core::Vec3::ZERO;
    dir[b] = 1.0;
    dir[c] = 0.37;
    let mut target = bounds.center();
    target[a] = sp;
    let extent = (bounds.max - bounds.min).length();
    let origin = target - dir * extent;
    let in_plane = Ray::new(origin, dir);
    assert_eq!(in_plane.origin[a], sp);
    let mut beside = in_plane;
    beside.origin[a] = sp + 1e-3 * extent;
    let run = |name: &str, r: &Ray| {
        let mut st = vec![TraversalStats::default(); 1];
        let h = tb_sparse::trace_hinted(
            &s,
            index(name),
            Query::Closest,
            TriTestKind::Watertight,
            std::slice::from_ref(r),
            Some(&mut st),
        );
        (h[0], st[0])
    };
    for r in [&in_plane, &beside] {
        let (hh, _) = run("htr", r);
        let (hs, ss) = run("sltr", r);
        let (hq, sq) = run("seq", r);
        let (hv, sv) = run("sltr-handover", r);
        assert!(hh.is_hit(), "{r:?}");
        assert_eq!((hs, hq, hv), (hh, hh, hh), "{r:?}");
        assert_eq!((ss.leaves, ss.prims), (sq.leaves, sq.prims), "{r:?}");
        assert_eq!((ss.handovers, sq.handovers), (0, 0), "{r:?}");
        let expect = (r.origin[a] == sp) as u32;
        assert_eq!(sv.handovers, expect, "{r:?}");
    }
}

/// The box's bytes: `paper_bytes` prices a box at [`PAPER_BOX_BYTES`], the one whole size
/// inside the range Table 1's M_KD and N_B give on both scenes for both readings of MB (the
/// text's 28 in none); `m_kd_bytes` at the text's 28; both on a known tree's counts.
#[test]
fn box_bytes_as_table_1() {
    // (M_KD of BTR, M_KD of HTR, N_B in millions), Table 1, printed rounded.
    let table = [(117.0, 89.0, 0.725), (64.0, 42.0, 0.557)];
    let fits = |bytes: f64| {
        table.iter().all(|&(btr, htr, nb)| {
            [1e6, 1048576.0].iter().all(|&mb| {
                let lo = (btr - 0.5 - (htr + 0.5)) * mb / ((nb + 0.0005) * 1e6);
                let hi = (btr + 0.5 - (htr - 0.5)) * mb / ((nb - 0.0005) * 1e6);
                (lo..=hi).contains(&bytes)
            })
        })
    };
    let whole: Vec<u32> = (1..100).filter(|&b| fits(b as f64)).collect();
    assert_eq!(whole, vec![PAPER_BOX_BYTES]);
    assert!(!fits(TEXT_BOX_BYTES as f64));
    assert_eq!(TEXT_BOX_BYTES, 24 + 4);

    let tris = tb_scene::load("builtin:teapot?tess=4", std::path::Path::new("."))
        .unwrap()
        .triangles;
    let s = SparseBoxes::build(&tris, &SparseParams::default());
    let rep = Accel::build_report(&s);
    let get = |k: &str| rep.extra.iter().find(|e| e.0 == k).unwrap().1;
    let (nodes, refs, nb) = (
        s.kd().nodes().len() as f64,
        s.kd().prim_refs().len() as f64,
        s.augmented().len() as f64,
    );
    assert!(nb > 1.0);
    assert_eq!(get("m_kd_htr_bytes"), 8.0 * nodes + 4.0 * refs);
    assert_eq!(get("m_kd_bytes"), 8.0 * nodes + 4.0 * refs + 28.0 * nb);
    assert_eq!(get("paper_bytes"), 8.0 * nodes + 4.0 * refs + 40.0 * nb);
    assert_eq!(
        get("paper_ratio"),
        get("paper_bytes") / get("m_kd_htr_bytes")
    );
}
