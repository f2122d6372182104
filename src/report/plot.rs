//! Line, scatter and grouped bar charts written as SVG and PNG, without a plotting crate.
//!
//! A [`Chart`] is laid out once into pixel-space primitives (lines, rectangles, circles,
//! text); [`Chart::to_svg`] writes them as SVG elements and [`Chart::to_png`] renders that
//! same SVG with `resvg` (anti-aliased, text shaped in DejaVu Sans, embedded from
//! `assets/fonts` so that no system font is needed) and encodes the image with the `png`
//! crate. All lengths are pixels (px); data coordinates are in the units the axis labels
//! name, e.g. "TCP speed (m/s)".
//!
//! Series take the Okabe–Ito colours (colour-blind friendly) in order; ticks fall on 1-2-5
//! steps. Degenerate input never panics: a non-finite coordinate, a chart without any point,
//! a non-positive x on a log axis, a bar outside its categories or an image too small for
//! its labels is an [`Error::InvalidInput`]. Non-finite points are rejected rather than
//! skipped, so a report never hides bad data.

use std::fmt::Write as _;
use std::path::Path;

use std::sync::{Arc, OnceLock};

use resvg::{tiny_skia, usvg};

use crate::error::{Error, Result};
use crate::io::write_atomic;

/// An sRGB colour with alpha.
type Rgba = [u8; 4];
/// Okabe–Ito colours (yellow left out: it is unreadable on white).
const PALETTE: [Rgba; 7] = [
    [0x00, 0x72, 0xB2, 255],
    [0xD5, 0x5E, 0x00, 255],
    [0x00, 0x9E, 0x73, 255],
    [0xE6, 0x9F, 0x00, 255],
    [0xCC, 0x79, 0xA7, 255],
    [0x56, 0xB4, 0xE9, 255],
    [0x00, 0x00, 0x00, 255],
];
const INK: Rgba = [0x22, 0x22, 0x22, 255];
const AXIS: Rgba = [0x55, 0x55, 0x55, 255];
const GRID: Rgba = [0xE4, 0xE4, 0xE4, 255];
const WHITE: Rgba = [255, 255, 255, 255];
const HALO: Rgba = [255, 255, 255, 215];
/// The chart font: a subset of DejaVu Sans 2.37 (Basic Latin, Latin-1, Greek, punctuation,
/// super/subscripts, arrows, some math; 33 kB). Bitstream Vera licence with public-domain
/// DejaVu changes: assets/fonts/LICENSE-DejaVu.txt.
const FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");
/// Its family name, first in the SVG's font-family list.
const FONT_FAMILY: &str = "DejaVu Sans";
/// Smallest and largest accepted image sides, px.
const MIN_SIDE: u32 = 200;
const MAX_SIDE: u32 = 4096;

/// How the points of a series are drawn (ignored on a category axis, where series are bars).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// A polyline through the points in the given order.
    Line,
    /// A filled circle at each point.
    Markers,
    /// Both.
    LineMarkers,
}

/// One named data series.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend entry (an empty name is left out of the legend).
    pub name: String,
    /// (x, y) in axis units; on a category axis x is the 0-based category index.
    pub points: Vec<(f64, f64)>,
    /// Drawing style.
    pub style: Style,
    /// Dashed instead of solid line.
    pub dashed: bool,
}

impl Series {
    /// A solid series.
    pub fn new(name: impl Into<String>, points: Vec<(f64, f64)>, style: Style) -> Self {
        Series {
            name: name.into(),
            points,
            style,
            dashed: false,
        }
    }

    /// A bar series for a category axis: `values[i]` is the bar of category `i`.
    pub fn bars(name: impl Into<String>, values: &[f64]) -> Self {
        let points = values.iter().enumerate().map(|(i, &v)| (i as f64, v));
        Series::new(name, points.collect(), Style::Markers)
    }

    /// The same series with a dashed line.
    pub fn dashed(mut self) -> Self {
        self.dashed = true;
        self
    }
}

