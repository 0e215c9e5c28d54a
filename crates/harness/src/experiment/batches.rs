//! The ray batches of a scene, generated once per scene: primary, shadow, ao, path1..k,
//! random, stress.

use crate::experiment::config::SceneSpec;
use tb_core::{HitRecord, Query, Ray, TriTestKind};
use tb_scene::rays::{self, RayKind};

/// One ray batch of a scene: a kind and its rays (or why there are none).
pub struct RayBatch {
    /// The ray kind's name in results (`primary`, `path1`, …).
    pub name: String,
    /// Closest or any hit, as the kind asks.
    pub query: Query,
    /// The rays (empty for a skipped batch).
    pub rays: Vec<Ray>,
    /// Set when the batch was skipped (no rays traced); the row's note.
    pub skipped: Option<String>,
}

/// Generate the batches a scene asks for, in the order primary, shadow, ao, path1..k, random,
/// stress. Secondary rays start at hits found with the watertight test by the default BVH, so
/// they are the same whatever structures and triangle tests the experiment runs; `gen` holds
/// that BVH once built, so the views of one table build it once. `first_view`: random and
/// stress rays do not depend on the camera, so only a table's first view traces them.
pub fn generate_batches(
    spec: &SceneSpec,
    seed: u64,
    gen: &mut Option<Box<dyn tb_core::Accel>>,
    first_view: bool,
    notes: &mut Vec<String>,
) -> Vec<RayBatch> {
    let tris = &spec.scene.triangles;
    let wants = |k: RayKind| {
        spec.rays.contains(&k) && (first_view || !matches!(k, RayKind::Random | RayKind::Stress))
    };
    let secondary = wants(RayKind::Shadow) || wants(RayKind::Ao) || wants(RayKind::PATH);
    let mut out = Vec::new();
    let primary = match (&spec.camera, wants(RayKind::Primary) || secondary) {
        (Some(c), true) => rays::primary(c),
        _ => Vec::new(),
    };
    if wants(RayKind::Primary) {
        out.push(RayBatch {
            name: RayKind::Primary.name(),
            query: Query::Closest,
            rays: primary.clone(),
            skipped: None,
        });
    }
    if secondary {
        if first_view {
            notes.push(format!(
                "{}: secondary rays start at primary hits found by the binary binned bvh (builder=binned, width=2, leaf_cost=linear; watertight test)",
                spec.table
            ));
        }
        let gen = gen.get_or_insert_with(|| crate::registry::generator(tris));
        let hits = tb_core::par::trace(
            gen.as_ref(),
            0,
            Query::Closest,
            TriTestKind::Watertight,
            &primary,
        );
        let nhit = hits.iter().filter(|h| h.is_hit()).count();
        if wants(RayKind::Shadow) {
            out.push(shadow_batch(spec, &primary, &hits, notes));
        }
        if wants(RayKind::Ao) {
            let r = rays::ao(
                tris,
                &primary,
                &hits,
                spec.ao_samples,
                spec.ao_distance,
                seed,
            );
            let skipped = if nhit == 0 { no_hits("ao") } else { None };
            out.push(RayBatch {
                name: RayKind::Ao.name(),
                query: Query::Any,
                rays: r,
                skipped,
            });
        }
        if wants(RayKind::PATH) {
            out.extend(path_batches(spec, gen.as_ref(), &primary, hits, seed));
        }
    }
    if wants(RayKind::Random) {
        let r = rays::random(&spec.scene.bounds, spec.random_count, seed);
        out.push(RayBatch {
            name: RayKind::Random.name(),
            query: Query::Closest,
            rays: r,
            skipped: None,
        });
    }
    if wants(RayKind::Stress) {
        out.push(RayBatch {
            name: RayKind::Stress.name(),
            query: Query::Closest,
            rays: spec.scene.own_rays.clone(),
            skipped: None,
        });
    }
    out
}

/// The note of a secondary batch without rays: no primary ray hit the scene.
fn no_hits(what: &str) -> Option<String> {
    Some(format!("no {what} rays: no primary ray hits the scene"))
}

/// The shadow rays from the primary hits to the scene's light (skipped, with a note, when it
/// has none).
fn shadow_batch(
    spec: &SceneSpec,
    primary: &[Ray],
    hits: &[HitRecord],
    notes: &mut Vec<String>,
) -> RayBatch {
    match spec.light {
        Some(light) => {
            let r = rays::shadow(&spec.scene.triangles, primary, hits, light);
            let skipped = if r.is_empty() {
                no_hits("shadow")
            } else {
                None
            };
            RayBatch {
                name: RayKind::Shadow.name(),
                query: Query::Any,
                rays: r,
                skipped,
            }
        }
        None => {
            let why =
                "skipped: the scene has no light (set `light` in the scene table)".to_string();
            notes.push(format!("{}: shadow rays {why}", spec.label));
            RayBatch {
                name: RayKind::Shadow.name(),
                query: Query::Any,
                rays: Vec::new(),
                skipped: Some(why),
            }
        }
    }
}

/// The path batches path1..k: each bounce from the hits of the one before, found by `gen`.
fn path_batches(
    spec: &SceneSpec,
    gen: &dyn tb_core::Accel,
    primary: &[Ray],
    hits: Vec<HitRecord>,
    seed: u64,
) -> Vec<RayBatch> {
    let tris = &spec.scene.triangles;
    let mut out = Vec::new();
    let (mut prev_rays, mut prev_hits) = (primary.to_vec(), hits);
    for b in 1..=spec.bounces {
        let r = rays::bounce(tris, &prev_rays, &prev_hits, seed.wrapping_add(b as u64));
        let skipped = if r.is_empty() {
            Some(format!("no rays: no ray of bounce {} hit the scene", b - 1))
        } else {
            None
        };
        let h = tb_core::par::trace(gen, 0, Query::Closest, TriTestKind::Watertight, &r);
        out.push(RayBatch {
            name: RayKind::Path(b).name(),
            query: Query::Closest,
            rays: r.clone(),
            skipped,
        });
        prev_rays = r;
        prev_hits = h;
    }
    out
}
