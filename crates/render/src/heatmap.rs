//! Heat maps: per-pixel counter images of primary rays in false colour with a labelled colour
//! bar, as in the sparse-boxes paper's Figure 5 (traversal steps per pixel, dark blue 0 to dark
//! red at 255 or more), and difference maps of two runs on the same rays.

use crate::colormap::{diverging, jet};
use crate::image::{Channels, Rgb8};
use tb_core::TraversalStats;

/// Per-ray values in generation order to a row-major image: value `i` goes to `pixels[i]`
/// (a camera's [`tb_scene::Camera::pixels`], row or Morton order).
pub fn to_row_major(pixels: &[(u32, u32)], values: &[f32], width: u32, height: u32) -> Vec<f32> {
    let mut out = vec![0.0; width as usize * height as usize];
    for (&(x, y), &v) in pixels.iter().zip(values) {
        if x < width && y < height {
            out[y as usize * width as usize + x as usize] = v;
        }
    }
    out
}

/// Every counter of [`TraversalStats`] ([`tb_core::COUNTERS`]) as a row-major `f32` channel
/// named as in the result columns (`interior`, `leaves`, `prims`, …). `stats[i]`
/// belongs to `pixels[i]`.
pub fn counter_channels(
    pixels: &[(u32, u32)],
    stats: &[TraversalStats],
    width: u32,
    height: u32,
) -> Channels {
    let mut c = Channels::new(width, height);
    for (k, counter) in tb_core::COUNTERS.iter().enumerate() {
        let v: Vec<f32> = stats.iter().map(|s| s.values()[k] as f32).collect();
        c.push(counter.name, to_row_major(pixels, &v, width, height))
            .expect("one value per pixel");
    }
    c
}

/// 3x5 bitmap glyphs for colour-bar labels, one row per `u8` (bit 2 the left column).
fn glyph(ch: char) -> [u8; 5] {
    match ch {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '+' => [0, 2, 7, 2, 0],
        '-' => [0, 0, 7, 0, 0],
        '.' => [0, 0, 0, 0, 2],
        'e' => [0, 7, 7, 4, 7],
        _ => [0, 0, 0, 0, 0],
    }
}

/// Draw `text` with its top-left corner at `(x, y)`, each glyph cell `s` pixels.
fn draw_text(img: &mut Rgb8, text: &str, x: u32, y: u32, s: u32, colour: [u8; 3]) {
    for (i, ch) in text.chars().enumerate() {
        let g = glyph(ch);
        let x0 = x + i as u32 * 4 * s;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3u32 {
                if bits & (4 >> col) != 0 {
                    for dy in 0..s {
                        for dx in 0..s {
                            img.set(x0 + col * s + dx, y + row as u32 * s + dy, colour);
                        }
                    }
                }
            }
        }
    }
}

/// A compact label for a scale value: integers as such, others with up to 3 significant digits.
pub fn label(v: f32) -> String {
    if v == v.round() && v.abs() < 1e6 {
        format!("{}", v as i64)
    } else if v.abs() >= 0.01 && v.abs() < 1e4 {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.1e}")
    }
}

/// `img` (width x height, row-major colours) with a vertical colour bar to its right: the bar
/// shows `map(t)` for `t` from `lo` (bottom) to `hi` (top), with the labels given for bottom,
/// middle and top. White background, black labels.
fn with_bar(
    colours: &[[u8; 3]],
    width: u32,
    height: u32,
    map: &dyn Fn(f32) -> [u8; 3],
    (lo, hi): (f32, f32),
    labels: [String; 3],
) -> Rgb8 {
    let s = (height / 160).max(1);
    let gap = 4 * s;
    let bar = (width / 24).max(8 * s);
    let chars = labels.iter().map(|l| l.chars().count()).max().unwrap_or(1) as u32;
    let pad = 3 * s; // room above the top label and below the bottom one
    let h = height + 2 * pad;
    let w = width + gap + bar + 2 * s + chars * 4 * s + 2 * s;
    let mut img = Rgb8::filled(w, h, [255, 255, 255]);
    for y in 0..height {
        for x in 0..width {
            img.set(x, y + pad, colours[(y * width + x) as usize]);
        }
    }
    let bx = width + gap;
    for y in 0..height {
        let t = 1.0 - y as f32 / (height.max(2) - 1) as f32;
        let c = map(lo + t * (hi - lo));
        for x in 0..bar {
            img.set(bx + x, y + pad, c);
        }
    }
    let lx = bx + bar + 2 * s;
    let ys = [height + pad - 1, pad + height / 2, pad];
    for (l, y) in labels.iter().zip(ys) {
        // Tick, then the label centred on it.
        for x in 0..s {
            img.set(bx + bar + x, y, [0, 0, 0]);
        }
        draw_text(&mut img, l, lx, y.saturating_sub(2 * s), s, [0, 0, 0]);
    }
    img
}