/// The kind of x axis.
#[derive(Debug, Clone, PartialEq)]
pub enum XAxis {
    /// Linear.
    Linear,
    /// Base-10 logarithmic (every x must be > 0).
    Log,
    /// Named categories with one group of bars each (a grouped bar chart).
    Categories(Vec<String>),
}

/// A labelled mark on the chart, in axis units.
#[derive(Debug, Clone, PartialEq)]
pub enum Annotation {
    /// A dashed horizontal reference line at `y`.
    HLine {
        /// Height in y-axis units.
        y: f64,
        /// Text above the line's right end.
        label: String,
    },
    /// A ring around the point (x, y), e.g. an optimum, with a label beside it.
    Point {
        /// Position in x-axis units (category index on a category axis).
        x: f64,
        /// Position in y-axis units.
        y: f64,
        /// Text beside the ring.
        label: String,
    },
}

/// A chart: titles, axes, series and annotations. Build with [`Chart::new`] and the `with_`
/// methods, or fill the public fields.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// x-axis title with units, e.g. "TCP speed (m/s)".
    pub x_label: String,
    /// y-axis title with units, e.g. "Energy (J)".
    pub y_label: String,
    /// Linear, log or categories.
    pub x_axis: XAxis,
    /// Series in legend and colour order.
    pub series: Vec<Series>,
    /// Reference lines and marked points, drawn over the series.
    pub annotations: Vec<Annotation>,
}

/// Horizontal text alignment relative to the anchor point (along the text direction).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Anchor {
    Start,
    Middle,
    End,
}

/// A pixel-space drawing primitive; both back ends draw the same list.
#[derive(Debug)]
enum Prim {
    /// Filled rectangle `[x, y, w, h]`.
    Rect([f64; 4], Rgba),
    /// Polyline: points, colour, stroke width and optional (dash, gap) lengths.
    Path(Vec<(f64, f64)>, Rgba, f64, Option<(f64, f64)>),
    /// Circle: centre, radius, fill and stroke (colour, width).
    Circle((f64, f64), f64, Option<Rgba>, Option<(Rgba, f64)>),
    /// Dark text: anchor point (the text is centred vertically on it), string, scale (12.5 px
    /// font per unit), alignment, and whether it is vertical (reading bottom to top).
    Text((f64, f64), String, f64, Anchor, bool),
}

/// Primitives being laid out with text scale `s` (1, 2, ...).
struct Sheet {
    prims: Vec<Prim>,
    s: f64,
}

impl Sheet {
    fn text(&mut self, at: (f64, f64), t: &str, anchor: Anchor, vertical: bool) {
        self.prims
            .push(Prim::Text(at, t.to_string(), self.s, anchor, vertical));
    }

    /// A series line, 2 px per scale unit, optionally dashed.
    fn line(&mut self, pts: Vec<(f64, f64)>, color: Rgba, dashed: bool) {
        let dash = dashed.then_some((7.0 * self.s, 4.0 * self.s));
        self.prims.push(Prim::Path(pts, color, 2.0 * self.s, dash));
    }

    /// A 1 px line.
    fn hair(&mut self, a: (f64, f64), b: (f64, f64), color: Rgba) {
        self.prims.push(Prim::Path(vec![a, b], color, 1.0, None));
    }

    /// A data marker: a filled circle with a thin white rim.
    fn marker(&mut self, at: (f64, f64), color: Rgba) {
        let s = self.s;
        self.prims
            .push(Prim::Circle(at, 3.5 * s, Some(color), Some((WHITE, s))));
    }
}

/// Width of `text` at `scale` for the layout, px: 8 px per character and scale unit, a little
/// more than DejaVu Sans's mean advance at 12.5 px, so labels never overlap.
fn text_w(text: &str, scale: f64) -> f64 {
    text.chars().count() as f64 * 8.0 * scale
}

/// (min, max) of the values; (inf, -inf) when there are none.
fn min_max(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.fold((f64::INFINITY, -f64::INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    })
}

/// A laid-out axis: range and labelled ticks, in axis units.
struct Axis {
    lo: f64,
    hi: f64,
    log: bool,
    ticks: Vec<(f64, String)>,
}

