//! Colour maps.
//!
//! [`ColorMap`] chooses the heat maps' map: `turbo` (the default; Google's improved rainbow,
//! perceptually smoother than jet) and `viridis` (perceptually uniform, colour-blind safe)
//! from the `colorous` crate, and `jet`, the paper's. [`jet`] is the map of the sparse-boxes
//! paper's Figure 5 (per-pixel traversal steps, "dark
//! blue 0, dark red 255+"): piecewise linear through dark blue, blue, cyan, yellow, red, dark
//! red. [`diverging`] is a blue–white–red map for signed differences (blue: the second run does
//! less work than the first, red: more).

/// A sequential colour map for heat maps (config `run.heatmap_colormap`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColorMap {
    /// Turbo (Mikhailov 2019), the default.
    #[default]
    Turbo,
    /// Viridis (van der Walt and Smith 2015), perceptually uniform.
    Viridis,
    /// Jet as the sparse-boxes paper's Figure 5 draws it ([`jet`]).
    Jet,
}

impl ColorMap {
    /// Config names, in declaration order.
    pub const NAMES: &'static [&'static str] = &["turbo", "viridis", "jet"];

    /// The map named `name` (one of [`ColorMap::NAMES`]).
    pub fn parse(name: &str) -> Option<ColorMap> {
        match name {
            "turbo" => Some(ColorMap::Turbo),
            "viridis" => Some(ColorMap::Viridis),
            "jet" => Some(ColorMap::Jet),
            _ => None,
        }
    }

    /// Its config name.
    pub fn name(self) -> &'static str {
        Self::NAMES[self as usize]
    }

    /// The colour of `t` in `[0, 1]` (clamped; NaN maps to 0).
    pub fn eval(self, t: f32) -> [u8; 3] {
        let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
        let g = match self {
            ColorMap::Jet => return jet(t),
            ColorMap::Turbo => colorous::TURBO,
            ColorMap::Viridis => colorous::VIRIDIS,
        };
        let c = g.eval_continuous(t as f64);
        [c.r, c.g, c.b]
    }
}

/// Jet colour of `t` in `[0, 1]` (clamped; NaN maps to 0): `(0, 0, 0.5)` at 0, `(0.5, 0, 0)` at
/// 1, with `r = 1.5 − |4t − 3|`, `g = 1.5 − |4t − 2|`, `b = 1.5 − |4t − 1|`, each clamped to
/// `[0, 1]`.
pub fn jet(t: f32) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let c = |x: f32| to_u8((1.5 - x.abs()).clamp(0.0, 1.0));
    [c(4.0 * t - 3.0), c(4.0 * t - 2.0), c(4.0 * t - 1.0)]
}

/// Diverging colour of `t` in `[−1, 1]` (clamped; NaN maps to 0): dark blue `(0.1, 0.2, 0.6)` at
/// −1, white at 0, dark red `(0.6, 0.05, 0.1)` at +1, linear in between.
pub fn diverging(t: f32) -> [u8; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(-1.0, 1.0) };
    let end = if t < 0.0 {
        [0.1, 0.2, 0.6]
    } else {
        [0.6, 0.05, 0.1]
    };
    let a = t.abs();
    [0, 1, 2].map(|i| to_u8(1.0 + (end[i] - 1.0) * a))
}

/// `x` in `[0, 1]` to 8 bits, rounded.
pub fn to_u8(x: f32) -> u8 {
    (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Linear intensity to an 8-bit sRGB value (IEC 61966-2-1 transfer curve), for shaded images.
pub fn srgb(x: f32) -> u8 {
    let x = if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) };
    let s = if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    };
    to_u8(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jet_ends_and_middle() {
        assert_eq!(jet(0.0), [0, 0, 128]);
        assert_eq!(jet(1.0), [128, 0, 0]);
        assert_eq!(jet(2.0), jet(1.0));
        assert_eq!(jet(f32::NAN), jet(0.0));
        // Green peaks in the middle.
        assert_eq!(jet(0.5)[1], 255);
    }

    #[test]
    fn maps_by_name_and_ends() {
        for &n in ColorMap::NAMES {
            assert_eq!(ColorMap::parse(n).unwrap().name(), n);
        }
        assert_eq!(ColorMap::parse("rainbow"), None);
        assert_eq!(ColorMap::Jet.eval(1.0), jet(1.0));
        // Viridis runs from dark purple to yellow; turbo from near black to dark red.
        let (v0, v1) = (ColorMap::Viridis.eval(0.0), ColorMap::Viridis.eval(1.0));
        assert!(v0[2] > v0[1] && v1[0] > 200 && v1[1] > 200 && v1[2] < 80);
        let (t0, t1) = (ColorMap::Turbo.eval(0.0), ColorMap::Turbo.eval(1.0));
        assert!(t0.iter().map(|&c| c as u32).sum::<u32>() < 160 && t1[0] > 3 * t1[2]);
        assert_eq!(ColorMap::Turbo.eval(f32::NAN), t0);
    }

    #[test]
    fn diverging_is_white_at_zero() {
        assert_eq!(diverging(0.0), [255, 255, 255]);
        let (n, p) = (diverging(-1.0), diverging(1.0));
        assert!(n[2] > n[0] && p[0] > p[2]);
    }

    #[test]
    fn srgb_curve() {
        assert_eq!(srgb(0.0), 0);
        assert_eq!(srgb(1.0), 255);
        assert_eq!(srgb(0.5), 188);
    }
}
