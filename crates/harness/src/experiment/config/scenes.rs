//! The `[[scene]]` tables: ray kinds, camera (over the scene's default view), light, AO,
//! path and random settings; the scene loaded.

use super::{parse_validate, scene_label, Ctx, RawScene, RawView, SceneSpec, Validate};
use crate::error::HarnessError;
use std::path::Path;
use std::sync::Arc;
use tb_core::Vec3;
use tb_scene::rays::RayKind;
use tb_scene::{Camera, Scene, View};

/// A viewpoint of a scene table: its label, camera and light.
type Viewpoint = (String, Option<Camera>, Option<Vec3>);

/// Check one scene table and load the scene: one spec, or one per entry of `views` (sharing
/// the loaded scene); `Ok(Err(note))` when an optional file scene is absent and skipped.
pub(super) fn check_scene(
    cx: &Ctx,
    s: &RawScene,
    scenes_root: &Path,
    validate: Validate,
    progress: &mut dyn FnMut(&str),
) -> Result<Result<Vec<SceneSpec>, String>, HarnessError> {
    let src = s.source.get_ref();
    let span = s.source.span();
    let kinds = check_rays(cx, s)?;
    // Check the file exists before loading anything (cheap, reports every config error
    // before the first expensive load).
    if let Err(note) = check_file(cx, s, scenes_root)? {
        return Ok(Err(note));
    }
    progress(src);
    let mut scene = load_scene(cx, s, scenes_root)?;
    let view = scene.view.clone();
    let needs_camera = kinds.iter().any(|k| {
        matches!(
            k,
            RayKind::Primary | RayKind::Shadow | RayKind::Ao | RayKind::Path(_)
        )
    });
    let table = label_of(s);
    let table_light = s
        .light
        .map(Vec3::from)
        .or(view.as_ref().and_then(|v| v.light));
    let views = check_views(cx, s, view.as_ref(), &table, table_light)?;
    if needs_camera {
        if let Some((label, _, _)) = views.iter().find(|(_, c, _)| c.is_none()) {
            return Err(cx.err(
                span,
                "scene.camera",
                format!(
                    "{label}: primary, shadow, ao and path rays need a camera: this scene has no default view"
                ),
            ));
        }
    }
    if kinds.contains(&RayKind::Stress) && scene.own_rays.is_empty() {
        return Err(cx.err(
            s.rays.as_ref().map(|r| r.span()).unwrap_or(span.clone()),
            "scene.rays",
            "ray kind `stress` needs a stress scene (builtin:stress/NAME) that comes with its own rays",
        ));
    }
    let enclosed = s.enclose == Some(true);
    if enclosed {
        // Torres et al. 2012 §6: the Bunny inside a box, so that no ray leaves the scene
        // (every view's eye and light inside it).
        let mut points: Vec<Vec3> = Vec::new();
        for (_, c, l) in &views {
            points.extend(c.iter().map(|c| c.eye));
            points.extend(*l);
        }
        scene.enclose(&points, 0.05);
    }
    let settings = check_settings(cx, s, &kinds, view.as_ref(), scene.bounds.diagonal())?;
    let scene_validate = match &s.validate {
        None => validate,
        Some(v) => parse_validate(cx, v, "scene.validate")?,
    };
    let scene = Arc::new(scene);
    Ok(Ok(views
        .into_iter()
        .map(|(label, camera, light)| SceneSpec {
            label,
            table: table.clone(),
            scene: scene.clone(),
            rays: kinds.clone(),
            camera,
            light,
            ao_samples: settings.ao_samples,
            ao_distance: settings.ao_distance,
            bounces: settings.bounces,
            random_count: settings.random_count,
            validate: scene_validate,
        })
        .collect()))
}

/// [`check_scene`]'s checks that need no scene loaded (`config::check_offline`): the ray
/// kinds, the file's existence, the AO, path and random settings, the camera's size and field
/// of view where the table gives them, and the views' names.
pub(super) fn check_offline(
    cx: &Ctx,
    s: &RawScene,
    scenes_root: &Path,
) -> Result<(), HarnessError> {
    let kinds = check_rays(cx, s)?;
    if check_file(cx, s, scenes_root)?.is_err() {
        // Absent and optional: skipped when the run comes.
        return Ok(());
    }
    // The defaults that depend on the scene (its view, its diagonal) are the scene's own
    // and checked when it loads; what the table gives is checked here.
    check_settings(cx, s, &kinds, None, 1.0)?;
    if let Some(c) = &s.camera {
        let cam = c.get_ref();
        if cam.width == Some(0) || cam.height == Some(0) {
            return Err(cx.err(
                c.span(),
                "scene.camera",
                "width and height must be positive",
            ));
        }
        if cam.width.unwrap_or(1) as u64 * cam.height.unwrap_or(1) as u64 > 64 << 20 {
            return Err(cx.err(c.span(), "scene.camera", "more than 64M pixels"));
        }
        if let Some(fov) = cam.fov.filter(|f| !(*f > 0.0 && *f < 180.0)) {
            return Err(cx.err(
                c.span(),
                "scene.camera",
                format!("fov must be in (0, 180) degrees, got {fov}"),
            ));
        }
    }
    Ok(())
}

