//! Layout: a [`Chart`] laid out into pixel-space primitives, in stages (title and legend,
//! data ranges, margins and axes, grid, series, annotations, axis titles).

use super::axis::{Axis, linear_axis, log_axis, min_max, text_w};
use super::{
    AXIS, Annotation, Chart, GRID, HALO, INK, MAX_SIDE, MIN_SIDE, PALETTE, Rgba, Style, WHITE,
    XAxis,
};
use crate::error::Result;

/// Horizontal text alignment relative to the anchor point (along the text direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Anchor {
    Start,
    Middle,
    End,
}

/// A pixel-space drawing primitive; both back ends draw the same list.
#[derive(Debug)]
pub(super) enum Prim {
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

/// Sizes derived from the image: text scale and the spacing that scales with it, px.
struct Metrics {
    /// Image width, px.
    wf: f64,
    /// Image height, px.
    hf: f64,
    /// Text scale: 1 below 1600 x 1000 px, 2 from there, 3 from 2400 x 1500 px...
    s: f64,
    /// Line height, px.
    lh: f64,
    /// Padding, px.
    pad: f64,
    /// Tick length, px.
    tick: f64,
}

/// Data ranges (including annotations; bars stand on 0), in data units.
struct Ranges {
    xmin: f64,
    xmax: f64,
    ymin: f64,
    ymax: f64,
}

/// The plot area and its axes, px.
struct PlotArea {
    left: f64,
    top: f64,
    /// Width, px.
    pw: f64,
    /// Height, px.
    ph: f64,
    xa: Axis,
    ya: Axis,
    /// Bar charts: whether the category labels are vertical.
    vertical: bool,
    /// Bar charts: the categories.
    bars: bool,
}

impl PlotArea {
    fn px(&self, x: f64) -> f64 {
        self.left + self.xa.frac(x) * self.pw
    }

    fn py(&self, y: f64) -> f64 {
        self.top + (1.0 - self.ya.frac(y)) * self.ph
    }

    fn right(&self) -> f64 {
        self.left + self.pw
    }

    fn bottom(&self) -> f64 {
        self.top + self.ph
    }
}

impl Chart {
    /// Lay the chart out into primitives for a `width` x `height` px image.
    pub(super) fn layout(&self, width: u32, height: u32) -> Result<Vec<Prim>> {
        let size = format!("size {width}x{height} px");
        let sides = MIN_SIDE..=MAX_SIDE;
        if !sides.contains(&width) || !sides.contains(&height) {
            return Err(self.invalid(&format!("{size}: sides must be {MIN_SIDE}..={MAX_SIDE} px")));
        }
        self.validate()?;
        let (wf, hf) = (width as f64, height as f64);
        let s = (wf / 800.0).min(hf / 500.0).floor().max(1.0);
        let m = Metrics {
            wf,
            hf,
            s,
            lh: 8.0 * s,
            pad: 12.0 * s,
            tick: 5.0 * s,
        };
        let mut sh = Sheet {
            prims: Vec::new(),
            s,
        };
        let top = self.layout_header(&mut sh, &m);
        let ranges = self.data_ranges()?;
        let area = self.layout_axes(&m, top, ranges, &size)?;
        Self::draw_grid(&mut sh, &m, &area);
        self.draw_series(&mut sh, &area);
        self.draw_annotations(&mut sh, &m, &area);
        self.draw_axis_titles(&mut sh, &m, &area);
        Ok(sh.prims)
    }

    /// Title (double size when it fits), then the legend; returns the top of the plot area,
    /// px.
    fn layout_header(&self, sh: &mut Sheet, m: &Metrics) -> f64 {
        let (s, pad, wf) = (m.s, m.pad, m.wf);
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
        (self.legend(sh, top, wf - 2.0 * pad) + pad).round()
    }

    /// Data ranges, including annotations.
    fn data_ranges(&self) -> Result<Ranges> {
        let pts = || self.series.iter().flat_map(|s| s.points.iter().copied());
        let (xmin, xmax) = min_max(
            pts()
                .map(|p| p.0)
                .chain(self.annotation_xy().filter_map(|a| a.0)),
        );
        let (ymin, ymax) = min_max(pts().map(|p| p.1).chain(self.annotation_xy().map(|a| a.1)));
        if !(xmax - xmin).is_finite() || !(ymax - ymin).is_finite() {
            return Err(self.invalid("the data range overflows f64"));
        }
        Ok(Ranges {
            xmin,
            xmax,
            ymin,
            ymax,
        })
    }

