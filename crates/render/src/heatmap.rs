//! Heat maps: per-pixel counter images of primary rays in false colour with a title and a
//! labelled colour bar (the sparse-boxes paper's Figure 5 draws traversal steps per pixel in
//! jet, dark blue 0 to dark red at 255 or more; turbo and viridis are the alternatives), and
//! difference maps of two runs on the same rays.

use crate::colormap::{diverging, ColorMap};
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

/// The 8x8 glyph of `ch` (ASCII and Latin-1 from the `font8x8` crate; others are blank).
fn glyph(ch: char) -> [u8; 8] {
    let c = ch as usize;
    match c {
        0..=127 => font8x8::legacy::BASIC_LEGACY[c],
        0xA0..=0xFF => font8x8::legacy::LATIN_LEGACY[c - 0xA0],
        _ => [0; 8],
    }
}

/// Draw `text` with its top-left corner at `(x, y)` in the 8x8 bitmap font of the `font8x8`
/// crate, each font pixel an `s` x `s` block; clipped to the image.
fn draw_text(img: &mut Rgb8, text: &str, x: u32, y: u32, s: u32, colour: [u8; 3]) {
    for (i, ch) in text.chars().enumerate() {
        let g = glyph(ch);
        let x0 = x + i as u32 * 8 * s;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..8u32 {
                // Bit 0 is the leftmost pixel of the row.
                if bits & (1 << col) != 0 {
                    for dy in 0..s {
                        for dx in 0..s {
                            let (px, py) = (x0 + col * s + dx, y + row as u32 * s + dy);
                            if px < img.width && py < img.height {
                                img.set(px, py, colour);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Text scale for an image `height` pixels tall: 8-pixel glyphs up to 384 rows, then one more
/// font pixel per 256 rows (32-pixel glyphs at 1024).
fn text_scale(height: u32) -> u32 {
    (height / 256).max(1)
}

/// `title` split into lines of at most `chars` characters at its newlines and at spaces, a
/// ` · ` separator kept at the end of a line (a word longer than a line is cut).
fn wrap(title: &str, chars: usize) -> Vec<String> {
    if title.contains('\n') {
        return title.split('\n').flat_map(|t| wrap(t, chars)).collect();
    }
    let chars = chars.max(8);
    let mut words: Vec<String> = Vec::new();
    for w in title.split(' ').filter(|w| !w.is_empty()) {
        match words.last_mut() {
            Some(last) if w == "·" => *last += " ·",
            _ => words.push(w.to_string()),
        }
    }
    let mut lines: Vec<String> = Vec::new();
    let mut cur = String::new();
    for word in &words {
        let (n, w) = (cur.chars().count(), word.chars().count());
        if n > 0 && n + 1 + w > chars {
            lines.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(word);
        while cur.chars().count() > chars {
            lines.push(cur.chars().take(chars).collect());
            cur = cur.chars().skip(chars).collect();
        }
    }
    if !cur.is_empty() {
        lines.push(cur);
    }
    lines
}

/// Tick values for a scale from `lo` to `hi`: multiples of a round step (1, 2 or 5 x 10^k)
/// giving three to six ticks, always including both ends.
fn nice_ticks(lo: f32, hi: f32) -> Vec<f32> {
    let span = (hi - lo).abs().max(f32::MIN_POSITIVE);
    let raw = span / 4.0;
    let mag = 10f32.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 5.0)
        .unwrap_or(10.0 * mag);
    let mut v = vec![lo];
    let mut t = (lo / step).floor() * step + step;
    while t < hi - 0.3 * step {
        if t > lo + 0.3 * step {
            v.push(t);
        }
        t += step;
    }
    v.push(hi);
    v
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

/// `img` (width x height, row-major colours) under a title and with a vertical colour bar to
/// its right: the bar shows `map(v)` for `v` from `lo` (bottom) to `hi` (top), with a tick and a
/// label at each of `ticks` (bottom to top, evenly spaced). White background, black text in
/// the 8x8 font, scaled with the image.
fn with_bar(
    colours: &[[u8; 3]],
    width: u32,
    height: u32,
    map: &dyn Fn(f32) -> [u8; 3],
    (lo, hi): (f32, f32),
    ticks: &[(f32, String)],
    title: &str,
) -> Rgb8 {
    let s = text_scale(height);
    let glyph = 8 * s;
    let gap = 2 * glyph / 3;
    let bar = (width / 20).max(2 * glyph);
    let chars = ticks
        .iter()
        .map(|(_, l)| l.chars().count())
        .max()
        .unwrap_or(1) as u32;
    let w = width + gap + bar + s + glyph + chars * glyph + glyph / 2;
    let lines = if title.is_empty() {
        Vec::new()
    } else {
        wrap(title, (w / glyph).saturating_sub(1) as usize)
    };
    let head = lines.len() as u32 * (glyph + 2 * s) + if lines.is_empty() { 0 } else { glyph / 2 };
    let pad = glyph / 2 + s; // room above the top label and below the bottom one
    let h = head + height + 2 * pad;
    let mut img = Rgb8::filled(w, h, [255, 255, 255]);
    for (i, l) in lines.iter().enumerate() {
        draw_text(
            &mut img,
            l,
            glyph / 2,
            glyph / 4 + i as u32 * (glyph + 2 * s),
            s,
            [0, 0, 0],
        );
    }
    let top = head + pad;
    for y in 0..height {
        for x in 0..width {
            img.set(x, y + top, colours[(y * width + x) as usize]);
        }
    }
    let bx = width + gap;
    for y in 0..height {
        let t = 1.0 - y as f32 / (height.max(2) - 1) as f32;
        let c = map(lo + t * (hi - lo));
        for x in 0..bar {
            img.set(bx + x, y + top, c);
        }
    }
    let lx = bx + bar + s + glyph;
    for (v, l) in ticks {
        let f = ((v - lo) / (hi - lo)).clamp(0.0, 1.0);
        let y = top + (height - 1) - ((height - 1) as f32 * f).round() as u32;
        // Tick, then the label centred on it.
        for x in 0..glyph / 3 {
            for dy in 0..s {
                img.set(bx + bar + s + x, (y + dy).min(h - 1), [0, 0, 0]);
            }
        }
        draw_text(&mut img, l, lx, y.saturating_sub(glyph / 2), s, [0, 0, 0]);
    }
    img
}

/// [`nice_ticks`] with labels, the first prefixed and the last suffixed.
fn labelled(lo: f32, hi: f32, first_prefix: &str, last_suffix: &str) -> Vec<(f32, String)> {
    let t = nice_ticks(lo, hi);
    let n = t.len();
    t.into_iter()
        .enumerate()
        .map(|(i, v)| {
            let l = label(v);
            let l = if i == 0 {
                format!("{first_prefix}{l}")
            } else {
                l
            };
            let l = if i + 1 == n {
                format!("{l}{last_suffix}")
            } else {
                l
            };
            (v, l)
        })
        .collect()
}

/// A false-colour heat map of row-major `values` with its colour bar and `title` (e.g. scene,
/// structure, parameters, traversal, counter): `map` from 0 to `max`; values at or above
/// `max` take the top colour (the top label reads `max+`).
pub fn heatmap(
    values: &[f32],
    width: u32,
    height: u32,
    max: f32,
    map: ColorMap,
    title: &str,
) -> Rgb8 {
    let max = if max > 0.0 { max } else { 1.0 };
    let colours: Vec<[u8; 3]> = values.iter().map(|&v| map.eval(v / max)).collect();
    with_scale(&colours, width, height, max, map, title)
}

/// [`with_bar`] for a colour map from 0 to `max` (the top label reads `max+`).
fn with_scale(
    colours: &[[u8; 3]],
    width: u32,
    height: u32,
    max: f32,
    map: ColorMap,
    title: &str,
) -> Rgb8 {
    with_bar(
        colours,
        width,
        height,
        &|v| map.eval(v / max),
        (0.0, max),
        &labelled(0.0, max, "", "+"),
        title,
    )
}

/// Heat maps of the same rays side by side on one colour scale, each panel labelled, with one
/// colour bar (the sparse-boxes paper's Figure 5: HTR, BTR and SLTR next to each other):
/// `panels` are (label, row-major values of `width x height`), `map` from 0 to `max`; values
/// at or above `max` take the top colour.
pub fn heatmaps_side_by_side(
    panels: &[(&str, &[f32])],
    width: u32,
    height: u32,
    max: f32,
    map: ColorMap,
    title: &str,
) -> Rgb8 {
    let max = if max > 0.0 { max } else { 1.0 };
    let s = text_scale(height);
    let glyph = 8 * s;
    let gap = glyph;
    let label_h = glyph + glyph / 2;
    let n = panels.len().max(1) as u32;
    let (w, h) = (n * width + (n - 1) * gap, height + label_h);
    let mut canvas = Rgb8::filled(w, h, [255, 255, 255]);
    for (i, (label, v)) in panels.iter().enumerate() {
        let x0 = i as u32 * (width + gap);
        draw_text(&mut canvas, label, x0, glyph / 4, s, [0, 0, 0]);
        for y in 0..height {
            for x in 0..width {
                let c = map.eval(v[(y * width + x) as usize] / max);
                canvas.set(x0 + x, y + label_h, c);
            }
        }
    }
    let colours: Vec<[u8; 3]> = canvas
        .data
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    with_scale(&colours, w, h, max, map, title)
}

/// A difference map `b − a` of two row-major images of the same rays: blue where `b` is below
/// `a`, white where equal, red where above, saturating at `±max` (default: the 99th
/// percentile of `|b − a|`, at least 1, so a few outliers do not wash out the map). Returns the
/// image and the scale used.
pub fn diff_map(
    a: &[f32],
    b: &[f32],
    width: u32,
    height: u32,
    max: Option<f32>,
    title: &str,
) -> (Rgb8, f32) {
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
        &labelled(-max, max, "", "")
            .into_iter()
            .map(|(v, l)| (v, if v > 0.0 { format!("+{l}") } else { l }))
            .collect::<Vec<_>>(),
        title,
    );
    (img, max)
}

/// The mean difference `b − a` per pixel (ray) of two images of the same rays, split by a
/// mask: the part from the masked pixels and the part from the rest, both divided by all the
/// pixels, so they sum to the whole (`trace-bench diff --split`: how much of the difference
/// of two traversals' counters comes from the rays one of them handed over).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitDiff {
    /// Pixels.
    pub pixels: usize,
    /// Masked pixels.
    pub masked: usize,
    /// `Σ (b − a) / pixels` over every pixel.
    pub all: f64,
    /// `Σ (b − a) / pixels` over the masked pixels.
    pub in_mask: f64,
    /// `Σ (b − a) / pixels` over the others.
    pub rest: f64,
}

/// [`SplitDiff`] of `b − a` split by `mask` (all three of one length).
pub fn split_diff(a: &[f32], b: &[f32], mask: &[bool]) -> SplitDiff {
    assert!(
        a.len() == b.len() && a.len() == mask.len(),
        "images of the same rays"
    );
    let n = a.len().max(1) as f64;
    let (mut in_mask, mut rest, mut masked) = (0.0f64, 0.0f64, 0usize);
    for ((&x, &y), &m) in a.iter().zip(b).zip(mask) {
        let d = y as f64 - x as f64;
        if m {
            in_mask += d;
            masked += 1;
        } else {
            rest += d;
        }
    }
    SplitDiff {
        pixels: a.len(),
        masked,
        all: (in_mask + rest) / n,
        in_mask: in_mask / n,
        rest: rest / n,
    }
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
        let jet = crate::colormap::jet;
        let img = heatmap(&values, w, h, 255.0, ColorMap::Jet, "");
        assert!(img.width > w && img.height >= h);
        let pad = 5;
        // Pixel (0, 0) is 0 steps: dark blue; pixel (31, 0) is 620 ≥ 255: dark red.
        assert_eq!(img.get(0, pad), jet(0.0));
        assert_eq!(img.get(31, pad), jet(1.0));
        // Bar: top dark red, bottom dark blue.
        let bx = w + 5;
        assert_eq!(img.get(bx, pad), jet(1.0));
        assert_eq!(img.get(bx, pad + h - 1), jet(0.0));
        // Some black label pixels exist.
        assert!(img.data.chunks(3).any(|c| c == [0, 0, 0]));
        // A title adds rows above the image; the map is the one asked for.
        let titled = heatmap(&values, w, h, 255.0, ColorMap::Viridis, "bvh · steps");
        assert!(titled.height > img.height);
        let top = titled.height - h - pad;
        assert_eq!(titled.get(0, top), ColorMap::Viridis.eval(0.0));
    }

    #[test]
    fn side_by_side_panels_share_one_scale() {
        let (w, h) = (16, 8);
        let low = vec![0.0f32; (w * h) as usize];
        let high = vec![300.0f32; (w * h) as usize];
        let jet = crate::colormap::jet;
        let img =
            heatmaps_side_by_side(&[("a", &low), ("b", &high)], w, h, 255.0, ColorMap::Jet, "");
        let single = heatmap(&low, w, h, 255.0, ColorMap::Jet, "");
        // Two panels and a gap wider than one map; one colour bar.
        assert!(img.width >= single.width + w);
        // The bottom row of each panel: 0 is dark blue, 300 >= 255 dark red.
        let y = img.height - 1 - 5;
        assert_eq!(img.get(0, y), jet(0.0));
        let gap = img.width - single.width - w;
        assert_eq!(img.get(w + gap, y), jet(1.0));
        // Between the panels: white.
        assert_eq!(img.get(w + gap / 2, y), [255, 255, 255]);
    }

    #[test]
    fn titles_wrap_at_separators() {
        assert_eq!(wrap("a · b · c", 40), vec!["a · b · c"]);
        assert_eq!(
            wrap("scene · structure · traversal", 19),
            vec!["scene · structure ·", "traversal"]
        );
        assert_eq!(wrap("a b\nc", 40), vec!["a b", "c"]);
        assert!(wrap(&"x".repeat(30), 10)
            .iter()
            .all(|l| l.chars().count() <= 10));
    }

    #[test]
    fn split_diff_parts_sum_to_the_whole() {
        let a = [1.0, 2.0, 3.0, 4.0];
        let b = [1.0, 5.0, 3.0, 2.0];
        let d = split_diff(&a, &b, &[false, true, false, false]);
        assert_eq!((d.pixels, d.masked), (4, 1));
        assert_eq!((d.all, d.in_mask, d.rest), (0.25, 0.75, -0.5));
        let none = split_diff(&a, &b, &[false; 4]);
        assert_eq!((none.masked, none.in_mask, none.rest), (0, 0.0, 0.25));
    }

    #[test]
    fn diff_is_signed() {
        let a = [1.0, 5.0, 3.0, 3.0];
        let b = [3.0, 1.0, 3.0, 3.0];
        let (img, max) = diff_map(&a, &b, 2, 2, None, "");
        assert_eq!(max, 4.0);
        let pad = 5;
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