impl Axis {
    /// Position of `v` along the axis, 0 at `lo` and 1 at `hi`.
    fn frac(&self, v: f64) -> f64 {
        if self.log {
            (v / self.lo).ln() / (self.hi / self.lo).ln()
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }
}

/// The 1-2-5 step at or above `raw`.
fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    let m = [1.0, 2.0, 5.0]
        .into_iter()
        .find(|&m| m * mag >= raw * (1.0 - 1e-9));
    m.unwrap_or(10.0) * mag
}

/// Labels for ticks `k * step`: plain decimals, or scientific ("1.5e6") for very large or
/// small values.
fn linear_labels(ks: &[i64], step: f64) -> Vec<String> {
    let e_step = step.log10().floor() as i32;
    let max = ks
        .iter()
        .map(|&k| (k as f64 * step).abs())
        .fold(0.0, f64::max);
    let e_max = (max.log10().floor() as i32).max(e_step);
    let sci = |v: f64| {
        let s = format!("{v:.*e}", (e_max - e_step).clamp(0, 6) as usize);
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        // The mantissa has one digit before the point, and it is not 0.
        format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'))
    };
    let plain = |v: f64| format!("{v:.*}", (-e_step).max(0) as usize);
    let label = |k: i64| match k as f64 * step {
        _ if k == 0 => "0".to_string(),
        v if e_step < -4 || e_max >= 6 => sci(v),
        v => plain(v),
    };
    ks.iter().map(|&k| label(k)).collect()
}

/// A linear axis over at least [min, max], ending on ticks, with ticks at least `min_gap` px
/// apart whose labels do not overlap (`extent`: a label's length along the axis, px).
fn linear_axis(min: f64, max: f64, len: f64, min_gap: f64, extent: &dyn Fn(&str) -> f64) -> Axis {
    let (min, max) = match max - min {
        d if d > 1e-12 * max.abs().max(min.abs()) => (min, max),
        _ if min == 0.0 => (-1.0, 1.0),
        _ => (min - 0.1 * min.abs(), max + 0.1 * max.abs()),
    };
    let mut step = nice_step((max - min) / 12.0);
    loop {
        let ka = (min / step + 1e-9).floor() as i64;
        let kb = (max / step - 1e-9).ceil() as i64;
        let ks: Vec<i64> = (ka..=kb).collect();
        let labels = linear_labels(&ks, step);
        let widest = labels.iter().map(|l| extent(l)).fold(0.0, f64::max);
        let gap = len / (kb - ka).max(1) as f64;
        if (gap >= min_gap && gap >= widest + 8.0) || ks.len() <= 2 {
            let ticks = ks.iter().map(|&k| k as f64 * step).zip(labels).collect();
            let (lo, hi) = (ka as f64 * step, kb as f64 * step);
            return Axis {
                lo,
                hi,
                log: false,
                ticks,
            };
        }
        step = nice_step(step * 1.5);
    }
}

