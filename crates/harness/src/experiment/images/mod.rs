//! `[run] images = true`: pictures of where the cost goes, for primary rays.
//!
//! Per scene with a camera, `images/<scene>/render.{exr,png}`: the primary hits of the default
//! BVH shaded `|n·d|` grey (EXR channel `Y`, PNG sRGB). Per scene x structure x parameter set x
//! traversal x triangle test, one counting pass over the same primary rays writes
//! `images/<scene>/<structure>[-<params>]-<traversal>-<test>.exr` (every counter of
//! [`tb_core::TraversalStats`] as a raw `f32` channel named as its column stem: `interior`,
//! `leaves`, `prims`, …) and one false-colour PNG per counter of [`PNG_COUNTERS`] the
//! traversal reports, `…-<test>-<counter>.png`: a title naming scene, structure, the swept
//! parameters, traversal, test and counter, and a colour bar (`heatmap_colormap`, turbo by
//! default, `jet` as the sparse-boxes paper's Figure 5; 0 to `heatmap_max` and above).
//! `<params>` is `key=value` of the parameters that vary in the structure's sweep (absent when
//! none does); `images/index.csv` maps every file to its scene, structure, full parameters,
//! traversal, test, counter and scale.
//! `trace-bench diff A.exr B.exr` draws the difference of two such EXRs.

pub mod config;

use crate::error::HarnessError;
use crate::experiment::config::SceneSpec;
use crate::experiment::images::config::{HeatMax, ImageSpec};
use crate::experiment::runner::build::BuildDone;
use std::fs::OpenOptions;
use std::path::{Path, PathBuf};
use tb_core::{Accel, Query, Ray, TriTestKind};
use tb_render::colormap::srgb;
use tb_render::heatmap::{
    counter_channels, heatmap, heatmaps_side_by_side, percentile99, to_row_major,
};
use tb_render::{Channels, Rgb8};
use tb_scene::{rays, Camera};

/// Counters drawn as PNG heat maps (every counter is in the EXR).
pub const PNG_COUNTERS: [&str; 4] = ["interior", "leaves", "prims", "steps"];

/// A file-name-safe form of a label: characters other than ASCII letters, digits, `.`, `_`,
/// `-`, `=` and `,` become `_` (`stress/flat?x=1` → `stress_flat_x=1`).
pub fn safe_name(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-' | '=' | ',') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// The directory of a scene's images under the run's output directory.
pub fn scene_dir(out: &Path, scene: &str) -> PathBuf {
    out.join("images").join(safe_name(scene))
}

fn err(e: impl std::fmt::Display) -> HarnessError {
    HarnessError::other(e.to_string())
}

/// Append one line to `images/index.csv` (header first when the file is new).
fn index(out: &Path, fields: [&str; 8]) -> Result<(), HarnessError> {
    let path = out.join("images").join("index.csv");
    let new = !path.is_file();
    let f = OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .map_err(|e| HarnessError::io(&path, e))?;
    let mut w = csv::WriterBuilder::new().has_headers(false).from_writer(f);
    if new {
        w.write_record([
            "file",
            "scene",
            "structure",
            "params",
            "traversal",
            "triangle_test",
            "counter",
            "scale_max",
        ])
        .map_err(|e| HarnessError::io(&path, e))?;
    }
    w.write_record(fields)
        .map_err(|e| HarnessError::io(&path, e))?;
    w.flush().map_err(|e| HarnessError::io(&path, e))
}

fn rel(out: &Path, p: &Path) -> String {
    p.strip_prefix(out).unwrap_or(p).display().to_string()
}

/// Write `images/<scene>/render.{exr,png}` (primary hits of the default BVH, `|n·d|` grey).
/// Returns a note when the scene has no camera (nothing written).
pub fn write_scene(spec: &SceneSpec, out: &Path) -> Result<Option<String>, HarnessError> {
    let Some(cam) = spec.camera else {
        return Ok(Some(format!(
            "{}: no images: the scene has no camera",
            spec.label
        )));
    };
    let dir = scene_dir(out, &spec.label);
    std::fs::create_dir_all(&dir).map_err(|e| HarnessError::io(&dir, e))?;
    let tris = &spec.scene.triangles;
    let pixels = cam.pixels();
    let prim = rays::primary(&cam);
    let gen = crate::registry::generator(tris);
    let hits = tb_core::par::trace(
        gen.as_ref(),
        0,
        Query::Closest,
        TriTestKind::Watertight,
        &prim,
    );
    let grey = to_row_major(
        &pixels,
        &tb_render::shade::eye_light(tris, &prim, &hits),
        cam.width,
        cam.height,
    );
    let mut c = Channels::new(cam.width, cam.height);
    c.push("Y", grey.clone()).map_err(err)?;
    let exr = dir.join("render.exr");
    c.write_exr(&exr).map_err(err)?;
    let mut png = Rgb8::filled(cam.width, cam.height, [0, 0, 0]);
    for (i, v) in grey.iter().enumerate() {
        let g = srgb(*v);
        png.set(i as u32 % cam.width, i as u32 / cam.width, [g, g, g]);
    }
    let pngp = dir.join("render.png");
    png.write_png(&pngp).map_err(err)?;
    for p in [&exr, &pngp] {
        index(
            out,
            [
                &rel(out, p),
                &spec.label,
                crate::registry::GENERATOR_LABEL,
                "",
                "",
                "",
                "Y",
                "",
            ],
        )?;
    }
    Ok(None)
}

/// `key=value` pairs (joined by `,`) of `set`'s parameters whose values differ across `sweep`
/// (empty when none does): what tells a build's files apart from its sweep siblings'.
pub fn varying_tag(sweep: &[String], set: &str) -> String {
    let pairs = |s: &str| -> Vec<(String, String)> {
        tb_results::pairs::pairs(s)
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    };
    let all: Vec<Vec<(String, String)>> = sweep.iter().map(|s| pairs(s)).collect();
    pairs(set)
        .into_iter()
        .filter(|(k, v)| {
            all.iter()
                .any(|p| p.iter().find(|(pk, _)| pk == k).map(|(_, pv)| pv) != Some(v))
        })
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Each traversal's name and per-pixel values of one counter.
type Panels<'a> = Vec<(&'a str, Vec<f32>)>;

/// Per triangle test and counter, each traversal's values: drawn side by side after.
type PanelSets = Vec<(TriTestKind, &'static str, Panels<'static>)>;

/// What the heat maps of one build share: the scene, the image settings, the structure and
/// where its files go.
struct BuildMaps<'a> {
    spec: &'a SceneSpec,
    images: &'a ImageSpec,
    out: &'a Path,
    accel: &'a dyn Accel,
    params: &'a str,
    cam: Camera,
    /// The scene's image directory.
    dir: PathBuf,
    /// The structure's name, with its tag.
    name: String,
}