/// A false-colour heat map of row-major `values` with its colour bar: jet from 0 (dark blue) to
/// `max` (dark red); values at or above `max` are dark red (the top label reads `max+`).
pub fn heatmap(values: &[f32], width: u32, height: u32, max: f32) -> Rgb8 {
    let max = if max > 0.0 { max } else { 1.0 };
    let colours: Vec<[u8; 3]> = values.iter().map(|&v| jet(v / max)).collect();
    with_bar(
        &colours,
        width,
        height,
        &|t| jet(t / max),
        (0.0, max),
        [label(0.0), label(max / 2.0), format!("{}+", label(max))],
    )
}

/// A difference map `b − a` of two row-major images of the same rays: blue where `b` is below
/// `a`, white where equal, red where above, saturating at `±max` (default: the 99th
/// percentile of `|b − a|`, at least 1, so a few outliers do not wash out the map). Returns the
/// image and the scale used.
pub fn diff_map(a: &[f32], b: &[f32], width: u32, height: u32, max: Option<f32>) -> (Rgb8, f32) {
    let d: Vec<f32> = a.iter().zip(b).map(|(x, y)| y - x).collect();
    let max = max.filter(|m| *m > 0.0).unwrap_or_else(|| {
        let abs: Vec<f32> = d.iter().map(|v| v.abs()).collect();
        percentile99(&abs)
    });
    let colours: Vec<[u8; 3]> = d.iter().map(|&v| diverging(v / max)).collect();
    let img = with_bar(
        &colours,
        width,
        height,
        &|t| diverging(t / max),
        (-max, max),
        [label(-max), label(0.0), format!("+{}", label(max))],
    );
    (img, max)
}

/// The 99th percentile of `values` (a robust automatic heat-map scale, at least 1).
pub fn percentile99(values: &[f32]) -> f32 {
    let mut v: Vec<f32> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return 1.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    v[((v.len() - 1) as f64 * 0.99).round() as usize].max(1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_values_land_on_their_pixels() {
        let pixels = [(1, 0), (0, 0), (1, 1), (0, 1)];
        let v = to_row_major(&pixels, &[10.0, 20.0, 30.0, 40.0], 2, 2);
        assert_eq!(v, vec![20.0, 10.0, 40.0, 30.0]);
        let stats = [TraversalStats {
            steps: 5,
            prims: 2,
            ..Default::default()
        }; 4];
        let c = counter_channels(&pixels, &stats, 2, 2);
        assert_eq!(c.names().len(), tb_core::N_COUNTERS);
        assert_eq!(c.get("steps").unwrap(), &[5.0; 4]);
        assert_eq!(c.get("prims").unwrap(), &[2.0; 4]);
    }

    #[test]
    fn heatmap_colours_and_bar() {
        let (w, h) = (32, 16);
        let values: Vec<f32> = (0..w * h).map(|i| (i % w) as f32 * 20.0).collect();
        let img = heatmap(&values, w, h, 255.0);
        assert!(img.width > w && img.height >= h);
        let pad = 3;
        // Pixel (0, 0) is 0 steps: dark blue; pixel (31, 0) is 620 ≥ 255: dark red.
        assert_eq!(img.get(0, pad), jet(0.0));
        assert_eq!(img.get(31, pad), jet(1.0));
        // Bar: top dark red, bottom dark blue.
        let bx = w + 4;
        assert_eq!(img.get(bx, pad), jet(1.0));
        assert_eq!(img.get(bx, pad + h - 1), jet(0.0));
        // Some black label pixels exist.
        assert!(img.data.chunks(3).any(|c| c == [0, 0, 0]));
    }

    #[test]
    fn diff_is_signed() {
        let a = [1.0, 5.0, 3.0, 3.0];
        let b = [3.0, 1.0, 3.0, 3.0];
        let (img, max) = diff_map(&a, &b, 2, 2, None);
        assert_eq!(max, 4.0);
        let pad = 3;
        let (more, less, same) = (img.get(0, pad), img.get(1, pad), img.get(0, pad + 1));
        assert!(more[0] > more[2], "b > a is red");
        assert!(less[2] > less[0], "b < a is blue");
        assert_eq!(same, [255, 255, 255]);
    }

    #[test]
    fn labels_and_percentile() {
        assert_eq!(label(255.0), "255");
        assert_eq!(label(0.125), "0.125");
        assert_eq!(label(2.5e-4), "2.5e-4");
        let v: Vec<f32> = (0..=100).map(|i| i as f32).collect();
        assert_eq!(percentile99(&v), 99.0);
        assert_eq!(percentile99(&[]), 1.0);
    }
}