/// A base-10 log axis over [min, max] (both > 0): 1-2-5 ticks over up to 2.5 decades,
/// otherwise decades (every n-th when their labels would overlap).
fn log_axis(min: f64, max: f64, len: f64, extent: &dyn Fn(&str) -> f64) -> Axis {
    let widen = if max > min * (1.0 + 1e-9) { 1.0 } else { 2.0 };
    let (min, max) = (min / widen, max * widen);
    let short = (max / min).log10() <= 2.5;
    let ms: &[f64] = if short {
        &[1.0, 2.0, 5.0, 10.0]
    } else {
        &[1.0, 10.0]
    };
    let snap = |v: f64, up: bool| {
        let mut c = ms.iter().map(|m| m * 10f64.powf(v.log10().floor()));
        let found = if up {
            c.find(|&c| c >= v * (1.0 - 1e-12))
        } else {
            c.rfind(|&c| c <= v * (1.0 + 1e-12))
        };
        found.unwrap_or(v)
    };
    let (lo, hi) = (snap(min, false), snap(max, true));
    let (ea, eb) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let label = |m: f64, e: i32| match e {
        -4..=5 => format!("{:.*}", (-e).max(0) as usize, m * 10f64.powi(e)),
        _ => format!("{m}e{e}"),
    };
    let sets =
        std::iter::once((&[1.0, 2.0, 5.0][..], 1)).chain([1, 2, 3, 5, 10].map(|n| (&[1.0][..], n)));
    let mut ticks = Vec::new();
    for (ms, stride) in sets {
        ticks = (ea..=eb)
            .filter(|e| e.rem_euclid(stride) == 0)
            .flat_map(|e| ms.iter().map(move |&m| (m * 10f64.powi(e), m, e)))
            .filter(|&(v, ..)| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9))
            .map(|(v, m, e)| (v, label(m, e)))
            .collect::<Vec<_>>();
        let fits = ticks.windows(2).all(|w| {
            let gap = len * (w[1].0 / w[0].0).log10() / (hi / lo).log10();
            gap >= (extent(&w[0].1) + extent(&w[1].1)) / 2.0 + 8.0
        });
        if fits && ticks.len() >= 2 {
            break;
        }
    }
    Axis {
        lo,
        hi,
        log: true,
        ticks,
    }
}