/// One built structure's heat maps (`done`): for each traversal and triangle test, count over
/// the primary rays and write the EXR and the PNGs. `tag` is [`varying_tag`] of its
/// parameters. Returns a note when nothing is written (no camera, or a structure without
/// counters).
pub fn write_build(
    done: &BuildDone<'_>,
    images: &ImageSpec,
    out: &Path,
    tag: &str,
) -> Result<Option<String>, HarnessError> {
    let BuildDone {
        scene: spec,
        accel,
        params,
        traversals,
        tests,
        ..
    } = *done;
    let Some(cam) = spec.camera else {
        return Ok(None);
    };
    if traversals
        .iter()
        .all(|&ti| accel.traversals()[ti].counters.is_empty())
    {
        return Ok(Some(format!(
            "{}: no heat maps for {}: it exposes no counters",
            spec.label,
            accel.name()
        )));
    }
    let dir = scene_dir(out, &spec.label);
    std::fs::create_dir_all(&dir).map_err(|e| HarnessError::io(&dir, e))?;
    let pixels = cam.pixels();
    let prim = rays::primary(&cam);
    let name = if tag.is_empty() {
        accel.name().to_string()
    } else {
        format!("{}-{tag}", accel.name())
    };
    let maps = BuildMaps {
        spec,
        images,
        out,
        accel,
        params,
        cam,
        dir,
        name,
    };
    let mut panels: PanelSets = Vec::new();
    for &ti in traversals {
        for &tri in tests {
            let keep = traversals.len() > 1;
            maps.write_traversal(ti, tri, &pixels, &prim, keep.then_some(&mut panels))?;
        }
    }
    // The traversals side by side on one scale (Figure 5 of Havran and Bittner 2007): the
    // fixed `heatmap_max`, else the largest of the panels' 99th percentiles.
    for (tri, counter, p) in panels.iter().filter(|(_, _, p)| p.len() > 1) {
        maps.write_side_by_side(*tri, counter, p)?;
    }
    Ok(None)
}