    /// Margins and axes: the bottom margin (category labels turn vertical when they do not
    /// fit side by side; bars stand on 0), the y axis, the left margin from its tick labels,
    /// the plot area and the x axis. `size` names the image in errors.
    fn layout_axes(&self, m: &Metrics, top: f64, r: Ranges, size: &str) -> Result<PlotArea> {
        let (s, lh, pad, tick, wf, hf) = (m.s, m.lh, m.pad, m.tick, m.wf, m.hf);
        let (mut ymin, mut ymax) = (r.ymin, r.ymax);
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

        let y_lab_w = ya
            .ticks
            .iter()
            .map(|(_, label)| text_w(label, s))
            .fold(0.0, f64::max);
        let left = (pad + lh + pad + y_lab_w + tick + 4.0 * s).round();
        let pw = (wf - left - pad - 3.0 * lh).round();
        if ph < 60.0 * s || pw < 60.0 * s {
            return Err(self.invalid(&format!("{size} is too small for the labels")));
        }
        let x_ext = |l: &str| text_w(l, s);
        let xa = match &self.x_axis {
            XAxis::Linear => linear_axis(r.xmin, r.xmax, pw, 70.0 * s, &x_ext),
            XAxis::Log => log_axis(r.xmin, r.xmax, pw, &x_ext),
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
        Ok(PlotArea {
            left,
            top,
            pw,
            ph,
            xa,
            ya,
            vertical,
            bars: cats.is_some(),
        })
    }

    /// Grid, ticks and tick labels (1 px lines on pixel centres, so they are crisp).
    fn draw_grid(sh: &mut Sheet, m: &Metrics, a: &PlotArea) {
        let (s, lh, tick) = (m.s, m.lh, m.tick);
        let (left, top, right, bottom) = (a.left, a.top, a.right(), a.bottom());
        for (v, l) in &a.ya.ticks {
            let y = a.py(*v).floor() + 0.5;
            sh.hair((left, y), (right, y), GRID);
            sh.hair((left - tick, y), (left, y), AXIS);
            sh.text((left - tick - 4.0 * s, y), l, Anchor::End, false);
        }
        for (v, l) in &a.xa.ticks {
            let x = a.px(*v).floor() + 0.5;
            if !a.bars {
                sh.hair((x, top), (x, bottom), GRID);
            }
            sh.hair((x, bottom), (x, bottom + tick), AXIS);
            let y = bottom + tick + 4.0 * s;
            match a.vertical {
                true => sh.text((x, y), l, Anchor::End, true),
                false => sh.text((x, y + lh / 2.0), l, Anchor::Middle, false),
            }
        }
    }

    /// Data: bars side by side in 80 % of each category, or lines and markers.
    fn draw_series(&self, sh: &mut Sheet, a: &PlotArea) {
        let bw = 0.8 / self.series.len() as f64;
        for (j, ser) in self.series.iter().enumerate() {
            let color = PALETTE[j % PALETTE.len()];
            if a.bars {
                for &(x, y) in &ser.points {
                    let x0 = a.px(x - 0.4 + (j as f64 + 0.05) * bw);
                    let w = a.px(x - 0.4 + (j as f64 + 0.95) * bw) - x0;
                    let (y0, y1) = (a.py(y).min(a.py(0.0)), a.py(y).max(a.py(0.0)));
                    sh.prims.push(Prim::Rect([x0, y0, w, y1 - y0], color));
                }
                continue;
            }
            let pts: Vec<(f64, f64)> = ser
                .points
                .iter()
                .map(|&(x, y)| (a.px(x), a.py(y)))
                .collect();
            if ser.style != Style::Markers && pts.len() > 1 {
                sh.line(pts.clone(), color, ser.dashed);
            }
            if ser.style != Style::Line || pts.len() == 1 {
                pts.into_iter().for_each(|p| sh.marker(p, color));
            }
        }
        if a.bars && a.ya.lo < 0.0 {
            let y = a.py(0.0).floor() + 0.5;
            sh.hair((a.left, y), (a.right(), y), AXIS);
        }
    }

    /// Annotations, each label on a translucent white box.
    fn draw_annotations(&self, sh: &mut Sheet, m: &Metrics, a: &PlotArea) {
        let (s, lh) = (m.s, m.lh);
        let (left, top, right) = (a.left, a.top, a.right());
        let label = |sh: &mut Sheet, (x, y): (f64, f64), l: &str, anchor: Anchor| {
            let w = text_w(l, s);
            let x0 = if anchor == Anchor::End { x - w } else { x };
            let (m, ch) = (3.0 * s, lh + 6.0 * s);
            sh.prims
                .push(Prim::Rect([x0 - m, y - ch / 2.0, w + 2.0 * m, ch], HALO));
            sh.text((x, y), l, anchor, false);
        };
        for ann in &self.annotations {
            match ann {
                Annotation::HLine { y, label: l } => {
                    let (y, dash) = (a.py(*y), Some((5.0 * s, 4.0 * s)));
                    sh.prims
                        .push(Prim::Path(vec![(left, y), (right, y)], AXIS, 1.5 * s, dash));
                    let ly = if y - 2.0 * lh < top { y + lh } else { y - lh };
                    label(sh, (right - 6.0 * s, ly), l, Anchor::End);
                }
                Annotation::Point { x, y, label: l } => {
                    let (cx, cy) = (a.px(*x), a.py(*y));
                    let ring = Some((INK, 1.5 * s));
                    sh.prims.push(Prim::Circle((cx, cy), 8.0 * s, None, ring));
                    let dy = 12.0 * s + lh / 2.0;
                    let ly = if cy - dy - lh < top { cy + dy } else { cy - dy };
                    match cx + 10.0 * s + text_w(l, s) > right {
                        true => label(sh, (cx - 10.0 * s, ly), l, Anchor::End),
                        false => label(sh, (cx + 10.0 * s, ly), l, Anchor::Start),
                    }
                }
            }
        }
    }

    /// Axis lines and titles.
    fn draw_axis_titles(&self, sh: &mut Sheet, m: &Metrics, a: &PlotArea) {
        let (lh, pad) = (m.lh, m.pad);
        let (left, top, right, bottom) = (a.left, a.top, a.right(), a.bottom());
        sh.hair((left - 0.5, top), (left - 0.5, bottom + 1.0), AXIS);
        sh.hair((left - 1.0, bottom + 0.5), (right, bottom + 0.5), AXIS);
        sh.text(
            (left + a.pw / 2.0, m.hf - pad - lh / 2.0),
            &self.x_label,
            Anchor::Middle,
            false,
        );
        sh.text(
            (pad + lh / 2.0, top + a.ph / 2.0),
            &self.y_label,
            Anchor::Middle,
            true,
        );
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