impl Chart {
    /// An empty chart with a linear x axis.
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
    ) -> Self {
        let (title, x_label, y_label) = (title.into(), x_label.into(), y_label.into());
        let (x_axis, series, annotations) = (XAxis::Linear, Vec::new(), Vec::new());
        Chart {
            title,
            x_label,
            y_label,
            x_axis,
            series,
            annotations,
        }
    }

    /// The same chart with another x axis.
    pub fn with_x_axis(mut self, x_axis: XAxis) -> Self {
        self.x_axis = x_axis;
        self
    }

    /// The same chart with one more series.
    pub fn with_series(mut self, series: Series) -> Self {
        self.series.push(series);
        self
    }

    /// The same chart with one more annotation.
    pub fn with_annotation(mut self, annotation: Annotation) -> Self {
        self.annotations.push(annotation);
        self
    }

    /// The chart as a standalone SVG document of `width` x `height` px.
    pub fn to_svg(&self, width: u32, height: u32) -> Result<String> {
        let prims = self.layout(width, height)?;
        let mut s = format!(
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" \
             width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\" \
             font-family=\"{FONT_FAMILY}, Helvetica, Arial, sans-serif\">\n\
             <rect width=\"{width}\" height=\"{height}\" fill=\"#ffffff\"/>\n"
        );
        for p in &prims {
            svg_prim(&mut s, p);
        }
        s.push_str("</svg>\n");
        Ok(s)
    }

    /// The chart as an 8-bit RGB PNG of `width` x `height` px: [`Chart::to_svg`] rendered by
    /// `resvg` with the embedded DejaVu Sans.
    pub fn to_png(&self, width: u32, height: u32) -> Result<Vec<u8>> {
        let svg = self.to_svg(width, height)?;
        let render_err = |what: &str| self.invalid(&format!("PNG rendering failed: {what}"));
        let tree =
            usvg::Tree::from_str(&svg, svg_options()).map_err(|e| render_err(&e.to_string()))?;
        let mut pixmap =
            tiny_skia::Pixmap::new(width, height).ok_or_else(|| render_err("empty image"))?;
        resvg::render(
            &tree,
            tiny_skia::Transform::identity(),
            &mut pixmap.as_mut(),
        );
        // The SVG paints an opaque white background first, so premultiplied RGBA is plain RGB.
        let rgb: Vec<u8> = pixmap
            .data()
            .chunks_exact(4)
            .flat_map(|px| [px[0], px[1], px[2]])
            .collect();
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let err = |e: png::EncodingError| Error::InvalidInput(format!("PNG encoding failed: {e}"));
        let mut w = enc.write_header().map_err(err)?;
        w.write_image_data(&rgb).map_err(err)?;
        w.finish().map_err(err)?;
        Ok(out)
    }

    fn invalid(&self, what: &str) -> Error {
        Error::InvalidInput(format!("chart \"{}\": {what}", self.title))
    }

    /// Annotation positions (x where there is one, y).
    fn annotation_xy(&self) -> impl Iterator<Item = (Option<f64>, f64)> + '_ {
        self.annotations.iter().map(|a| match a {
            Annotation::HLine { y, .. } => (None, *y),
            Annotation::Point { x, y, .. } => (Some(*x), *y),
        })
    }

    /// Check the data: finite, something to plot, positive x on a log axis, bars on categories.
    fn validate(&self) -> Result<()> {
        if self.series.iter().all(|s| s.points.is_empty()) {
            return Err(self.invalid("no data points to plot"));
        }
        let mut xs: Vec<(f64, String)> = Vec::new();
        for s in &self.series {
            for (i, &(x, y)) in s.points.iter().enumerate() {
                let what = format!("series \"{}\" point {} ({x}, {y})", s.name, i + 1);
                if !x.is_finite() || !y.is_finite() {
                    return Err(self.invalid(&format!("{what} is not finite")));
                }
                xs.push((x, what));
            }
        }
        for (x, y) in self.annotation_xy() {
            if !y.is_finite() || x.is_some_and(|x| !x.is_finite()) {
                return Err(self.invalid(&format!("annotation at ({x:?}, {y}) is not finite")));
            }
            xs.extend(x.map(|x| (x, format!("annotation at x = {x}"))));
        }
        for (x, what) in xs {
            let problem = match &self.x_axis {
                XAxis::Log if x <= 0.0 => "x must be > 0 on a log axis".to_string(),
                XAxis::Categories(c) if x < 0.0 || x.fract() != 0.0 || x >= c.len() as f64 => {
                    format!("x must be a category index 0..{}", c.len())
                }
                _ => continue,
            };
            return Err(self.invalid(&format!("{what}: {problem}")));
        }
        Ok(())
    }

    /// Lay the chart out into primitives for a `width` x `height` px image.
    fn layout(&self, width: u32, height: u32) -> Result<Vec<Prim>> {
        let size = format!("size {width}x{height} px");
        let sides = MIN_SIDE..=MAX_SIDE;
        if !sides.contains(&width) || !sides.contains(&height) {
            return Err(self.invalid(&format!("{size}: sides must be {MIN_SIDE}..={MAX_SIDE} px")));
        }
        self.validate()?;
        let (wf, hf) = (width as f64, height as f64);
        // Text scale: 1 below 1600 x 1000 px, 2 from there, 3 from 2400 x 1500 px...
        let s = (wf / 800.0).min(hf / 500.0).floor().max(1.0);
        let (lh, pad, tick) = (8.0 * s, 12.0 * s, 5.0 * s);
        let mut sh = Sheet {
            prims: Vec::new(),
            s,
        };

        // Title (double size when it fits), then the legend.
        let mut top = pad;
        if !self.title.is_empty() {
            let ts = if text_w(&self.title, 2.0 * s) <= wf - 2.0 * pad {
                2.0 * s
            } else {
                s
            };
            let at = (wf / 2.0, top + 4.0 * ts);
            sh.prims.push(Prim::Text(
                at,
                self.title.clone(),
                ts,
                Anchor::Middle,
                false,
            ));
            top += 8.0 * ts + pad;
        }
        let top = (self.legend(&mut sh, top, wf - 2.0 * pad) + pad).round();

        // Data ranges, including annotations; bars stand on 0.
        let pts = || self.series.iter().flat_map(|s| s.points.iter().copied());
        let (xmin, xmax) = min_max(
            pts()
                .map(|p| p.0)
                .chain(self.annotation_xy().filter_map(|a| a.0)),
        );
        let (mut ymin, mut ymax) =
            min_max(pts().map(|p| p.1).chain(self.annotation_xy().map(|a| a.1)));
        if !(xmax - xmin).is_finite() || !(ymax - ymin).is_finite() {
            return Err(self.invalid("the data range overflows f64"));
        }

        // Bottom margin; category labels turn vertical when they do not fit side by side.
        let cats = match &self.x_axis {
            XAxis::Categories(c) => Some(c),
            _ => None,
        };
        let (mut vertical, mut x_extent) = (false, lh);
        if let Some(c) = cats {
            (ymin, ymax) = (ymin.min(0.0), ymax.max(0.0));
            let widest = c.iter().map(|l| text_w(l, s)).fold(0.0, f64::max);
            vertical = widest + 8.0 * s > (wf - 2.0 * pad - 12.0 * lh) / c.len() as f64;
            x_extent = if vertical { widest } else { lh };
        }
        let ph = (hf - top - (tick + 4.0 * s + x_extent + pad + lh + pad)).round();
        let ya = linear_axis(ymin, ymax, ph, 40.0 * s, &|_| 2.0 * lh);

        // Left margin from the y tick labels; the plot area; the x axis.
        let y_lab_w = ya.ticks.iter().map(|t| text_w(&t.1, s)).fold(0.0, f64::max);
        let left = (pad + lh + pad + y_lab_w + tick + 4.0 * s).round();
        let pw = (wf - left - pad - 3.0 * lh).round();
        if ph < 60.0 * s || pw < 60.0 * s {
            return Err(self.invalid(&format!("{size} is too small for the labels")));
        }
        let x_ext = |l: &str| text_w(l, s);
        let xa = match &self.x_axis {
            XAxis::Linear => linear_axis(xmin, xmax, pw, 70.0 * s, &x_ext),
            XAxis::Log => log_axis(xmin, xmax, pw, &x_ext),
            XAxis::Categories(c) => {
                let ticks = c.iter().enumerate().map(|(i, l)| (i as f64, l.clone()));
                let hi = c.len() as f64 - 0.5;
                Axis {
                    lo: -0.5,
                    hi,
                    log: false,
                    ticks: ticks.collect(),
                }
            }
        };
        let px = |x: f64| left + xa.frac(x) * pw;
        let py = |y: f64| top + (1.0 - ya.frac(y)) * ph;
        let (right, bottom) = (left + pw, top + ph);

        // Grid, ticks and tick labels (1 px lines on pixel centres, so they are crisp).
        for (v, l) in &ya.ticks {
            let y = py(*v).floor() + 0.5;
            sh.hair((left, y), (right, y), GRID);
            sh.hair((left - tick, y), (left, y), AXIS);
            sh.text((left - tick - 4.0 * s, y), l, Anchor::End, false);
        }
        for (v, l) in &xa.ticks {
            let x = px(*v).floor() + 0.5;
            if cats.is_none() {
                sh.hair((x, top), (x, bottom), GRID);
            }
            sh.hair((x, bottom), (x, bottom + tick), AXIS);
            let y = bottom + tick + 4.0 * s;
            match vertical {
                true => sh.text((x, y), l, Anchor::End, true),
                false => sh.text((x, y + lh / 2.0), l, Anchor::Middle, false),
            }
        }

        // Data: bars side by side in 80 % of each category, or lines and markers.
        let bw = 0.8 / self.series.len() as f64;
        for (j, ser) in self.series.iter().enumerate() {
            let color = PALETTE[j % PALETTE.len()];
            if cats.is_some() {
                for &(x, y) in &ser.points {
                    let x0 = px(x - 0.4 + (j as f64 + 0.05) * bw);
                    let w = px(x - 0.4 + (j as f64 + 0.95) * bw) - x0;
                    let (y0, y1) = (py(y).min(py(0.0)), py(y).max(py(0.0)));
                    sh.prims.push(Prim::Rect([x0, y0, w, y1 - y0], color));
                }
                continue;
            }
            let pts: Vec<(f64, f64)> = ser.points.iter().map(|&(x, y)| (px(x), py(y))).collect();
            if ser.style != Style::Markers && pts.len() > 1 {
                sh.line(pts.clone(), color, ser.dashed);
            }
            if ser.style != Style::Line || pts.len() == 1 {
                pts.into_iter().for_each(|p| sh.marker(p, color));
            }
        }
        if cats.is_some() && ya.lo < 0.0 {
            let y = py(0.0).floor() + 0.5;
            sh.hair((left, y), (right, y), AXIS);
        }

        // Annotations, each label on a translucent white box.
        let label = |sh: &mut Sheet, (x, y): (f64, f64), l: &str, anchor: Anchor| {
            let w = text_w(l, s);
            let x0 = if anchor == Anchor::End { x - w } else { x };
            let (m, ch) = (3.0 * s, lh + 6.0 * s);
            sh.prims
                .push(Prim::Rect([x0 - m, y - ch / 2.0, w + 2.0 * m, ch], HALO));
            sh.text((x, y), l, anchor, false);
        };
        for a in &self.annotations {
            match a {
                Annotation::HLine { y, label: l } => {
                    let (y, dash) = (py(*y), Some((5.0 * s, 4.0 * s)));
                    sh.prims
                        .push(Prim::Path(vec![(left, y), (right, y)], AXIS, 1.5 * s, dash));
                    let ly = if y - 2.0 * lh < top { y + lh } else { y - lh };
                    label(&mut sh, (right - 6.0 * s, ly), l, Anchor::End);
                }
                Annotation::Point { x, y, label: l } => {
                    let (cx, cy) = (px(*x), py(*y));
                    let ring = Some((INK, 1.5 * s));
                    sh.prims.push(Prim::Circle((cx, cy), 8.0 * s, None, ring));
                    let dy = 12.0 * s + lh / 2.0;
                    let ly = if cy - dy - lh < top { cy + dy } else { cy - dy };
                    match cx + 10.0 * s + text_w(l, s) > right {
                        true => label(&mut sh, (cx - 10.0 * s, ly), l, Anchor::End),
                        false => label(&mut sh, (cx + 10.0 * s, ly), l, Anchor::Start),
                    }
                }
            }
        }

        // Axis lines and titles.
        sh.hair((left - 0.5, top), (left - 0.5, bottom + 1.0), AXIS);
        sh.hair((left - 1.0, bottom + 0.5), (right, bottom + 0.5), AXIS);
        sh.text(
            (left + pw / 2.0, hf - pad - lh / 2.0),
            &self.x_label,
            Anchor::Middle,
            false,
        );
        sh.text(
            (pad + lh / 2.0, top + ph / 2.0),
            &self.y_label,
            Anchor::Middle,
            true,
        );
        Ok(sh.prims)
    }

    /// Legend rows centred under the title from `top`, at most `max_w` px wide; returns the
    /// y below the legend, px.
    fn legend(&self, sh: &mut Sheet, top: f64, max_w: f64) -> f64 {
        let s = sh.s;
        let bars = matches!(self.x_axis, XAxis::Categories(_));
        let (swatch, gap, sep) = (if bars { 10.0 } else { 26.0 } * s, 6.0 * s, 22.0 * s);
        // Rows of (total width, entries of (series index, width)).
        let mut rows: Vec<(f64, Vec<(usize, f64)>)> = Vec::new();
        for (j, ser) in self
            .series
            .iter()
            .enumerate()
            .filter(|e| !e.1.name.is_empty())
        {
            let w = swatch + gap + text_w(&ser.name, s);
            match rows.last_mut() {
                Some((used, row)) if *used + sep + w <= max_w => {
                    *used += sep + w;
                    row.push((j, w));
                }
                _ => rows.push((w, vec![(j, w)])),
            }
        }
        let mut cy = top + 4.0 * s;
        for (total, row) in rows {
            let mut x = ((max_w - total) / 2.0 + 12.0 * s).round();
            for (j, w) in row {
                let (ser, color) = (&self.series[j], PALETTE[j % PALETTE.len()]);
                if bars {
                    sh.prims
                        .push(Prim::Rect([x, cy - 5.0 * s, swatch, 10.0 * s], color));
                }
                if !bars && ser.style != Style::Markers {
                    sh.line(vec![(x, cy), (x + swatch, cy)], color, ser.dashed);
                }
                if !bars && ser.style != Style::Line {
                    sh.marker((x + swatch / 2.0, cy), color);
                }
                sh.text((x + swatch + gap, cy), &ser.name, Anchor::Start, false);
                x += w + sep;
            }
            cy += 14.0 * s;
        }
        cy - 4.0 * s
    }
}