impl BuildMaps<'_> {
    /// Count traversal `ti` with triangle test `tri` over the primary rays and write its EXR
    /// and PNGs; keep each PNG counter's values in `panels` when given.
    fn write_traversal(
        &self,
        ti: usize,
        tri: TriTestKind,
        pixels: &[(u32, u32)],
        prim: &[Ray],
        mut panels: Option<&mut PanelSets>,
    ) -> Result<(), HarnessError> {
        let (spec, images, out, accel, params) =
            (self.spec, self.images, self.out, self.accel, self.params);
        let (cam, dir, name) = (&self.cam, &self.dir, &self.name);
        let info = accel.traversals()[ti];
        let tname = info.name;
        let (_, stats) = tb_core::par::count(accel, ti, Query::Closest, tri, prim);
        let c = counter_channels(pixels, &stats, cam.width, cam.height);
        let stem = safe_name(&format!("{name}-{tname}-{}", tri.name()));
        let exr = dir.join(format!("{stem}.exr"));
        c.write_exr(&exr).map_err(err)?;
        let row = |file: &Path, counter: &str, max: String| {
            index(
                out,
                [
                    &rel(out, file),
                    &spec.label,
                    accel.name(),
                    params,
                    tname,
                    tri.name(),
                    counter,
                    &max,
                ],
            )
        };
        row(&exr, "all", String::new())?;
        let reported = |n: &str| {
            (tb_core::COUNTERS.iter())
                .position(|d| d.name == n)
                .is_some_and(|i| info.counters.contains(i))
        };
        for counter in PNG_COUNTERS.into_iter().filter(|n| reported(n)) {
            let v = c.get(counter).expect("every counter is a channel");
            let max = match images.max {
                HeatMax::Fixed(m) => m,
                HeatMax::Auto => percentile99(v),
            };
            let png = dir.join(format!("{stem}-{counter}.png"));
            let what = tb_core::COUNTERS
                .iter()
                .find(|d| d.name == counter)
                .map_or(counter, |d| d.doc);
            let mut title = format!("{} · {name}", spec.label);
            title += &format!(" · {tname} · {}\n{counter}: {what}", tri.name());
            heatmap(v, cam.width, cam.height, max, images.colormap, &title)
                .write_png(&png)
                .map_err(err)?;
            row(&png, counter, max.to_string())?;
            if let Some(panels) = panels.as_deref_mut() {
                let at = match panels
                    .iter()
                    .position(|(t, n, _)| *t == tri && *n == counter)
                {
                    Some(i) => i,
                    None => {
                        panels.push((tri, counter, Vec::new()));
                        panels.len() - 1
                    }
                };
                panels[at].2.push((tname, v.to_vec()));
            }
        }
        Ok(())
    }

    /// Draw the traversals' values `p` of one triangle test and counter side by side on one
    /// scale.
    fn write_side_by_side(
        &self,
        tri: TriTestKind,
        counter: &str,
        p: &Panels,
    ) -> Result<(), HarnessError> {
        let (spec, images, out, accel, params) =
            (self.spec, self.images, self.out, self.accel, self.params);
        let (cam, dir, name) = (&self.cam, &self.dir, &self.name);
        let max = match images.max {
            HeatMax::Fixed(m) => m,
            HeatMax::Auto => p.iter().map(|(_, v)| percentile99(v)).fold(0.0, f32::max),
        };
        let names: Vec<&str> = p.iter().map(|(n, _)| *n).collect();
        let stem = safe_name(&format!("{name}-{}-{counter}-side-by-side", tri.name()));
        let png = dir.join(format!("{stem}.png"));
        let what = tb_core::COUNTERS
            .iter()
            .find(|d| d.name == counter)
            .map_or(counter, |d| d.doc);
        let title = format!(
            "{} · {name} · {} · {}\n{counter}: {what}",
            spec.label,
            names.join(" | "),
            tri.name()
        );
        let refs: Vec<(&str, &[f32])> = p.iter().map(|(n, v)| (*n, v.as_slice())).collect();
        heatmaps_side_by_side(&refs, cam.width, cam.height, max, images.colormap, &title)
            .write_png(&png)
            .map_err(err)?;
        index(
            out,
            [
                &rel(out, &png),
                &spec.label,
                accel.name(),
                params,
                &names.join("|"),
                tri.name(),
                counter,
                &max.to_string(),
            ],
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tags_name_only_the_swept_parameters() {
        let sweep = ["bins=8;leaf=4".to_string(), "bins=16;leaf=4".to_string()];
        assert_eq!(varying_tag(&sweep, &sweep[1]), "bins=16");
        assert_eq!(varying_tag(&sweep[..1], &sweep[0]), "");
        assert_eq!(varying_tag(&[], ""), "");
    }

    #[test]
    fn safe_names() {
        assert_eq!(safe_name("stress/flat?x=1"), "stress_flat_x=1");
        assert_eq!(safe_name("conference"), "conference");
        assert_eq!(safe_name("a.b-c_d"), "a.b-c_d");
    }
}
