//! Harness overhead check for the Embree peer: a minimal standalone `rtcIntersect1` loop over
//! the primary rays of a view, beside the same rays traced through `trace-bench`'s path
//! (`EmbreePeer` behind `dyn Accel`, `tb_core::par::trace` on a one-thread pool), both on
//! Embree's default scene flags with build quality high. Prints the median MRays/s of each
//! over `--repeat` alternating runs and their ratio.
//!
//! Then, for a comparison that holds on a busy machine (every contender timed in turn within
//! each repeat, so load changes hit all alike), the peer and our BVHs (binary, BVH8 binned,
//! BVH8 SBVH; watertight test) on primary, AO (one sample per primary hit) and random rays,
//! one thread, medians of `--repeat`.
//!
//! ```text
//! cargo run --release -p tb-peers --features embree --example embree_loop -- \
//!     $TRACE_BENCH_SCENES/conference/conference.obj.gz \
//!     --eye 1450,400,450 --target=-400,150,-900 --fov 60 --ao 130
//! ```

use embree3::{
    BufferUsage, BuildQuality, Device, Format, GeometryKind, IntersectContext, RayHit, SceneFlags,
};
use std::time::Instant;
use tb_core::{Accel, Query, Ray, TriTestKind, Vec3};
use tb_peers::embree::{EmbreeParams, EmbreePeer};
use tb_scene::camera::Camera;

