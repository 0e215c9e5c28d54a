//! The `[convergence]` section ([`crate::experiment::convergence`] renders it).

use crate::error::HarnessError;
use crate::experiment::config::ctx::Ctx;
use crate::experiment::config::spec::SceneSpec;
use serde::Deserialize;
use std::path::PathBuf;
use toml::Spanned;

/// The `[convergence]` table as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RawConvergence {
    integrators: Option<Spanned<Vec<String>>>,
    passes: Option<Spanned<u32>>,
    spp_per_pass: Option<Spanned<u32>>,
    schedule: Option<Spanned<String>>,
    reference_spp: Option<Spanned<u32>>,
    frame_budget_ms: Option<Spanned<Vec<f64>>>,
    max_seconds: Option<Spanned<f64>>,
    albedo: Option<Spanned<f32>>,
    resolution: Option<Spanned<[u32; 2]>>,
    cache: Option<String>,
}

impl RawConvergence {
    /// Where the reference images are cached (`cache`, default `results/.cache`).
    pub fn cache_dir(&self) -> PathBuf {
        PathBuf::from(self.cache.as_deref().unwrap_or(DEFAULT_CACHE))
    }
}

/// The reference images' cache folder where `[convergence] cache` is not given.
pub const DEFAULT_CACHE: &str = "results/.cache";

/// Which integrator a convergence run uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IntegratorKind {
    /// Ambient occlusion with the scene's `ao.distance`.
    Ao,
    /// Diffuse path tracing with the scene's `path.bounces` and the section's `albedo`.
    Path,
}

/// A checked `[convergence]` section.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergenceSpec {
    /// The integrators rendered (`integrators`, default both).
    pub integrators: Vec<IntegratorKind>,
    /// Passes per render.
    pub passes: u32,
    /// Samples per pixel of the first pass (and of every pass with the linear schedule).
    pub spp_per_pass: u32,
    /// Whether each pass doubles the samples so far (else adds `spp_per_pass`).
    pub doubling: bool,
    /// Samples per pixel of the reference image.
    pub reference_spp: u32,
    /// Frame budgets, ms (build time included).
    pub frame_budget_ms: Vec<f64>,
    /// No further pass starts once a render has taken this long.
    pub max_seconds: f64,
    /// Grey albedo of every surface for path tracing.
    pub albedo: f32,
    /// Overrides the cameras' resolution.
    pub resolution: Option<(u32, u32)>,
    /// Directory of cached reference images.
    pub cache: PathBuf,
}

impl ConvergenceSpec {
    /// Samples per pixel added by pass `k` (0-based).
    pub fn pass_spp(&self, k: u32) -> u32 {
        if self.doubling && k > 0 {
            self.spp_per_pass.saturating_mul(1 << (k - 1).min(30))
        } else {
            self.spp_per_pass
        }
    }
}

/// Check a `[convergence]` table; every scene must have a camera.
pub(crate) fn check(
    cx: &Ctx,
    raw: &Spanned<RawConvergence>,
    scenes: &[SceneSpec],
) -> Result<ConvergenceSpec, HarnessError> {
    let r = raw.get_ref();
    let span = raw.span();
    let integrators = check_integrators(cx, r)?;
    let passes = check_int(cx, &r.passes, "passes", 8, 64)?;
    let spp_per_pass = check_int(cx, &r.spp_per_pass, "spp_per_pass", 1, 1 << 16)?;
    let reference_spp = check_int(cx, &r.reference_spp, "reference_spp", 1024, 1 << 20)?;
    let doubling = check_schedule(cx, r)?;
    let spec_tmp = ConvergenceSpec {
        integrators: Vec::new(),
        passes,
        spp_per_pass,
        doubling,
        reference_spp,
        frame_budget_ms: Vec::new(),
        max_seconds: 0.0,
        albedo: 0.0,
        resolution: None,
        cache: PathBuf::new(),
    };
    let total: u64 = (0..passes).map(|k| spec_tmp.pass_spp(k) as u64).sum();
    if total > 1 << 20 {
        return Err(cx.err(
            span,
            "convergence.passes",
            format!("{passes} passes reach {total} samples per pixel (at most 2^20)"),
        ));
    }
    let frame_budget_ms = check_frame_budgets(cx, r)?;
    let max_seconds = match &r.max_seconds {
        None => 60.0,
        Some(s) if *s.get_ref() > 0.0 && s.get_ref().is_finite() => *s.get_ref(),
        Some(s) => {
            return Err(cx.err(
                s.span(),
                "convergence.max_seconds",
                "must be positive and finite",
            ))
        }
    };
    let albedo = match &r.albedo {
        None => 0.7,
        Some(a) if (0.0..1.0).contains(a.get_ref()) => *a.get_ref(),
        Some(a) => {
            return Err(cx.err(
                a.span(),
                "convergence.albedo",
                format!("{} is outside [0, 1)", a.get_ref()),
            ))
        }
    };
    let resolution = check_resolution(cx, r)?;
    for s in scenes {
        if s.camera.is_none() {
            return Err(cx.err(
                span.clone(),
                "convergence",
                format!(
                    "scene `{}` has no camera (convergence renders need one)",
                    s.label
                ),
            ));
        }
    }
    Ok(ConvergenceSpec {
        integrators,
        frame_budget_ms,
        max_seconds,
        albedo,
        resolution,
        cache: r.cache_dir(),
        ..spec_tmp
    })
}

