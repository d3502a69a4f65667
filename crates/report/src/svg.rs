//! SVG back end: the chart's primitives as SVG 1.1 elements (text in the viewer's sans-serif).

use crate::chart::{Anchor, HEIGHT, Prim, Rgb, WIDTH};
use std::fmt::Write;

fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// Coordinates with two decimals: enough for the canvas, and byte-stable.
fn n(v: f64) -> String {
    let s = format!("{v:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// `&`, `<`, `>` and quotes escaped for XML text and attributes.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

/// A standalone SVG document.
pub fn render(prims: &[Prim]) -> String {
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{WIDTH}\" height=\"{HEIGHT}\" viewBox=\"0 0 {WIDTH} {HEIGHT}\" font-family=\"sans-serif\">\n<rect width=\"{WIDTH}\" height=\"{HEIGHT}\" fill=\"#ffffff\"/>\n"
    );
    for p in prims {
        // Writing to a String cannot fail.
        let _ = match p {
            Prim::Line {
                points,
                color,
                width,
                dashed,
            } => {
                let pts: Vec<String> = points
                    .iter()
                    .map(|(x, y)| format!("{},{}", n(*x), n(*y)))
                    .collect();
                writeln!(
                    s,
                    "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"{}/>",
                    pts.join(" "),
                    hex(*color),
                    n(*width),
                    if *dashed {
                        " stroke-dasharray=\"6,4\""
                    } else {
                        ""
                    }
                )
            }
            Prim::Rect { x, y, w, h, color } => writeln!(
                s,
                "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"{}\"/>",
                n(*x),
                n(*y),
                n(*w),
                n(*h),
                hex(*color)
            ),
            Prim::Dot { x, y, r, color } => writeln!(
                s,
                "<circle cx=\"{}\" cy=\"{}\" r=\"{}\" fill=\"{}\"/>",
                n(*x),
                n(*y),
                n(*r),
                hex(*color)
            ),
            Prim::Text {
                x,
                y,
                size,
                anchor,
                vertical,
                color,
                text,
            } => {
                let anchor = match anchor {
                    Anchor::Start => "start",
                    Anchor::Middle => "middle",
                    Anchor::End => "end",
                };
                let rotate = if *vertical {
                    format!(" transform=\"rotate(-90 {} {})\"", n(*x), n(*y))
                } else {
                    String::new()
                };
                writeln!(
                    s,
                    "<text x=\"{}\" y=\"{}\" font-size=\"{}\" text-anchor=\"{anchor}\" fill=\"{}\"{rotate}>{}</text>",
                    n(*x),
                    n(*y),
                    n(*size),
                    hex(*color),
                    escape(text)
                )
            }
        };
    }
    s.push_str("</svg>\n");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::chart::BLACK;

    #[test]
    fn primitives_become_elements_with_escaped_text() {
        let s = render(&[
            Prim::Line {
                points: vec![(0.0, 1.5), (2.25, 3.0)],
                color: [255, 0, 16],
                width: 2.0,
                dashed: true,
            },
            Prim::Text {
                x: 1.0,
                y: 2.0,
                size: 12.0,
                anchor: Anchor::End,
                vertical: true,
                color: BLACK,
                text: "a<b & c".into(),
            },
        ]);
        assert!(s.contains("points=\"0,1.5 2.25,3\""), "{s}");
        assert!(s.contains("stroke=\"#ff0010\"") && s.contains("stroke-dasharray"));
        assert!(s.contains(">a&lt;b &amp; c</text>") && s.contains("rotate(-90 1 2)"));
        assert!(s.starts_with("<svg") && s.ends_with("</svg>\n"));
    }
}