/// The table's ray kinds (`rays`, primary when absent), without repeats.
fn check_rays(cx: &Ctx, s: &RawScene) -> Result<Vec<RayKind>, HarnessError> {
    let mut kinds = Vec::new();
    match &s.rays {
        None => kinds.push(RayKind::Primary),
        Some(r) => {
            for k in r.get_ref() {
                let kind = RayKind::parse(k).ok_or_else(|| {
                    cx.err(
                        r.span(),
                        "scene.rays",
                        format!(
                            "unknown ray kind `{k}` (known: {})",
                            RayKind::NAMES.join(", ")
                        ),
                    )
                })?;
                if !kinds.contains(&kind) {
                    kinds.push(kind);
                }
            }
            if kinds.is_empty() {
                return Err(cx.err(r.span(), "scene.rays", "needs at least one ray kind"));
            }
        }
    }
    Ok(kinds)
}

/// Check that a file scene exists under the scenes root; `Ok(Err(note))` when it is absent
/// and optional.
fn check_file(
    cx: &Ctx,
    s: &RawScene,
    scenes_root: &Path,
) -> Result<Result<(), String>, HarnessError> {
    let src = s.source.get_ref();
    if !src.starts_with("builtin:") {
        let full = tb_scene::source::resolve(src, scenes_root);
        if full.is_dir() {
            return Err(cx.err(
                s.source.span(),
                "scene.source",
                format!(
                    "{} is a directory, not a scene file (.obj, .obj.gz, .gltf, .glb)",
                    full.display()
                ),
            ));
        }
        if !full.is_file() && s.optional == Some(true) {
            return Ok(Err(format!(
                "{}: skipped, not found under the scenes root {} (optional = true)",
                s.name.clone().unwrap_or_else(|| scene_label(src)),
                scenes_root.display()
            )));
        }
        if !full.is_file() {
            return Err(cx.err(
                s.source.span(),
                "scene.source",
                format!(
                    "{} not found (scenes root {}; set --scenes-root or TRACE_BENCH_SCENES)",
                    full.display(),
                    scenes_root.display()
                ),
            ));
        }
    }
    Ok(Ok(()))
}

/// Load the table's scene, check it has triangles and apply its `inset`.
fn load_scene(cx: &Ctx, s: &RawScene, scenes_root: &Path) -> Result<Scene, HarnessError> {
    let span = s.source.span();
    let mut scene = tb_scene::load(s.source.get_ref(), scenes_root)
        .map_err(|e| cx.err(span.clone(), "scene.source", e.to_string()))?;
    if scene.triangles.is_empty() {
        return Err(cx.err(span, "scene.source", "the scene has no triangles"));
    }
    if let Some(inset) = &s.inset {
        // Pérard-Gayot et al. 2017 §6.2, Figure 8: the scene scaled down inside itself.
        let i = inset.get_ref();
        scene
            .inset(i.scale, i.at.map(Vec3::from))
            .map_err(|m| cx.err(inset.span(), "scene.inset", m))?;
    }
    Ok(scene)
}

/// The viewpoints: the table's own camera and light, or each entry of `views` over them.
fn check_views(
    cx: &Ctx,
    s: &RawScene,
    view: Option<&View>,
    table: &str,
    table_light: Option<Vec3>,
) -> Result<Vec<Viewpoint>, HarnessError> {
    Ok(match &s.views {
        None => vec![(
            table.to_owned(),
            check_camera(cx, s, view, None)?,
            table_light,
        )],
        Some(vs) => {
            if vs.get_ref().is_empty() {
                return Err(cx.err(vs.span(), "scene.views", "needs at least one view"));
            }
            let mut out: Vec<Viewpoint> = Vec::new();
            for (i, v) in vs.get_ref().iter().enumerate() {
                let name = v.name.clone().unwrap_or_else(|| (i + 1).to_string());
                if name.is_empty() || name.contains(['@', '/', '\\']) || name.trim() != name {
                    return Err(cx.err(
                        vs.span(),
                        "scene.views.name",
                        format!("view name `{name}`: give a non-empty name without `@`, `/`, `\\` or surrounding spaces"),
                    ));
                }
                let label = format!("{table}@{name}");
                if out.iter().any(|(l, _, _)| *l == label) {
                    return Err(cx.err(
                        vs.span(),
                        "scene.views.name",
                        format!("two views are named `{name}`"),
                    ));
                }
                let cam = check_camera(cx, s, view, Some((v, &name)))?;
                out.push((label, cam, v.light.map(Vec3::from).or(table_light)));
            }
            out
        }
    })
}