/// Write `chart` as `dir/stem.svg` and `dir/stem.png` (`width` x `height` px), each
/// atomically; nothing is written when the chart is invalid. `dir` must exist.
pub fn write_chart(chart: &Chart, dir: &Path, stem: &str, width: u32, height: u32) -> Result<()> {
    let svg = chart.to_svg(width, height)?;
    let png = chart.to_png(width, height)?;
    write_atomic(&dir.join(format!("{stem}.svg")), svg.as_bytes())?;
    write_atomic(&dir.join(format!("{stem}.png")), &png)
}

/// XML-escaped text; control characters (not allowed in XML) become spaces.
fn xml_escape(t: &str) -> String {
    let t: String = t
        .chars()
        .map(|c| if c.is_control() { ' ' } else { c })
        .collect();
    t.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// `fill="#rrggbb"` (or another attribute) plus an opacity attribute when translucent.
fn svg_color(attr: &str, c: Rgba) -> String {
    let mut s = format!("{attr}=\"#{:02x}{:02x}{:02x}\"", c[0], c[1], c[2]);
    if c[3] < 255 {
        let _ = write!(s, " {attr}-opacity=\"{:.2}\"", c[3] as f64 / 255.0);
    }
    s
}

fn svg_prim(s: &mut String, p: &Prim) {
    let _ = match p {
        Prim::Rect([x, y, w, h], fill) => {
            let fill = svg_color("fill", *fill);
            writeln!(
                s,
                r#"<rect x="{x:.2}" y="{y:.2}" width="{w:.2}" height="{h:.2}" {fill}/>"#
            )
        }
        Prim::Path(pts, color, width, dash) => {
            let pts: Vec<String> = pts.iter().map(|(x, y)| format!("{x:.2},{y:.2}")).collect();
            let (pts, stroke) = (pts.join(" "), svg_color("stroke", *color));
            let dash = dash.map_or(String::new(), |(a, b)| {
                format!(r#" stroke-dasharray="{a} {b}""#)
            });
            let style = format!(r#"stroke-width="{width}" stroke-linejoin="round"{dash}"#);
            writeln!(
                s,
                r#"<polyline points="{pts}" fill="none" {stroke} {style}/>"#
            )
        }
        Prim::Circle((cx, cy), r, fill, stroke) => {
            let fill = fill.map_or(r#"fill="none""#.into(), |c| svg_color("fill", c));
            let stroke = stroke.map_or(String::new(), |(c, w)| {
                format!(r#" {} stroke-width="{w}""#, svg_color("stroke", c))
            });
            writeln!(
                s,
                r#"<circle cx="{cx:.2}" cy="{cy:.2}" r="{r}" {fill}{stroke}/>"#
            )
        }
        Prim::Text((x, y), text, scale, anchor, vertical) => {
            let size = 12.5 * scale;
            let anchor = format!("{anchor:?}").to_lowercase();
            let rot = match vertical {
                true => format!(r#" transform="rotate(-90 {x:.2} {y:.2})""#),
                false => String::new(),
            };
            let (yb, fill, body) = (y + 0.35 * size, svg_color("fill", INK), xml_escape(text));
            let attrs = format!(r#"font-size="{size}" text-anchor="{anchor}" {fill}{rot}"#);
            writeln!(s, r#"<text x="{x:.2}" y="{yb:.2}" {attrs}>{body}</text>"#)
        }
    };
}

/// SVG parsing options with the embedded font as the only font (built once).
fn svg_options() -> &'static usvg::Options<'static> {
    static OPTIONS: OnceLock<usvg::Options<'static>> = OnceLock::new();
    OPTIONS.get_or_init(|| {
        let mut db = usvg::fontdb::Database::new();
        db.load_font_data(FONT.to_vec());
        usvg::Options {
            font_family: FONT_FAMILY.to_string(),
            fontdb: Arc::new(db),
            ..usvg::Options::default()
        }
    })
}
