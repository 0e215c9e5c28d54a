//! The `[dynamic]` section ([`crate::experiment::dynamic`] runs it): the dynamic-scene experiment of
//! Pérard-Gayot et al. 2017 (§6.3, Table 4).

use crate::error::HarnessError;
use crate::experiment::config::ctx::Ctx;
use crate::experiment::config::spec::{SceneSpec, StructureSpec};
use serde::Deserialize;
use toml::Spanned;

/// The `[dynamic]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawDynamic {
    frames: Spanned<Vec<u32>>,
    budget_ms: Option<Spanned<Vec<f64>>>,
    lambda_1: Option<Spanned<Vec<f64>>>,
    ratio: Option<Spanned<f64>>,
    resolution: Option<Spanned<[u32; 2]>>,
}

/// A checked `[dynamic]` section.
#[derive(Clone, Debug, PartialEq)]
pub struct DynamicSpec {
    /// Frames to render; each scene's source gets `frame=F`.
    pub frames: Vec<u32>,
    /// Frame budgets, ms (build and primary rays included).
    pub budget_ms: Vec<f64>,
    /// Candidate top-level densities λ_1 of the automatic choice, ascending.
    pub lambda_1: Vec<f64>,
    /// λ_2 = ratio · λ_1 (the paper's 1 : 8).
    pub ratio: f64,
    /// Image size (width, height) of the primary and AO rays.
    pub resolution: (u32, u32),
}

/// The paper's λ_1 range for the automatic choice, [0.01, 0.3] (§6.3).
pub const DEFAULT_LAMBDA_1: [f64; 9] = [0.01, 0.02, 0.03, 0.05, 0.08, 0.12, 0.16, 0.2, 0.3];

/// Check `[dynamic]` against the scenes (built-in, with a `frame` parameter left to the
/// experiment) and structures (each must take `lambda_1` and `lambda_2`).
pub(crate) fn check(
    cx: &Ctx,
    raw: &Spanned<RawDynamic>,
    scenes: &[SceneSpec],
    structures: &[StructureSpec],
) -> Result<DynamicSpec, HarnessError> {
    let d = raw.get_ref();
    let frames = d.frames.get_ref().clone();
    if frames.is_empty() {
        return Err(cx.err(
            d.frames.span(),
            "dynamic.frames",
            "needs at least one frame",
        ));
    }
    let budget_ms = match &d.budget_ms {
        None => vec![100.0, 50.0, 33.3],
        Some(b) => {
            if b.get_ref().is_empty() || b.get_ref().iter().any(|&x| !(x > 0.0 && x.is_finite())) {
                return Err(cx.err(
                    b.span(),
                    "dynamic.budget_ms",
                    "needs one or more positive, finite budgets (ms)",
                ));
            }
            b.get_ref().clone()
        }
    };
    let lambda_1 = match &d.lambda_1 {
        None => DEFAULT_LAMBDA_1.to_vec(),
        Some(l) => {
            let v = l.get_ref().clone();
            if v.is_empty()
                || v.iter().any(|&x| !(x > 0.0 && x.is_finite()))
                || v.windows(2).any(|w| w[0] >= w[1])
            {
                return Err(cx.err(
                    l.span(),
                    "dynamic.lambda_1",
                    "needs one or more positive densities in ascending order",
                ));
            }
            v
        }
    };
    let ratio = match &d.ratio {
        None => 8.0,
        Some(r) if *r.get_ref() > 0.0 && r.get_ref().is_finite() => *r.get_ref(),
        Some(r) => return Err(cx.err(r.span(), "dynamic.ratio", "must be positive and finite")),
    };
    let resolution = match &d.resolution {
        None => (1024, 1024),
        Some(r) => {
            let [w, h] = *r.get_ref();
            if w == 0 || h == 0 || w as u64 * h as u64 > 64 << 20 {
                return Err(cx.err(
                    r.span(),
                    "dynamic.resolution",
                    "width and height must be positive, at most 64M pixels",
                ));
            }
            (w, h)
        }
    };
    check_scenes(cx, raw.span(), scenes)?;
    check_structures(cx, raw.span(), structures)?;
    Ok(DynamicSpec {
        frames,
        budget_ms,
        lambda_1,
        ratio,
        resolution,
    })
}

/// Every scene traces one view, is a built-in animated scene without `frame` and has a
/// camera.
fn check_scenes(
    cx: &Ctx,
    span: std::ops::Range<usize>,
    scenes: &[SceneSpec],
) -> Result<(), HarnessError> {
    for s in scenes {
        if s.label != s.table {
            return Err(cx.err(
                span.clone(),
                "dynamic",
                format!(
                    "scene `{}`: a dynamic experiment traces one view per scene: drop `views`",
                    s.table
                ),
            ));
        }
        let src = &s.scene.source;
        if !src.starts_with("builtin:") || src.contains("frame=") {
            return Err(cx.err(
                span.clone(),
                "dynamic",
                format!(
                    "scene `{}`: a dynamic experiment needs built-in animated scenes (e.g. \
                     builtin:explode, builtin:deform) without a `frame` parameter (the \
                     experiment sets it)",
                    s.label
                ),
            ));
        }
        if s.camera.is_none() {
            return Err(cx.err(
                span.clone(),
                "dynamic",
                format!("scene `{}` has no camera", s.label),
            ));
        }
    }
    Ok(())
}

/// Every structure offers its two densities ([`tb_core::Family::densities`]: the automatic
/// density choice sets them).
fn check_structures(
    cx: &Ctx,
    span: std::ops::Range<usize>,
    structures: &[StructureSpec],
) -> Result<(), HarnessError> {
    if let Some(st) = structures.iter().find(|st| st.family.densities.is_none()) {
        let offering: Vec<&str> = crate::registry::families()
            .iter()
            .filter(|f| f.densities.is_some())
            .map(|f| f.name)
            .collect();
        return Err(cx.err(
            span,
            "dynamic",
            format!(
                "structure `{}` has no lambda_1 and lambda_2 (the automatic density choice \
                 needs them: {})",
                st.family.name,
                offering.join(", ")
            ),
        ));
    }
    Ok(())
}
