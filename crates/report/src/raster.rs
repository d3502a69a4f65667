//! PNG back end: a small rasteriser for the chart's primitives, with text in an embedded 8×8
//! bitmap font (`font8x8`), so drawing needs no system fonts. Everything is drawn at
//! [`SUPERSAMPLE`]× the canvas and averaged down, which smooths edges; the arithmetic is plain
//! and ordered, so the same chart gives the same bytes.

use crate::chart::{Anchor, HEIGHT, Prim, Rgb, WIDTH};

/// Drawing resolution over the canvas's, per axis.
const SUPERSAMPLE: usize = 2;
/// Glyph cell of the bitmap font, in font pixels.
const GLYPH: usize = 8;
/// Dash pattern of dashed lines: on, off (canvas pixels; the SVG uses the same).
const DASH: (f64, f64) = (6.0, 4.0);

/// An RGB image at the supersampled size.
struct Canvas {
    w: usize,
    h: usize,
    px: Vec<Rgb>,
}

impl Canvas {
    fn put(&mut self, x: i64, y: i64, c: Rgb) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            self.px[y as usize * self.w + x as usize] = c;
        }
    }

    /// Pixels whose centres lie in [x0, x1) × [y0, y1) (supersampled coordinates).
    fn fill_rect(&mut self, x0: f64, y0: f64, x1: f64, y1: f64, c: Rgb) {
        let (xa, xb) = (span(x0), span(x1));
        let (ya, yb) = (span(y0), span(y1));
        for y in ya..yb {
            for x in xa..xb {
                self.put(x, y, c);
            }
        }
    }

    /// Pixels within `r` of the segment a–b (a round-capped thick line).
    fn segment(&mut self, a: (f64, f64), b: (f64, f64), r: f64, c: Rgb) {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        let x0 = span(a.0.min(b.0) - r);
        let x1 = span(a.0.max(b.0) + r) + 1;
        let y0 = span(a.1.min(b.1) - r);
        let y1 = span(a.1.max(b.1) + r) + 1;
        for y in y0..y1 {
            for x in x0..x1 {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let t = if len2 > 0.0 {
                    (((px - a.0) * dx + (py - a.1) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (px - a.0 - t * dx, py - a.1 - t * dy);
                if ex * ex + ey * ey <= r * r {
                    self.put(x, y, c);
                }
            }
        }
    }
}

/// First pixel whose centre is at or after `v`.
fn span(v: f64) -> i64 {
    (v - 0.5).ceil() as i64
}

/// Pieces of a polyline that are drawn when it is dashed.
fn dashes(points: &[(f64, f64)], on: f64, off: f64) -> Vec<((f64, f64), (f64, f64))> {
    let mut out = Vec::new();
    let mut phase = 0.0; // distance into the current on+off period
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        let mut t = 0.0;
        while t < len {
            let (in_on, left) = if phase < on {
                (true, on - phase)
            } else {
                (false, on + off - phase)
            };
            let step = left.min(len - t);
            if in_on {
                let p = |s: f64| (a.0 + (b.0 - a.0) * s / len, a.1 + (b.1 - a.1) * s / len);
                out.push((p(t), p(t + step)));
            }
            t += step;
            phase = (phase + step) % (on + off);
        }
    }
    out
}

/// The font's bitmap for `c` (rows top to bottom, bit 0 the leftmost pixel); `?` for
/// characters outside ASCII, with the few non-ASCII ones the report uses mapped to ASCII.
fn glyph(c: char) -> [u8; 8] {
    let c = match c {
        '×' => 'x',
        '–' | '—' | '−' => '-',
        '²' => '2',
        '≈' => '~',
        c => c,
    };
    let i = if c.is_ascii() {
        c as usize
    } else {
        '?' as usize
    };
    font8x8::legacy::BASIC_LEGACY[i]
}

/// Supersampled pixels per font pixel for text of `size`: whole, so every glyph is drawn
/// alike, and rounded down, so a line of the bitmap font is about as wide as the SVG's
/// sans-serif.
fn font_scale(size: f64) -> i64 {
    ((size * SUPERSAMPLE as f64) / GLYPH as f64)
        .floor()
        .max(1.0) as i64
}

/// Width in canvas pixels of `s` drawn at `size` (the bitmap font is monospaced), so a
/// layout can make room for its longest label.
pub fn text_width(size: f64, s: &str) -> f64 {
    (font_scale(size) * GLYPH as i64 * s.chars().count() as i64) as f64 / SUPERSAMPLE as f64
}

/// Text: the 8×8 glyphs scaled to about `size` pixels per line.
#[allow(clippy::too_many_arguments)]
fn draw_text(
    cv: &mut Canvas,
    x: f64,
    y: f64,
    size: f64,
    anchor: Anchor,
    vertical: bool,
    c: Rgb,
    s: &str,
) {
    let ss = SUPERSAMPLE as f64;
    let scale = font_scale(size);
    let advance = GLYPH as i64 * scale;
    let total = advance * s.chars().count() as i64;
    let start = match anchor {
        Anchor::Start => 0,
        Anchor::Middle => -total / 2,
        Anchor::End => -total,
    };
    // The baseline sits one font pixel above the cell's bottom (descenders use that row).
    let (ox, oy) = ((x * ss).round() as i64, (y * ss).round() as i64);
    for (k, ch) in s.chars().enumerate() {
        let bits = glyph(ch);
        let along = start + advance * k as i64;
        for (row, byte) in bits.iter().enumerate() {
            for col in 0..GLYPH {
                if byte >> col & 1 == 0 {
                    continue;
                }
                // (u, v): along the text and down from its top, in supersampled pixels.
                let u = along + col as i64 * scale;
                let v = (row as i64 - GLYPH as i64 + 1) * scale;
                for dv in 0..scale {
                    for du in 0..scale {
                        let (px, py) = if vertical {
                            (ox + v + dv, oy - u - du)
                        } else {
                            (ox + u + du, oy + v + dv)
                        };
                        cv.put(px, py, c);
                    }
                }
            }
        }
    }
}

/// The primitives as 8-bit RGB pixels, `WIDTH × HEIGHT`, row by row.
pub fn rasterize(prims: &[Prim]) -> Vec<u8> {
    let ss = SUPERSAMPLE as f64;
    let (w, h) = (WIDTH as usize * SUPERSAMPLE, HEIGHT as usize * SUPERSAMPLE);
    let mut cv = Canvas {
        w,
        h,
        px: vec![[255, 255, 255]; w * h],
    };
    for p in prims {
        match p {
            Prim::Rect { x, y, w, h, color } => {
                cv.fill_rect(x * ss, y * ss, (x + w) * ss, (y + h) * ss, *color)
            }
            Prim::Dot { x, y, r, color } => {
                cv.segment((x * ss, y * ss), (x * ss, y * ss), r * ss, *color)
            }
            Prim::Line {
                points,
                color,
                width,
                dashed,
            } => {
                let scaled: Vec<(f64, f64)> =
                    points.iter().map(|(x, y)| (x * ss, y * ss)).collect();
                let r = width * ss / 2.0;
                let pieces = if *dashed {
                    dashes(&scaled, DASH.0 * ss, DASH.1 * ss)
                } else {
                    scaled.windows(2).map(|w| (w[0], w[1])).collect()
                };
                for (a, b) in pieces {
                    cv.segment(a, b, r, *color);
                }
            }
            Prim::Text {
                x,
                y,
                size,
                anchor,
                vertical,
                color,
                text,
            } => draw_text(&mut cv, *x, *y, *size, *anchor, *vertical, *color, text),
        }
    }
    // Average each SUPERSAMPLE² block.
    let mut out = Vec::with_capacity(WIDTH as usize * HEIGHT as usize * 3);
    let n = (SUPERSAMPLE * SUPERSAMPLE) as u32;
    for y in 0..HEIGHT as usize {
        for x in 0..WIDTH as usize {
            let mut sum = [0u32; 3];
            for dy in 0..SUPERSAMPLE {
                for dx in 0..SUPERSAMPLE {
                    let p = cv.px[(y * SUPERSAMPLE + dy) * w + x * SUPERSAMPLE + dx];
                    for ch in 0..3 {
                        sum[ch] += u32::from(p[ch]);
                    }
                }
            }
            out.extend(sum.map(|s| ((s + n / 2) / n) as u8));
        }
    }
    out
}

/// The primitives as a PNG file.
pub fn png(prims: &[Prim]) -> Result<Vec<u8>, png::EncodingError> {
    let rgb = rasterize(prims);
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, WIDTH, HEIGHT);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut w = enc.write_header()?;
    w.write_image_data(&rgb)?;
    w.finish()?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chart::BLACK;

    fn at(rgb: &[u8], x: usize, y: usize) -> [u8; 3] {
        let i = (y * WIDTH as usize + x) * 3;
        [rgb[i], rgb[i + 1], rgb[i + 2]]
    }

    #[test]
    fn rects_lines_and_text_cover_the_right_pixels() {
        let rgb = rasterize(&[
            Prim::Rect {
                x: 10.0,
                y: 10.0,
                w: 4.0,
                h: 4.0,
                color: [255, 0, 0],
            },
            Prim::Line {
                points: vec![(100.0, 50.5), (200.0, 50.5)],
                color: BLACK,
                width: 1.0,
                dashed: false,
            },
            Prim::Text {
                x: 300.0,
                y: 100.0,
                size: 8.0,
                anchor: Anchor::Start,
                vertical: false,
                color: BLACK,
                text: "I".into(),
            },
        ]);
        assert_eq!(rgb.len(), (WIDTH * HEIGHT * 3) as usize);
        assert_eq!(at(&rgb, 11, 11), [255, 0, 0]);
        assert_eq!(at(&rgb, 15, 11), [255, 255, 255]);
        assert_eq!(at(&rgb, 150, 50), [0, 0, 0]);
        assert_eq!(at(&rgb, 150, 52), [255, 255, 255]);
        // Some pixel of the glyph's cell above the baseline is inked.
        let inked = (300..308).any(|x| (93..100).any(|y| at(&rgb, x, y) != [255, 255, 255]));
        assert!(inked);
    }

    #[test]
    fn dashes_alternate_and_keep_the_phase_across_corners() {
        let d = dashes(&[(0.0, 0.0), (8.0, 0.0), (8.0, 12.0)], 6.0, 4.0);
        assert_eq!(d[0], ((0.0, 0.0), (6.0, 0.0)));
        // The off part runs 6..10: 2 px left of the first segment, 2 px into the second.
        assert_eq!(d[1], ((8.0, 2.0), (8.0, 8.0)));
    }

    #[test]
    fn png_encodes_the_canvas_size() {
        let bytes = png(&[]).unwrap();
        let dec = png::Decoder::new(std::io::Cursor::new(bytes));
        let r = dec.read_info().unwrap();
        assert_eq!((r.info().width, r.info().height), (WIDTH, HEIGHT));
    }
}