fn vec3(s: &str) -> Vec3 {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse().expect("a number"))
        .collect();
    assert_eq!(v.len(), 3, "expected x,y,z, got {s}");
    Vec3::new(v[0], v[1], v[2])
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut args = std::env::args().skip(1);
    let path = args.next().expect("usage: embree_loop SCENE [--eye x,y,z] [--target x,y,z] [--up x,y,z] [--fov deg] [--size px] [--repeat n] [--ao distance]");
    let mut cam = Camera {
        eye: Vec3::new(1450.0, 400.0, 450.0),
        target: Vec3::new(-400.0, 150.0, -900.0),
        up: Vec3::Y,
        fov: 60.0,
        width: 1024,
        height: 1024,
        order: Default::default(),
    };
    let mut repeat = 5;
    let mut ao_distance = 130.0f32;
    while let Some(a) = args.next() {
        let (key, val) = match a.split_once('=') {
            Some((k, v)) => (k.to_string(), v.to_string()),
            None => (a.clone(), args.next().expect("a value")),
        };
        match key.as_str() {
            "--eye" => cam.eye = vec3(&val),
            "--target" => cam.target = vec3(&val),
            "--up" => cam.up = vec3(&val),
            "--fov" => cam.fov = val.parse().expect("degrees"),
            "--size" => (cam.width, cam.height) = (val.parse().unwrap(), val.parse().unwrap()),
            "--repeat" => repeat = val.parse().expect("a count"),
            "--ao" => ao_distance = val.parse().expect("a distance"),
            k => panic!("unknown option {k}"),
        }
    }
    let scene = tb_scene::loader::load_file(path.as_ref()).expect("scene");
    let tris = &scene.triangles;
    let rays: Vec<Ray> = tb_scene::rays::primary(&cam);
    println!("{} triangles, {} primary rays", tris.len(), rays.len());

    // The standalone loop: Embree's defaults (no scene flags), build quality high.
    let device = Device::new().expect("embree device");
    let mut escene = device.create_scene().expect("embree scene");
    escene.set_build_quality(BuildQuality::HIGH);
    escene.set_flags(SceneFlags::NONE);
    let mut geom = device
        .create_geometry(GeometryKind::TRIANGLE)
        .expect("geometry");
    geom.set_build_quality(BuildQuality::HIGH);
    {
        let mut v = geom
            .set_new_buffer::<[f32; 3]>(BufferUsage::VERTEX, 0, Format::FLOAT3, 12, tris.len() * 3)
            .expect("vertices");
        for (i, t) in tris.iter().enumerate() {
            v[3 * i] = t.v0.to_array();
            v[3 * i + 1] = t.v1.to_array();
            v[3 * i + 2] = t.v2.to_array();
        }
    }
    {
        let mut ix = geom
            .set_new_buffer::<[u32; 3]>(BufferUsage::INDEX, 0, Format::UINT3, 12, tris.len())
            .expect("indices");
        for i in 0..tris.len() {
            let b = 3 * i as u32;
            ix[i] = [b, b + 1, b + 2];
        }
    }
    let geom = geom.commit();
    escene.attach_geometry(&geom);
    escene.commit();
    let mut out = vec![(0.0f32, 0u32); rays.len()];
    let standalone = |out: &mut [(f32, u32)]| {
        let mut ctx = IntersectContext::incoherent();
        for (r, o) in rays.iter().zip(out.iter_mut()) {
            let mut rh = RayHit::from(embree3::Ray::segment(
                r.origin.to_array(),
                r.dir.to_array(),
                r.tmin,
                r.tmax,
            ));
            escene.intersect(&mut ctx, &mut rh);
            *o = (rh.ray.tfar, rh.hit.primID);
        }
    };

    // The harness's path: the peer behind `dyn Accel`, traced in chunks on one thread.
    let params = EmbreeParams {
        robust: false,
        ..Default::default()
    };
    let peer: Box<dyn Accel> = Box::new(EmbreePeer::build(tris, &params).expect("peer"));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let harness = || {
        pool.install(|| {
            tb_core::par::trace(&*peer, 0, Query::Closest, TriTestKind::Watertight, &rays)
        })
    };

    let (mut t_alone, mut t_peer) = (Vec::new(), Vec::new());
    let mut hits = Vec::new();
    for _ in 0..repeat {
        let t = Instant::now();
        standalone(&mut out);
        t_alone.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        hits = harness();
        t_peer.push(t.elapsed().as_secs_f64());
    }
    let agree = hits
        .iter()
        .zip(&out)
        .filter(|(h, o)| !h.is_hit() || (h.prim == o.1 && h.t == o.0))
        .count();
    let n = rays.len() as f64 / 1e6;
    let (a, p) = (n / median(t_alone), n / median(t_peer));
    println!("standalone rtcIntersect1 loop: {a:.2} MRays/s (median of {repeat})");
    println!("trace-bench embree peer:       {p:.2} MRays/s (median of {repeat})");
    println!(
        "peer / standalone = {:.3}; hits agreeing {agree}/{}",
        p / a,
        rays.len()
    );

    // Interleaved comparison with our BVHs.
    let bvh = |builder, width| -> Box<dyn Accel> {
        let p = tb_bvh::BvhParams {
            builder,
            width,
            ..tb_bvh::BvhParams::binary()
        };
        Box::new(tb_bvh::Bvh::build(tris, &p))
    };
    let contenders: Vec<(&str, Box<dyn Accel>)> = vec![
        ("embree (default flags)", peer),
        ("bvh binned w2", bvh(tb_bvh::Builder::Binned, 2)),
        ("bvh binned w8", bvh(tb_bvh::Builder::Binned, 8)),
        ("bvh sbvh w8", bvh(tb_bvh::Builder::Sbvh, 8)),
    ];
    let closest = Query::Closest;
    let wt = TriTestKind::Watertight;
    let prim_hits = pool.install(|| tb_core::par::trace(&*contenders[1].1, 0, closest, wt, &rays));
    let ao = tb_scene::rays::ao(tris, &rays, &prim_hits, 1, ao_distance, 1);
    let random = tb_scene::rays::random(&scene.bounds, rays.len(), 1);
    for (kind, batch, query) in [
        ("primary", &rays, Query::Closest),
        ("ao", &ao, Query::Any),
        ("random", &random, Query::Closest),
    ] {
        let mut times = vec![Vec::new(); contenders.len()];
        for _ in 0..repeat {
            for (i, (_, a)) in contenders.iter().enumerate() {
                let t = Instant::now();
                pool.install(|| tb_core::par::trace(&**a, 0, query, wt, batch));
                times[i].push(t.elapsed().as_secs_f64());
            }
        }
        let n = batch.len() as f64 / 1e6;
        let e = n / median(times[0].clone());
        for (i, (name, _)) in contenders.iter().enumerate() {
            let m = n / median(times[i].clone());
            println!("{kind:8} {name:24} {m:6.2} MRays/s  {:.2}x embree", m / e);
        }
    }
}