/// The section's `integrators` (both when absent), without repeats.
fn check_integrators(cx: &Ctx, r: &RawConvergence) -> Result<Vec<IntegratorKind>, HarnessError> {
    let mut integrators = Vec::new();
    match &r.integrators {
        None => integrators = vec![IntegratorKind::Ao, IntegratorKind::Path],
        Some(list) => {
            for n in list.get_ref() {
                let k = match n.as_str() {
                    "ao" => IntegratorKind::Ao,
                    "path" => IntegratorKind::Path,
                    other => {
                        return Err(cx.err(
                            list.span(),
                            "convergence.integrators",
                            format!("unknown integrator `{other}` (known: ao, path)"),
                        ))
                    }
                };
                if !integrators.contains(&k) {
                    integrators.push(k);
                }
            }
            if integrators.is_empty() {
                return Err(cx.err(
                    list.span(),
                    "convergence.integrators",
                    "needs at least one integrator",
                ));
            }
        }
    }
    Ok(integrators)
}

/// A count of the section (`convergence.KEY`) in 1..=`max`, `default` when absent.
fn check_int(
    cx: &Ctx,
    v: &Option<Spanned<u32>>,
    key: &str,
    default: u32,
    max: u32,
) -> Result<u32, HarnessError> {
    match v {
        None => Ok(default),
        Some(s) if (1..=max).contains(s.get_ref()) => Ok(*s.get_ref()),
        Some(s) => Err(cx.err(
            s.span(),
            &format!("convergence.{key}"),
            format!("{} is out of range 1..={max}", s.get_ref()),
        )),
    }
}

/// Whether the `schedule` doubles the samples each pass (the default) or is linear.
fn check_schedule(cx: &Ctx, r: &RawConvergence) -> Result<bool, HarnessError> {
    Ok(match &r.schedule {
        None => true,
        Some(s) => match s.get_ref().as_str() {
            "doubling" => true,
            "linear" => false,
            other => {
                return Err(cx.err(
                    s.span(),
                    "convergence.schedule",
                    format!("unknown schedule `{other}` (known: doubling, linear)"),
                ))
            }
        },
    })
}

/// The `frame_budget_ms` list, each a positive time.
fn check_frame_budgets(cx: &Ctx, r: &RawConvergence) -> Result<Vec<f64>, HarnessError> {
    let mut frame_budget_ms = Vec::new();
    if let Some(b) = &r.frame_budget_ms {
        for &ms in b.get_ref() {
            if !(ms > 0.0 && ms.is_finite()) {
                return Err(cx.err(
                    b.span(),
                    "convergence.frame_budget_ms",
                    format!("{ms} is not a positive time"),
                ));
            }
            frame_budget_ms.push(ms);
        }
    }
    Ok(frame_budget_ms)
}

/// The `resolution` overriding the cameras', at most 16M pixels.
fn check_resolution(cx: &Ctx, r: &RawConvergence) -> Result<Option<(u32, u32)>, HarnessError> {
    Ok(match &r.resolution {
        None => None,
        Some(s) => {
            let [w, h] = *s.get_ref();
            if w == 0 || h == 0 || w as u64 * h as u64 > 16 << 20 {
                return Err(cx.err(
                    s.span(),
                    "convergence.resolution",
                    "width and height must be positive, at most 16M pixels",
                ));
            }
            Some((w, h))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schedules() {
        let mut s = ConvergenceSpec {
            integrators: vec![IntegratorKind::Ao],
            passes: 4,
            spp_per_pass: 2,
            doubling: true,
            reference_spp: 64,
            frame_budget_ms: vec![],
            max_seconds: 1.0,
            albedo: 0.5,
            resolution: None,
            cache: PathBuf::new(),
        };
        let d: Vec<u32> = (0..4).map(|k| s.pass_spp(k)).collect();
        assert_eq!(d, [2, 2, 4, 8], "totals 2, 4, 8, 16");
        s.doubling = false;
        let l: Vec<u32> = (0..4).map(|k| s.pass_spp(k)).collect();
        assert_eq!(l, [2, 2, 2, 2]);
    }
}