/// The AO, path and random settings of a scene table, checked.
struct RaySettings {
    ao_samples: u32,
    ao_distance: f32,
    bounces: u32,
    random_count: usize,
}

/// Check the table's `ao`, `path` and `random` settings (defaults from the scene's view and
/// its diagonal `diag`).
fn check_settings(
    cx: &Ctx,
    s: &RawScene,
    kinds: &[RayKind],
    view: Option<&View>,
    diag: f32,
) -> Result<RaySettings, HarnessError> {
    let span = s.source.span();
    let ao_distance =
        s.ao.as_ref()
            .and_then(|a| a.distance)
            .or(view.map(|v| v.ao_distance))
            .unwrap_or(0.04 * diag);
    // Checked where AO rays are asked for (a scene scaled to 1e30 has an infinite default
    // distance, which matters only to AO rays).
    let ao_given = s.ao.as_ref().and_then(|a| a.distance).is_some();
    if (ao_given || kinds.contains(&RayKind::Ao)) && !(ao_distance > 0.0 && ao_distance.is_finite())
    {
        return Err(cx.err(span, "scene.ao.distance", "must be positive and finite"));
    }
    let ao_samples = s.ao.as_ref().and_then(|a| a.samples).unwrap_or(4);
    if ao_samples == 0 || ao_samples > 1024 {
        return Err(cx.err(span, "scene.ao.samples", "must be in 1..=1024"));
    }
    let bounces = s.path.as_ref().map(|p| p.bounces).unwrap_or(2);
    if bounces == 0 || bounces > 64 {
        return Err(cx.err(span, "scene.path.bounces", "must be in 1..=64"));
    }
    let random_count = s.random.as_ref().map(|r| r.count).unwrap_or(1 << 16) as usize;
    if random_count == 0 || random_count > 1 << 28 {
        return Err(cx.err(span, "scene.random.count", "must be in 1..=2^28"));
    }
    Ok(RaySettings {
        ao_samples,
        ao_distance,
        bounces,
        random_count,
    })
}

/// The label of a scene table: its `name`, else derived from the source (`-boxed` when
/// enclosed).
pub(super) fn label_of(s: &RawScene) -> String {
    s.name.clone().unwrap_or_else(|| {
        let mut l = scene_label(s.source.get_ref());
        if s.inset.is_some() {
            l.push_str("-inset");
        }
        if s.enclose == Some(true) {
            format!("{l}-boxed")
        } else {
            l
        }
    })
}

