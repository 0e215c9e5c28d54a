//! `btr` is the paper's Algorithm 2 (Havran and Bittner 2007 §5.2): checked ray for ray
//! against a literal transcription of the pseudocode written here (the stack traversal with
//! `lastAugmentedNode` in every entry, `TraverseUp` from `lastAugmentedNode` with the fixed
//! epsilon shift `tentry = texit + eps`), on rays where that epsilon cannot matter: the same
//! hit, interior nodes (down steps and parent links), leaves, triangle tests, climbs and
//! restarts. A BTR that climbs from the finished subtree's root instead (our reading before
//! method version 2) follows fewer parent links and fails here.

use tb_core::{HitRecord, Query, Ray, Structure, TraversalStats, TriTest, TriTestKind};
use tb_sparse::{SparseBoxes, SparseParams};

fn index(name: &str) -> usize {
    SparseBoxes::TRAVERSALS
        .iter()
        .position(|t| t.info.name == name)
        .unwrap()
}

/// What the literal Algorithm 2 did with one ray.
#[derive(Debug, PartialEq)]
struct Walked {
    hit: HitRecord,
    /// Interior nodes: `TraverseDown` steps and parent links followed.
    interior: u32,
    leaves: u32,
    prims: u32,
    ups: u32,
    restarts: u32,
}

/// Algorithm 2 as printed, from augmented record `start`: `None` where a distance the
/// traversal compares lies within a tolerance of another it is compared with (a split plane
/// at an entry or exit, a parent box's exit at the shifted origin) or for a ray lying in a
/// plane: there rounding or the epsilon decides, and the kernel's rules may rightly differ.
/// Beside the walk, how many of its climbs began below the root of the subtree just finished
/// (where climbing from that root would follow fewer links).
fn algorithm2(s: &SparseBoxes, ray: &Ray, start: usize) -> Option<(Walked, u32)> {
    let v = s.kd().view();
    let (nodes, aug) = (v.nodes(), s.augmented());
    let o = ray.origin.to_array();
    let inv = ray.inv_dir().to_array();
    let neg = [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0];
    let pre = tb_core::Watertight::prepare(ray);
    let mut w = Walked {
        hit: HitRecord::MISS,
        interior: 0,
        leaves: 0,
        prims: 0,
        ups: 0,
        restarts: 0,
    };
    // ComputeMinMaxT / ComputeMaxT: the ray's interval in a box, each plane's distance by the
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
        (tn, tf)
    };
    // Within rounding of each other, unless `a` is the exit just crossed (the same plane gives
    // the same distance, bitwise): the shifted origin is then beyond it by `eps`.
    let mut crossed = f32::NAN;
    let close = |a: f32, b: f32, crossed: f32| {
        a != crossed && (a - b).abs() <= 1e-5 * a.abs().max(b.abs()).max(1.0)
    };
    let (t0, t1) = clip(aug[start].min, aug[start].max);
    if t0 > t1 {
        return Some((w, 0));
    }
    // (node, lastAugmentedNode, tentry, texit)
    let mut stack = vec![(aug[start].node as usize, start, t0, t1)];
    let mut best_t = ray.tmax;
    let (mut last, mut texit) = (start, t1);
    // The record whose subtree is walked, and the climbs that began below it.
    let (mut sub, mut below) = (start, 0);
    loop {
        while let Some((mut node, mut la, tn, tf)) = stack.pop() {
            (last, texit) = (la, tf);
            let n = nodes[node];
            if n.is_leaf() {
                w.leaves += 1;
                w.prims += n.count();
                for &id in &v.refs()[n.offset()..n.offset() + n.count() as usize] {
                    let tri = &v.triangles()[id as usize];
                    if let Some((t, u, vv)) = tb_core::Watertight::intersect(&pre, ray, tri, best_t)
                    {
                        best_t = t;
                        w.hit = HitRecord {
                            t,
                            prim: id,
                            u,
                            v: vv,
                        };
                    }
                }
                if w.hit.is_hit() && close(best_t, tf, crossed) {
                    return None;
                }
                if w.hit.is_hit() && best_t <= tf {
                    return Some((w, below));
                }
                continue;
            }
            // TraverseDown.
            w.interior += 1;
            let a = n.axis();
            let t = (n.split() - o[a]) * inv[a];
            if t.is_nan() || close(t, tn, crossed) || close(t, tf, crossed) {
                return None;
            }
            if let Some(k) = s.aug_of(node) {
                la = k;
            }
            let (l, r) = (node + 1, n.link());
            let (nc, fc) = if neg[a] { (r, l) } else { (l, r) };
            if t > tf {
                node = nc;
                stack.push((node, la, tn, tf));
            } else if t < tn {
                node = fc;
                stack.push((node, la, tn, tf));
            } else {
                stack.push((fc, la, t, tf));
                stack.push((nc, la, tn, t));
            }
        }
        // TraverseUp: the shifted origin, then up from lastAugmentedNode.
        let eps = 1e-6 * texit.abs().max(1.0);
        let tentry = texit + eps;
        crossed = texit;
        let mut node = last;
        below += (last != sub) as u32;
        loop {
            if node == 0 {
                return Some((w, below));
            }
            let p = aug[node].parent as usize;
            w.ups += 1;
            w.interior += 1;
            let (_, tmax) = clip(aug[p].min, aug[p].max);
            if close(tmax, tentry, crossed) {
                return None;
            }
            if tentry < tmax {
                w.restarts += 1;
                stack.push((aug[p].node as usize, p, tentry, tmax));
                sub = p;
                break;
            }
            node = p;
        }
    }
}

