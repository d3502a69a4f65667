//! Charts: a [`Chart`] (line chart over a linear or log₂ axis, or grouped bars) is laid out
//! once into drawing [`Prim`]itives on a fixed canvas; `svg` and `raster` each draw the same
//! primitives, so the SVG and the PNG of a figure show the same thing.

/// Canvas size in pixels (the PNG's size; the SVG's view box).
pub const WIDTH: u32 = 900;
pub const HEIGHT: u32 = 440;
/// Plot area: left, top, right and bottom edges (room for tick labels and the legend).
const PLOT: (f64, f64, f64, f64) = (90.0, 44.0, 560.0, 380.0);

/// Series of more points than this are drawn without a dot per point.
const DOTS_UP_TO: usize = 60;

/// The plot area's right edge never comes nearer its left than this: a long legend narrows
/// the plot down to it (370 px of the full 470), and names wider than the room left beside it
/// (about 46 characters) wrap. Assumed: the axes' tick labels stay apart at this width (six
/// sizes, 512 KB to 16 MB), and the legend costs wrapped lines, not a squeezed plot.
const PLOT_RIGHT_MIN: f64 = 460.0;

/// Legend text: its size, and where it starts right of the plot area.
const LEGEND_TEXT: f64 = 11.0;
const LEGEND_TEXT_X: f64 = 46.0;
/// A reference line's label: its text size, and the gap kept between it and the data.
const MARKER_TEXT: f64 = 11.0;
const MARKER_GAP: f64 = 5.0;

/// An sRGB colour.
pub type Rgb = [u8; 3];
pub const BLACK: Rgb = [0, 0, 0];
pub const GREY: Rgb = [160, 160, 160];
pub const WHITE: Rgb = [255, 255, 255];
const LIGHT: Rgb = [225, 225, 225];
/// Series colours, assigned in order (Okabe–Ito's colour-blind-safe palette).
const PALETTE: [Rgb; 8] = [
    [0, 114, 178],
    [213, 94, 0],
    [0, 158, 115],
    [204, 121, 167],
    [230, 159, 0],
    [86, 180, 233],
    [0, 0, 0],
    [240, 228, 66],
];

pub fn palette(i: usize) -> Rgb {
    PALETTE[i % PALETTE.len()]
}

/// How text is placed relative to its point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anchor {
    Start,
    Middle,
    End,
}

/// What both back ends draw.
#[derive(Clone, Debug, PartialEq)]
pub enum Prim {
    Line {
        points: Vec<(f64, f64)>,
        color: Rgb,
        width: f64,
        dashed: bool,
    },
    Rect {
        x: f64,
        y: f64,
        w: f64,
        h: f64,
        color: Rgb,
    },
    Dot {
        x: f64,
        y: f64,
        r: f64,
        color: Rgb,
    },
    /// Text whose baseline starts, is centred or ends at (x, y); `vertical` turns it a
    /// quarter anticlockwise about (x, y).
    Text {
        x: f64,
        y: f64,
        size: f64,
        anchor: Anchor,
        vertical: bool,
        color: Rgb,
        text: String,
    },
}

/// An axis's mapping from data to the plot.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    Log2,
    Log10,
}

/// One line of a line chart.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    /// (x, y), drawn in x order.
    pub points: Vec<(f64, f64)>,
    pub color: Rgb,
    pub dashed: bool,
}

/// One set of bars of a bar chart (one value per category; None leaves a gap).
#[derive(Clone, Debug, PartialEq)]
pub struct BarSeries {
    pub name: String,
    pub values: Vec<Option<f64>>,
    pub color: Rgb,
}

