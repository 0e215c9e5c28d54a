//! The `[run] images` and `heatmap_max` keys ([`crate::experiment::images`] draws the pictures).

use crate::error::HarnessError;
use crate::experiment::config::ctx::Ctx;
use tb_render::colormap::ColorMap;
use toml::Spanned;

/// The top of the heat maps' colour scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeatMax {
    /// A fixed count for every counter (`heatmap_max = 255`, as in the sparse-boxes paper's
    /// Figure 5).
    Fixed(f32),
    /// Per image, the 99th percentile of its values (`heatmap_max = "auto"`, the default:
    /// small scenes are not one flat colour).
    Auto,
}

/// What `[run] images = true` asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSpec {
    /// The top of the heat maps' colour scale (`run.heatmap_max`).
    pub max: HeatMax,
    /// The heat maps' colour map (`run.heatmap_colormap`).
    pub colormap: ColorMap,
}

/// Check `run.images`, `run.heatmap_max` and `run.heatmap_colormap`.
pub(crate) fn check(
    cx: &Ctx,
    images: Option<bool>,
    max: Option<&Spanned<toml::Value>>,
    colormap: Option<&Spanned<String>>,
) -> Result<Option<ImageSpec>, HarnessError> {
    let colormap = match colormap {
        None => ColorMap::default(),
        Some(c) => {
            let m = ColorMap::parse(c.get_ref()).ok_or_else(|| {
                cx.err(
                    c.span(),
                    "run.heatmap_colormap",
                    format!(
                        "unknown colour map `{}` (one of: {})",
                        c.get_ref(),
                        ColorMap::NAMES.join(", ")
                    ),
                )
            })?;
            if images != Some(true) {
                return Err(cx.err(
                    c.span(),
                    "run.heatmap_colormap",
                    "has no effect without `images = true`",
                ));
            }
            m
        }
    };
    let max = match max {
        None => HeatMax::Auto,
        Some(v) => {
            let bad = || {
                cx.err(
                    v.span(),
                    "run.heatmap_max",
                    format!(
                        "expected a positive count or \"auto\", found {}",
                        v.get_ref()
                    ),
                )
            };
            let m = match v.get_ref() {
                toml::Value::String(s) if s == "auto" => HeatMax::Auto,
                toml::Value::Integer(n) if *n > 0 => HeatMax::Fixed(*n as f32),
                toml::Value::Float(f) if *f > 0.0 && f.is_finite() => HeatMax::Fixed(*f as f32),
                _ => return Err(bad()),
            };
            if images != Some(true) {
                return Err(cx.err(
                    v.span(),
                    "run.heatmap_max",
                    "has no effect without `images = true`",
                ));
            }
            m
        }
    };
    Ok(images
        .unwrap_or(false)
        .then_some(ImageSpec { max, colormap }))
}
