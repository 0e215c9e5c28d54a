//! Named views: viewpoints written once in a views file (`views_file = "views.toml"` at a
//! config's top level, a path from the config's folder) and referred to by name from the scene
//! tables, `view = "conference"`, or from their `views` entries, `{ view = "conference" }`.
//!
//! A named view gives the eye, target, up, field of view and, optionally, the light; it fills
//! what the table's `camera` (or the entry) leaves out, before any other check, so that the rest
//! of the config checking sees a table as if its camera had been written out in full.

use super::{Ctx, RawConfig, RawScene};
use crate::error::HarnessError;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use toml::Spanned;

/// One named view of a views file.
#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
struct NamedView {
    eye: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov: f32,
    light: Option<[f32; 3]>,
}

/// The views file a config read: its path and text (part of the config's hash and of
/// results.json, so that a changed view is a changed config).
#[derive(Clone, Debug)]
pub struct ViewsFile {
    /// The file as the config names it, joined to the config's folder.
    pub path: PathBuf,
    /// Its text as read.
    pub text: String,
}

/// Fill the scene tables' cameras and lights and their `views` entries from the named views
/// they refer to; `Ok(None)` when the config names no views file. `config` is the config
/// file (its folder is where `views_file` is found).
pub(super) fn resolve(
    cx: &Ctx,
    raw: &mut RawConfig,
    config: &Path,
) -> Result<Option<ViewsFile>, HarnessError> {
    let refers = raw.scenes.iter().any(|s| {
        s.view.is_some()
            || s.views
                .as_ref()
                .is_some_and(|vs| vs.get_ref().iter().any(|v| v.view.is_some()))
    });
    let Some(name) = raw.views_file.as_ref() else {
        if let Some(s) = raw.scenes.iter().find(|s| s.view.is_some()) {
            let span = s.view.as_ref().map_or(0..0, |v| v.span());
            return Err(cx.err(
                span,
                "scene.view",
                "names a view, but the config has no `views_file`",
            ));
        }
        if refers {
            return Err(cx.err(
                0..0,
                "scene.views.view",
                "names a view, but the config has no `views_file`",
            ));
        }
        return Ok(None);
    };
    let path = config
        .parent()
        .unwrap_or(Path::new(""))
        .join(name.get_ref());
    let text = std::fs::read_to_string(&path).map_err(|e| {
        cx.err(
            name.span(),
            "views_file",
            format!("cannot read {}: {e}", path.display()),
        )
    })?;
    let views: BTreeMap<String, NamedView> =
        toml::from_str(&text).map_err(|e| super::syntax_error(&path, &text, &e))?;
    tb_results::finite::check_toml(&path, &text)?;
    for s in &mut raw.scenes {
        fill_table(cx, s, &views)?;
    }
    Ok(Some(ViewsFile { path, text }))
}

/// The named view `name` (at `span` of the config), or an error listing the known names.
fn named<'v>(
    cx: &Ctx,
    views: &'v BTreeMap<String, NamedView>,
    name: &str,
    span: std::ops::Range<usize>,
    key: &str,
) -> Result<&'v NamedView, HarnessError> {
    views.get(name).ok_or_else(|| {
        let known: Vec<&str> = views.keys().map(String::as_str).collect();
        cx.err(
            span,
            key,
            format!(
                "no view `{name}` in the views file (it has: {})",
                known.join(", ")
            ),
        )
    })
}

/// Fill one scene table from its `view` and its entries from theirs.
fn fill_table(
    cx: &Ctx,
    s: &mut RawScene,
    views: &BTreeMap<String, NamedView>,
) -> Result<(), HarnessError> {
    if let Some(name) = &s.view {
        let v = named(cx, views, name.get_ref(), name.span(), "scene.view")?;
        let span = s.camera.as_ref().map_or(name.span(), |c| c.span());
        let mut cam = s.camera.take().map(Spanned::into_inner).unwrap_or_default();
        cam.eye = cam.eye.or(Some(v.eye));
        cam.target = cam.target.or(Some(v.target));
        cam.up = cam.up.or(v.up);
        cam.fov = cam.fov.or(Some(v.fov));
        s.camera = Some(Spanned::new(span, cam));
        s.light = s.light.or(v.light);
    }
    let Some(entries) = s.views.as_mut() else {
        return Ok(());
    };
    let span = entries.span();
    for e in entries.get_mut() {
        let Some(name) = e.view.as_deref() else {
            continue;
        };
        let v = named(cx, views, name, span.clone(), "scene.views.view")?;
        e.name = e.name.take().or_else(|| Some(name.to_owned()));
        e.eye = e.eye.or(Some(v.eye));
        e.target = e.target.or(Some(v.target));
        e.up = e.up.or(v.up);
        e.fov = e.fov.or(Some(v.fov));
        e.light = e.light.or(v.light);
    }
    Ok(())
}