/// What a chart shows.
#[derive(Clone, Debug, PartialEq)]
pub enum Body {
    Lines {
        x_scale: Scale,
        y_scale: Scale,
        /// Tick positions on x (data units) with their labels.
        x_ticks: Vec<(f64, String)>,
        series: Vec<Series>,
        /// Grey vertical reference line (x, label).
        marker: Option<(f64, String)>,
    },
    Bars {
        categories: Vec<String>,
        series: Vec<BarSeries>,
        /// Horizontal reference marks over one category: (category index, value, label).
        marks: Vec<(usize, f64, String)>,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Chart {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub body: Body,
}

impl Chart {
    /// True when the chart has no data to draw.
    pub fn is_empty(&self) -> bool {
        match &self.body {
            Body::Lines { series, .. } => series.iter().all(|s| s.points.is_empty()),
            Body::Bars { series, .. } => {
                series.iter().all(|s| s.values.iter().all(Option::is_none))
            }
        }
    }

    /// The series' names, in legend order.
    fn series_names(&self) -> impl Iterator<Item = &str> {
        let names: Vec<&str> = match &self.body {
            Body::Lines { series, .. } => series.iter().map(|s| s.name.as_str()).collect(),
            Body::Bars { series, .. } => series.iter().map(|s| s.name.as_str()).collect(),
        };
        names.into_iter()
    }

    /// Lay the chart out on the canvas.
    pub fn layout(&self) -> Vec<Prim> {
        let mut out = Vec::new();
        let (l, t, r, b) = PLOT;
        // The legend sits right of the plot: narrow the plot so its longest name fits.
        let widest = self
            .series_names()
            .map(|n| crate::raster::text_width(LEGEND_TEXT, n))
            .fold(0.0, f64::max);
        let r = r
            .min(WIDTH as f64 - LEGEND_TEXT_X - widest - 6.0)
            .max(PLOT_RIGHT_MIN);
        text(
            &mut out,
            (WIDTH as f64) / 2.0,
            24.0,
            15.0,
            Anchor::Middle,
            &self.title,
        );
        text(
            &mut out,
            (l + r) / 2.0,
            b + 46.0,
            13.0,
            Anchor::Middle,
            &self.x_label,
        );
        out.push(Prim::Text {
            x: 20.0,
            y: (t + b) / 2.0,
            size: 13.0,
            anchor: Anchor::Middle,
            vertical: true,
            color: BLACK,
            text: self.y_label.clone(),
        });
        let legend: Vec<(String, Rgb, bool)> = match &self.body {
            Body::Lines {
                x_scale,
                y_scale,
                x_ticks,
                series,
                marker,
            } => {
                let xs = x_ticks
                    .iter()
                    .map(|p| p.0)
                    .chain(series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
                let x_axis = Axis::fit(*x_scale, xs, l, r, false);
                let ys = series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
                let y_axis = Axis::fit(*y_scale, ys, b, t, true);
                y_grid(&mut out, &y_axis, l, r);
                for (x, label) in x_ticks {
                    let px = x_axis.map(*x);
                    line(&mut out, vec![(px, b), (px, b + 5.0)], BLACK, 1.0, false);
                    text(&mut out, px, b + 20.0, 11.0, Anchor::Middle, label);
                }
                let placed: Vec<Vec<(f64, f64)>> = series
                    .iter()
                    .map(|s| {
                        let mut pts: Vec<(f64, f64)> = s
                            .points
                            .iter()
                            .map(|&(x, y)| (x_axis.map(x), y_axis.map(y)))
                            // A value the axis cannot place (NaN, infinite, ≤ 0 on a log
                            // axis) is not drawn.
                            .filter(|(x, y)| x.is_finite() && y.is_finite())
                            .collect();
                        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                        pts
                    })
                    .collect();
                // The reference line goes under the data, its label over it, in a place
                // no line crosses.
                let marker_label = marker.as_ref().map(|(x, label)| {
                    let px = x_axis.map(*x);
                    line(&mut out, vec![(px, t), (px, b)], GREY, 2.0, false);
                    let (x, anchor, y) = marker_label_place(px, label, &placed, (l, t, r, b));
                    (x, y, anchor, label)
                });
                for (s, pts) in series.iter().zip(placed) {
                    if pts.len() > 1 {
                        line(&mut out, pts.clone(), s.color, 2.0, s.dashed);
                    }
                    // A dense series (a time series) is a line alone: dots would hide it.
                    let dots = pts.len() <= DOTS_UP_TO;
                    for (x, y) in pts.into_iter().filter(|_| dots) {
                        out.push(Prim::Dot {
                            x,
                            y,
                            r: 3.5,
                            color: s.color,
                        });
                    }
                }
                if let Some((x, y, anchor, label)) = marker_label {
                    text(&mut out, x, y, MARKER_TEXT, anchor, label);
                }
                series
                    .iter()
                    .map(|s| (s.name.clone(), s.color, s.dashed))
                    .collect()
            }
            Body::Bars {
                categories,
                series,
                marks,
            } => {
                let ys = series
                    .iter()
                    .flat_map(|s| s.values.iter().flatten().copied())
                    .chain(marks.iter().map(|m| m.1));
                let y_axis = Axis::fit(Scale::Linear, ys, b, t, true);
                y_grid(&mut out, &y_axis, l, r);
                let slot = (r - l) / categories.len().max(1) as f64;
                let bar = slot * 0.8 / series.len().max(1) as f64;
                for (i, c) in categories.iter().enumerate() {
                    let x0 = l + slot * i as f64 + slot * 0.1;
                    text(&mut out, x0 + slot * 0.4, b + 18.0, 11.0, Anchor::Middle, c);
                    for (j, s) in series.iter().enumerate() {
                        let value = s.values.get(i).copied().flatten();
                        if let Some(v) = value.filter(|v| v.is_finite()) {
                            let y = y_axis.map(v);
                            out.push(Prim::Rect {
                                x: x0 + bar * j as f64,
                                y,
                                w: bar,
                                h: b - y,
                                color: s.color,
                            });
                        }
                    }
                }
                // Reference marks over the bars: a white band under the dashes keeps them
                // visible where they cross a bar.
                for (i, v, label) in marks {
                    let x0 = l + slot * *i as f64;
                    let y = y_axis.map(*v);
                    line(&mut out, vec![(x0, y), (x0 + slot, y)], WHITE, 5.0, false);
                    line(&mut out, vec![(x0, y), (x0 + slot, y)], BLACK, 2.0, true);
                    text(
                        &mut out,
                        x0 + slot + 4.0,
                        y + 4.0,
                        11.0,
                        Anchor::Start,
                        label,
                    );
                }
                series
                    .iter()
                    .map(|s| (s.name.clone(), s.color, false))
                    .collect()
            }
        };
        if self.is_empty() {
            text(
                &mut out,
                (l + r) / 2.0,
                (t + b) / 2.0,
                14.0,
                Anchor::Middle,
                "no data in these results",
            );
        }
        // Axes on top of the data.
        line(&mut out, vec![(l, t), (l, b), (r, b)], BLACK, 1.0, false);
        // A name wider than the room right of the narrowest plot wraps at spaces, its further
        // lines below its first.
        let room = WIDTH as f64 - (r + LEGEND_TEXT_X) - 6.0;
        let mut y = t + 10.0;
        for (name, color, dashed) in &legend {
            line(
                &mut out,
                vec![(r + 14.0, y), (r + 40.0, y)],
                *color,
                2.5,
                *dashed,
            );
            for part in wrap(name, LEGEND_TEXT, room) {
                text(
                    &mut out,
                    r + LEGEND_TEXT_X,
                    y + 4.0,
                    LEGEND_TEXT,
                    Anchor::Start,
                    &part,
                );
                y += 14.0;
            }
            y += 4.0;
        }
        out
    }
}

/// Where a vertical reference line's label goes, as (x, anchor, baseline y): the highest
/// place, right of the line or else left of it, where no series' line or dot comes within
/// `MARKER_GAP` of the text; the top right of the line if there is none.
fn marker_label_place(
    px: f64,
    label: &str,
    series: &[Vec<(f64, f64)>],
    (l, t, r, b): (f64, f64, f64, f64),
) -> (f64, Anchor, f64) {
    let w = crate::raster::text_width(MARKER_TEXT, label);
    let sides = [
        (px + 4.0, Anchor::Start, px + 4.0, px + 4.0 + w),
        (px - 4.0, Anchor::End, px - 4.0 - w, px - 4.0),
    ];
    // Baselines from the top down, one text line apart.
    let mut y = t + 14.0;
    while y <= b - 4.0 {
        for (x, anchor, x0, x1) in sides {
            if x0 < l || x1 > r {
                continue;
            }
            let (top, bottom) = (y - MARKER_TEXT - MARKER_GAP, y + 3.0 + MARKER_GAP);
            let hit = series.iter().any(|pts| {
                y_span(pts, x0 - MARKER_GAP, x1 + MARKER_GAP)
                    .is_some_and(|(lo, hi)| lo <= bottom && hi >= top)
            });
            if !hit {
                return (x, anchor, y);
            }
        }
        y += MARKER_TEXT + 3.0;
    }
    (px + 4.0, Anchor::Start, t + 14.0)
}

/// The least and greatest y of a polyline (points in x order, each a dot of radius 4)
/// between x0 and x1; None where it does not reach that range.
fn y_span(pts: &[(f64, f64)], x0: f64, x1: f64) -> Option<(f64, f64)> {
    const DOT: f64 = 4.0;
    let mut span: Option<(f64, f64)> = None;
    let mut add = |y: f64, r: f64| {
        let (lo, hi) = span.unwrap_or((f64::INFINITY, f64::NEG_INFINITY));
        span = Some((lo.min(y - r), hi.max(y + r)));
    };
    for &(x, y) in pts {
        if x >= x0 - DOT && x <= x1 + DOT {
            add(y, DOT);
        }
    }
    // Where a segment crosses the range's edges.
    for w in pts.windows(2) {
        let ((xa, ya), (xb, yb)) = (w[0], w[1]);
        for x in [x0, x1] {
            if xa < x && x < xb {
                add(ya + (yb - ya) * (x - xa) / (xb - xa), 1.0);
            }
        }
    }
    span
}

/// `s` in lines no wider than `room` at text size `size`, broken at spaces (a word wider than
/// `room` keeps a line of its own).
fn wrap(s: &str, size: f64, room: f64) -> Vec<String> {
    let mut lines: Vec<String> = Vec::new();
    for word in s.split(' ') {
        match lines.last_mut() {
            Some(last) if crate::raster::text_width(size, &format!("{last} {word}")) <= room => {
                last.push(' ');
                last.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

fn text(out: &mut Vec<Prim>, x: f64, y: f64, size: f64, anchor: Anchor, s: &str) {
    out.push(Prim::Text {
        x,
        y,
        size,
        anchor,
        vertical: false,
        color: BLACK,
        text: s.to_string(),
    });
}

fn line(out: &mut Vec<Prim>, points: Vec<(f64, f64)>, color: Rgb, width: f64, dashed: bool) {
    out.push(Prim::Line {
        points,
        color,
        width,
        dashed,
    });
}

/// Horizontal grid lines and labels at the y axis's ticks.
fn y_grid(out: &mut Vec<Prim>, y: &Axis, l: f64, r: f64) {
    let ticks = y.ticks();
    for (v, label) in ticks.iter().zip(tick_labels(y.scale, &ticks)) {
        let py = y.map(*v);
        line(out, vec![(l, py), (r, py)], LIGHT, 1.0, false);
        text(out, l - 6.0, py + 4.0, 11.0, Anchor::End, &label);
    }
}

/// One axis's tick labels, all in one form: on a log₁₀ axis reaching below 0.001 every
/// label is a power of ten in exponent form (`1e-1` … `1e-5`), never `0.001` beside `1e-4`.
fn tick_labels(scale: Scale, ticks: &[f64]) -> Vec<String> {
    let tiny = ticks.iter().any(|v| *v != 0.0 && v.abs() < 1e-3);
    if scale == Scale::Log10 && tiny {
        ticks.iter().map(|v| format!("{v:.0e}")).collect()
    } else {
        ticks.iter().map(|v| short_number(*v)).collect()
    }
}

/// A data range mapped onto pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Axis {
    scale: Scale,
    lo: f64,
    hi: f64,
    /// Pixel positions of `lo` and `hi`.
    p0: f64,
    p1: f64,
}

impl Axis {
    /// Fit the finite (and, on a log scale, positive) values; `from_zero` starts a linear
    /// axis at 0. An empty range becomes [0, 1] (or one decade).
    fn fit(
        scale: Scale,
        values: impl Iterator<Item = f64>,
        p0: f64,
        p1: f64,
        from_zero: bool,
    ) -> Axis {
        let usable = |v: &f64| v.is_finite() && (scale == Scale::Linear || *v > 0.0);
        let (mut lo, mut hi) = values
            .filter(usable)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            });
        if lo > hi {
            (lo, hi) = if scale == Scale::Linear {
                (0.0, 1.0)
            } else {
                (1.0, 10.0)
            };
        }
        match scale {
            Scale::Linear => {
                if from_zero {
                    lo = lo.min(0.0);
                }
                let step = nice_step((hi - lo).max(hi.abs() * 1e-9).max(1e-300) / 5.0);
                lo = (lo / step).floor() * step;
                hi = ((hi / step).ceil() * step).max(lo + step);
            }
            Scale::Log2 => {
                lo = lo.log2().floor().exp2();
                hi = hi.log2().ceil().exp2().max(lo * 2.0);
            }
            Scale::Log10 => {
                lo = 10f64.powf(lo.log10().floor());
                hi = 10f64.powf(hi.log10().ceil()).max(lo * 10.0);
            }
        }
        Axis {
            scale,
            lo,
            hi,
            p0,
            p1,
        }
    }

    fn unit(&self, v: f64) -> f64 {
        match self.scale {
            Scale::Linear => v,
            Scale::Log2 => v.log2(),
            Scale::Log10 => v.log10(),
        }
    }

    fn map(&self, v: f64) -> f64 {
        let (a, b) = (self.unit(self.lo), self.unit(self.hi));
        self.p0 + (self.unit(v) - a) / (b - a) * (self.p1 - self.p0)
    }

    fn ticks(&self) -> Vec<f64> {
        match self.scale {
            Scale::Linear => {
                let step = nice_step((self.hi - self.lo) / 5.0);
                let n = ((self.hi - self.lo) / step).round() as usize;
                (0..=n).map(|i| self.lo + step * i as f64).collect()
            }
            Scale::Log2 | Scale::Log10 => {
                let base = if self.scale == Scale::Log2 { 2.0 } else { 10.0 };
                let mut v = self.lo;
                let mut out = Vec::new();
                while v <= self.hi * (1.0 + 1e-9) {
                    out.push(v);
                    v *= base;
                }
                out
            }
        }
    }
}

/// 1, 2 or 5 × 10^k, the smallest at least `raw`.
pub(crate) fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw * (1.0 - 1e-9))
        .unwrap_or(10.0 * mag)
}

/// A tick label: `0`, `0.25`, `12`, `1.5k`, `3M`, `2G`, `1e-5`.
pub fn short_number(v: f64) -> String {
    let a = v.abs();
    let trim = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if a == 0.0 {
        return "0".into();
    }
    for (div, suffix) in [(1e9, "G"), (1e6, "M"), (1e3, "k")] {
        if a >= div {
            return format!("{}{suffix}", trim(format!("{:.2}", v / div)));
        }
    }
    if a >= 1e-3 {
        return trim(format!("{v:.4}"));
    }
    format!("{v:.0e}")
}

/// A byte size as the papers print it: `512 KB`, `1.5 MB`, `16 MB`.
pub fn bytes_label(b: f64) -> String {
    if b >= 1048576.0 {
        format!("{} MB", short_number(b / 1048576.0))
    } else {
        format!("{} KB", short_number(b / 1024.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_map_ends_and_round_outwards() {
        let a = Axis::fit(Scale::Linear, [3.0, 87.0].into_iter(), 100.0, 0.0, true);
        assert_eq!((a.lo, a.hi), (0.0, 100.0));
        assert_eq!(a.map(0.0), 100.0);
        assert_eq!(a.map(50.0), 50.0);
        assert_eq!(a.ticks(), [0.0, 20.0, 40.0, 60.0, 80.0, 100.0]);
        let l = Axis::fit(Scale::Log2, [1.0, 100.0].into_iter(), 0.0, 70.0, false);
        assert_eq!((l.lo, l.hi), (1.0, 128.0));
        assert_eq!(l.map(8.0), 30.0);
        let d = Axis::fit(Scale::Log10, [0.02, 3.0].into_iter(), 0.0, 1.0, false);
        assert_eq!(d.ticks().len(), 4);
        // Nothing to fit: a usable default, never a NaN.
        let e = Axis::fit(Scale::Log10, [-1.0, f64::NAN].into_iter(), 0.0, 1.0, false);
        assert!(e.map(5.0).is_finite());
    }

    /// A one-series dashed line chart over a log₂ x axis.
    fn line_chart(y_scale: Scale, points: Vec<(f64, f64)>, x_ticks: Vec<(f64, String)>) -> Chart {
        Chart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            body: Body::Lines {
                x_scale: Scale::Log2,
                y_scale,
                x_ticks,
                series: vec![Series {
                    name: "s".into(),
                    points,
                    color: palette(0),
                    dashed: true,
                }],
                marker: Some((2.0, "m".into())),
            },
        }
    }

    #[test]
    fn values_the_axes_cannot_place_are_not_drawn() {
        let points = vec![
            (1.0, 1.0),
            (2.0, 0.0),
            (f64::INFINITY, 3.0),
            (4.0, f64::NAN),
        ];
        let prims = line_chart(Scale::Log10, points, vec![]).layout();
        let dots = prims
            .iter()
            .filter(|p| matches!(p, Prim::Dot { .. }))
            .count();
        assert_eq!(dots, 1);
        // And both back ends finish.
        assert!(crate::svg::render(&prims).contains("<circle"));
        assert!(crate::raster::png(&prims).is_ok());
    }

    #[test]
    fn labels_are_short() {
        assert_eq!(short_number(1_500_000.0), "1.5M");
        assert_eq!(short_number(0.25), "0.25");
        assert_eq!(short_number(20.0), "20");
        assert_eq!(bytes_label(524288.0), "512 KB");
        assert_eq!(bytes_label(1.5 * 1048576.0), "1.5 MB");
    }

    #[test]
    fn line_chart_lays_out_every_point_and_legend_entry() {
        let ticks = vec![(1.0, "1".into()), (4.0, "4".into())];
        let c = line_chart(Scale::Linear, vec![(4.0, 2.0), (1.0, 1.0)], ticks);
        assert!(!c.is_empty());
        let prims = c.layout();
        let dots: Vec<_> = prims
            .iter()
            .filter(|p| matches!(p, Prim::Dot { .. }))
            .collect();
        assert_eq!(dots.len(), 2);
        assert!(
            prims
                .iter()
                .any(|p| matches!(p, Prim::Line { dashed: true, .. }))
        );
        assert!(
            prims
                .iter()
                .any(|p| matches!(p, Prim::Text { text, .. } if text == "s"))
        );
    }

    #[test]
    fn long_legend_names_fit_on_the_canvas() {
        let ticks = vec![(1.0, "1".into()), (4.0, "4".into())];
        let mut c = line_chart(Scale::Linear, vec![(4.0, 2.0), (1.0, 1.0)], ticks);
        let name = "conference baseline (128 TMs) L1 misses";
        if let Body::Lines { series, .. } = &mut c.body {
            series[0].name = name.into();
        }
        let prims = c.layout();
        let (x, size) = prims
            .iter()
            .find_map(|p| match p {
                Prim::Text { x, size, text, .. } if text == name => Some((*x, *size)),
                _ => None,
            })
            .expect("legend entry");
        let end = x + crate::raster::text_width(size, name);
        assert!(end <= WIDTH as f64, "legend ends at {end}");
        // The plot narrowed, and its right edge is where the grid lines end.
        let right = PLOT.2.min(x - LEGEND_TEXT_X);
        assert!(right < PLOT.2, "{right}");
        // A name too long even beside the narrowest plot wraps onto lines that fit, and the
        // next entry starts below its last line.
        let long = "conference STRaTA (128 TMs; fill static, policy rays-per-tm, switch drained) L1 misses";
        if let Body::Lines { series, .. } = &mut c.body {
            series[0].name = long.into();
            series.push(series[0].clone());
            series[1].name = "next".into();
        }
        let texts: Vec<(f64, f64, String)> = c
            .layout()
            .into_iter()
            .filter_map(|p| match p {
                Prim::Text {
                    x, y, size, text, ..
                } if size == LEGEND_TEXT => Some((x, y, text)),
                _ => None,
            })
            .collect();
        // The legend's lines: those at the last entry's x.
        let lx = texts.iter().find(|t| t.2 == "next").expect("next entry").0;
        let texts: Vec<_> = texts.into_iter().filter(|t| t.0 == lx).collect();
        let parts: Vec<&str> = texts.iter().map(|t| t.2.as_str()).collect();
        assert!(parts.len() >= 3, "{parts:?}");
        assert_eq!(parts[..parts.len() - 1].join(" "), long);
        for (x, _, text) in &texts {
            let end = x + crate::raster::text_width(LEGEND_TEXT, text);
            assert!(end <= WIDTH as f64, "{text:?} ends at {end}");
        }
        assert!(texts.windows(2).all(|w| w[1].1 > w[0].1), "lines go down");
        // The plot keeps its least width: the axes (the one three-point line) end there.
        let right = c.layout().into_iter().find_map(|p| match p {
            Prim::Line { points, .. } if points.len() == 3 => Some(points[2].0),
            _ => None,
        });
        assert_eq!(right, Some(PLOT_RIGHT_MIN));
    }

    #[test]
    fn log_axis_tick_labels_share_one_form() {
        let d = Axis::fit(Scale::Log10, [2e-5, 0.05].into_iter(), 0.0, 1.0, false);
        let labels = tick_labels(Scale::Log10, &d.ticks());
        assert_eq!(labels, ["1e-5", "1e-4", "1e-3", "1e-2", "1e-1"]);
        // Without tiny values the short form stays.
        let labels = tick_labels(Scale::Log10, &[0.01, 0.1, 1.0, 10.0]);
        assert_eq!(labels, ["0.01", "0.1", "1", "10"]);
    }

    /// The box of a text primitive (left, top, right, bottom).
    fn text_box(p: &Prim) -> Option<(f64, f64, f64, f64)> {
        let Prim::Text {
            x,
            y,
            size,
            anchor,
            text,
            ..
        } = p
        else {
            return None;
        };
        let w = crate::raster::text_width(*size, text);
        let x0 = match anchor {
            Anchor::Start => *x,
            Anchor::Middle => x - w / 2.0,
            Anchor::End => x - w,
        };
        Some((x0, y - size, x0 + w, y + 3.0))
    }

    #[test]
    fn the_marker_label_stays_clear_of_the_lines() {
        // A flat line at the top of the plot, right across the marker: the label moves down.
        let points = vec![(1.0, 100.0), (2.0, 100.0), (4.0, 100.0)];
        let mut c = line_chart(Scale::Linear, points, vec![]);
        if let Body::Lines { series, .. } = &mut c.body {
            series.push(Series {
                name: "low".into(),
                points: vec![(1.0, 0.0), (4.0, 0.0)],
                color: palette(1),
                dashed: false,
            });
        }
        let prims = c.layout();
        let label = prims
            .iter()
            .find(|p| matches!(p, Prim::Text { text, .. } if text == "m"))
            .and_then(text_box)
            .unwrap();
        let lines: Vec<&Vec<(f64, f64)>> = prims
            .iter()
            .filter_map(|p| match p {
                // The series' lines, not the legend's right of the plot.
                Prim::Line { points, color, .. }
                    if [palette(0), palette(1)].contains(color)
                        && points.iter().all(|p| p.0 <= PLOT.2) =>
                {
                    Some(points)
                }
                _ => None,
            })
            .collect();
        assert_eq!(lines.len(), 2);
        for pts in lines {
            let (lo, hi) = y_span(pts, label.0, label.2).unwrap();
            assert!(hi < label.1 || lo > label.3, "{label:?} meets {pts:?}");
        }
        // Still inside the plot, beside its reference line.
        assert!(label.1 > PLOT.1 && label.3 < PLOT.3, "{label:?}");
    }

    #[test]
    fn bar_marks_are_drawn_over_the_bars() {
        let c = Chart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            body: Body::Bars {
                categories: vec!["a".into()],
                series: vec![BarSeries {
                    name: "s".into(),
                    values: vec![Some(90.0)],
                    color: palette(0),
                }],
                marks: vec![(0, 60.0, "paper".into())],
            },
        };
        let prims = c.layout();
        let bar = prims
            .iter()
            .position(|p| matches!(p, Prim::Rect { .. }))
            .unwrap();
        let halo = prims
            .iter()
            .position(|p| matches!(p, Prim::Line { color, .. } if *color == WHITE))
            .unwrap();
        let dashes = prims
            .iter()
            .position(|p| matches!(p, Prim::Line { dashed: true, .. }))
            .unwrap();
        assert!(bar < halo && halo < dashes);
    }
}