/// `btr` and `btr-root` follow Algorithm 2 ray for ray on every ray where the epsilon and
/// rounding cannot matter, from the start node and from the root, primary rays from a view
/// outside and random rays from inside, for dense and sparse boxes, on a triangle soup; most
/// rays are compared, many climb, and some climb from an augmented node below the subtree
/// they finished (where climbing from that subtree's root would follow fewer links).
#[test]
fn btr_is_algorithm_2() {
    let scene = tb_scene::load("builtin:soup?count=3000", std::path::Path::new(".")).unwrap();
    let mut cam = scene.view.clone().unwrap().camera;
    (cam.width, cam.height) = (48, 36);
    let primary = tb_scene::rays::primary(&cam);
    let bounds =
        tb_core::Aabb::from_points(scene.triangles.iter().flat_map(|t| [t.v0, t.v1, t.v2]));
    let random = tb_scene::rays::random(&bounds, 2000, 7);
    let (mut compared, mut total, mut climbs, mut deeper) = (0usize, 0usize, 0u32, 0u32);
    for d_min in [1, 3] {
        let s = SparseBoxes::build(
            &scene.triangles,
            &SparseParams {
                d_min,
                ..Default::default()
            },
        );
        for (name, rays) in [
            ("btr", &primary),
            ("btr-root", &primary),
            ("btr", &random),
            ("btr-root", &random),
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
                let start = if name == "btr" && r.tmin == 0.0 {
                    s.start_node(r.origin) as usize
                } else {
                    0
                };
                total += 1;
                let Some((w, b)) = algorithm2(&s, r, start) else {
                    continue;
                };
                let k = &st[i];
                let got = Walked {
                    hit: hits[i],
                    interior: k.interior,
                    leaves: k.leaves,
                    prims: k.prims,
                    ups: k.ups,
                    restarts: k.restarts,
                };
                assert_eq!(got, w, "d_min {d_min}, {name}, ray {i}: {r:?}");
                climbs += w.ups;
                deeper += b;
                compared += 1;
            }
        }
    }
    println!("{compared} of {total} rays compared, {climbs} climbs, {deeper} from below");
    assert!(compared * 10 >= total * 8, "{compared} of {total}");
    assert!(
        climbs > 0 && deeper > 0,
        "{climbs} climbs, {deeper} from below"
    );
}
