//! The `[run] images` and `heatmap_max` keys ([`crate::images`] draws the pictures).

use super::Ctx;
use crate::error::HarnessError;
use toml::Spanned;

/// The top of the heat maps' colour scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HeatMax {
    /// A fixed count for every counter (`heatmap_max = 255`, the default, as in the
    /// sparse-boxes paper's Figure 5).
    Fixed(f32),
    /// Per image, the 99th percentile of its values (`heatmap_max = "auto"`).
    Auto,
}

/// What `[run] images = true` asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSpec {
    pub max: HeatMax,
}

/// Check `run.images` and `run.heatmap_max`.
pub(super) fn check(
    cx: &Ctx,
    images: Option<bool>,
    max: Option<&Spanned<toml::Value>>,
) -> Result<Option<ImageSpec>, HarnessError> {
    let max = match max {
        None => HeatMax::Fixed(255.0),
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
    Ok(images.unwrap_or(false).then_some(ImageSpec { max }))
}
