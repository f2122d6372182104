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

mod axis;
mod layout;
mod svg;

use std::path::Path;

use resvg::{tiny_skia, usvg};

use crate::error::{Error, Result};
use crate::io::write_atomic;

use svg::{svg_options, svg_prim};

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
const FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans-subset.ttf");
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
}

/// Write `chart` as `dir/stem.svg` and `dir/stem.png` (`width` x `height` px), each
/// atomically; nothing is written when the chart is invalid. `dir` must exist.
pub fn write_chart(chart: &Chart, dir: &Path, stem: &str, width: u32, height: u32) -> Result<()> {
    let svg = chart.to_svg(width, height)?;
    let png = chart.to_png(width, height)?;
    write_atomic(&dir.join(format!("{stem}.svg")), svg.as_bytes())?;
    write_atomic(&dir.join(format!("{stem}.png")), &png)
}
