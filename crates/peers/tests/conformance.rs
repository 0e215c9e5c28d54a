//! The peers through the shared oracle suite: every stress scene and the small procedural
//! scenes, every ray kind, against brute force with the watertight test.
//!
//! Asserted: on the procedural scenes, primary and random rays (origins well away from
//! surfaces) agree with brute force exactly. Printed as findings, not asserted: the stress
//! scenes and the secondary rays (origins offset just off a surface, rays in triangle planes,
//! shared edges, 1e±6 scales), where a library whose box or triangle test is not conservative
//! misses hits. obvhs and bvh test their candidates with our triangle test; Embree uses its
//! own, so its rows also include its intersector's edge decisions.

#![allow(dead_code, unused_imports)]

use tb_core::{Accel, TriTestKind, Triangle};
use tb_scene::conformance::{check_scenes, format_table, suite_scenes};

fn report(name: &str, build: &dyn Fn(&[Triangle]) -> Box<dyn Accel>) {
    let scenes = suite_scenes();
    let res = check_scenes(&scenes, build, TriTestKind::Watertight);
    print!("{name}\n{}", format_table(&res));
    let total: usize = res.iter().map(|r| r.mismatches).sum();
    let rays: usize = res.iter().map(|r| r.rays).sum();
    println!("{name}: {total} mismatches in {rays} rays over all scenes and kinds (finding)");
    let bad: Vec<_> = res
        .iter()
        .filter(|r| {
            !r.scene.starts_with("stress/")
                && (r.ray_kind == "primary" || r.ray_kind == "random")
                && r.mismatches > 0
        })
        .collect();
    assert!(
        bad.is_empty(),
        "{name} disagrees with brute force on primary/random rays: {bad:#?}"
    );
}

#[cfg(feature = "obvhs")]
#[test]
fn obvhs_against_the_oracle() {
    report("obvhs", &|t: &[Triangle]| -> Box<dyn Accel> {
        Box::new(tb_peers::obvhs::ObvhsPeer::build(
            t,
            tb_peers::obvhs::Preset::Medium,
        ))
    });
}

#[cfg(feature = "bvh")]
#[test]
fn bvh_rs_against_the_oracle() {
    report("bvh-rs", &|t: &[Triangle]| -> Box<dyn Accel> {
        Box::new(tb_peers::bvh_rs::BvhRsPeer::build(t))
    });
}

#[cfg(feature = "embree")]
#[test]
fn embree_against_the_oracle() {
    use tb_peers::embree::{EmbreeParams, EmbreePeer};
    report("embree", &|t: &[Triangle]| -> Box<dyn Accel> {
        Box::new(EmbreePeer::build(t, &EmbreeParams::default()).expect("embree build"))
    });
}