/// What the shard planner knows of a scene table without loading the scene
/// ([`crate::cluster::shard`]): its label, estimated triangles, the rays of each batch (the camera's
/// pixels, 256 x 256 where the table gives no size: the built-in scenes' default view) and the
/// rays the oracle checks. `None` when the file is absent (optional scenes are skipped; the
/// others fail the config check).
pub(super) fn estimate(
    s: &RawScene,
    scenes_root: &Path,
    validate: Validate,
) -> Option<crate::cluster::shard::SceneEstimate> {
    let mut triangles = crate::cluster::shard::triangles_of(s.source.get_ref(), scenes_root)?;
    if s.inset.is_some() {
        // The scene and its scaled-down copy.
        triangles *= 2;
    }
    let cam = s.camera.as_ref().map(|c| c.get_ref());
    let pixels = cam.and_then(|c| c.width).unwrap_or(256) as u64
        * cam.and_then(|c| c.height).unwrap_or(256) as u64;
    let mut kinds = Vec::new();
    for k in s
        .rays
        .as_ref()
        .map(|r| r.get_ref().clone())
        .unwrap_or_default()
    {
        if let Some(k) = RayKind::parse(&k) {
            if !kinds.contains(&k) {
                kinds.push(k);
            }
        }
    }
    if kinds.is_empty() {
        kinds.push(RayKind::Primary);
    }
    // Every view traces the camera's batches; random and stress rays, which do not depend on
    // the camera, only the first view.
    let views = s.views.as_ref().map_or(1, |v| v.get_ref().len().max(1));
    let mut batch_rays = Vec::new();
    for k in kinds {
        let per_view = if matches!(k, RayKind::Random | RayKind::Stress) {
            1
        } else {
            views
        };
        let start = batch_rays.len();
        match k {
            RayKind::Primary | RayKind::Shadow => batch_rays.push(pixels),
            RayKind::Ao => {
                batch_rays.push(pixels * s.ao.as_ref().and_then(|a| a.samples).unwrap_or(4) as u64)
            }
            RayKind::Path(_) => {
                let b = s.path.as_ref().map_or(2, |p| p.bounces);
                batch_rays.extend(std::iter::repeat_n(pixels, b as usize));
            }
            RayKind::Random => {
                batch_rays.push(s.random.as_ref().map_or(1 << 16, |r| r.count) as u64)
            }
            RayKind::Stress => batch_rays.push(1000),
        }
        let one: Vec<u64> = batch_rays[start..].to_vec();
        for _ in 1..per_view {
            batch_rays.extend(&one);
        }
    }
    // A value the check will refuse prices as the run's (the run never starts).
    let validate = s
        .validate
        .as_ref()
        .and_then(|v| super::validate_of(v.get_ref()))
        .unwrap_or(validate);
    let validated_rays = batch_rays
        .iter()
        .map(|&n| match validate {
            Validate::Off => 0,
            Validate::All => n,
            Validate::Sample(k) => n.min(k as u64),
        })
        .sum();
    Some(crate::cluster::shard::SceneEstimate {
        label: label_of(s),
        triangles,
        batch_rays,
        validated_rays,
    })
}

/// The camera of a scene: the config's, filling what it leaves out from the default view;
/// for a view of `views` (`over`: the entry and its name), the entry's eye, target, up and
/// fov over that.
fn check_camera(
    cx: &Ctx,
    s: &RawScene,
    view: Option<&View>,
    over: Option<(&RawView, &str)>,
) -> Result<Option<Camera>, HarnessError> {
    let base = view.map(|v| v.camera);
    let rc = s.camera.as_ref().map(|c| c.get_ref());
    if rc.is_none() && over.is_none() {
        return Ok(base);
    }
    let (span, prefix, whose) = match (over, &s.camera, &s.views) {
        (Some((_, name)), _, Some(vs)) => (
            vs.span(),
            "scene.views",
            format!(" for view `{name}` (not in the view, the table's camera or a default view)"),
        ),
        (_, Some(c), _) => (
            c.span(),
            "scene.camera",
            " (the scene has no default view)".to_string(),
        ),
        _ => (s.source.span(), "scene.camera", String::new()),
    };
    let v = over.map(|(v, _)| v);
    let pick = |o: Option<[f32; 3]>,
                t: Option<[f32; 3]>,
                b: Option<Vec3>,
                key: &str|
     -> Result<Vec3, HarnessError> {
        o.or(t).map(Vec3::from).or(b).ok_or_else(|| {
            cx.err(
                span.clone(),
                &format!("{prefix}.{key}"),
                format!("missing{whose}"),
            )
        })
    };
    let cam = Camera {
        eye: pick(
            v.and_then(|v| v.eye),
            rc.and_then(|c| c.eye),
            base.map(|b| b.eye),
            "eye",
        )?,
        target: pick(
            v.and_then(|v| v.target),
            rc.and_then(|c| c.target),
            base.map(|b| b.target),
            "target",
        )?,
        up: pick(
            v.and_then(|v| v.up),
            rc.and_then(|c| c.up),
            Some(base.map(|b| b.up).unwrap_or(Vec3::Y)),
            "up",
        )?,
        fov: v
            .and_then(|v| v.fov)
            .or(rc.and_then(|c| c.fov))
            .or(base.map(|b| b.fov))
            .ok_or_else(|| {
                cx.err(
                    span.clone(),
                    &format!("{prefix}.fov"),
                    format!("missing{whose}"),
                )
            })?,
        width: rc
            .and_then(|c| c.width)
            .or(base.map(|b| b.width))
            .unwrap_or(512),
        height: rc
            .and_then(|c| c.height)
            .or(base.map(|b| b.height))
            .unwrap_or(512),
        order: rc
            .and_then(|c| c.order)
            .or(base.map(|b| b.order))
            .unwrap_or_default(),
    };
    cam.check().map_err(|m| cx.err(span.clone(), prefix, m))?;
    if cam.width as u64 * cam.height as u64 > 64 << 20 {
        return Err(cx.err(span, prefix, "more than 64M pixels"));
    }
    Ok(Some(cam))
}
