//! Axes: ranges and 1-2-5 ticks (linear), decades (log), and text extents for the layout.

/// Width of `text` at `scale` for the layout, px: 8 px per character and scale unit, a little
/// more than DejaVu Sans's mean advance at 12.5 px, so labels never overlap.
pub(super) fn text_w(text: &str, scale: f64) -> f64 {
    text.chars().count() as f64 * 8.0 * scale
}

/// (min, max) of the values; (inf, -inf) when there are none.
pub(super) fn min_max(v: impl Iterator<Item = f64>) -> (f64, f64) {
    v.fold((f64::INFINITY, -f64::INFINITY), |(a, b), x| {
        (a.min(x), b.max(x))
    })
}

/// A laid-out axis: range and labelled ticks, in axis units.
pub(super) struct Axis {
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) log: bool,
    pub(super) ticks: Vec<(f64, String)>,
}

impl Axis {
    /// Position of `v` along the axis, 0 at `lo` and 1 at `hi`.
    pub(super) fn frac(&self, v: f64) -> f64 {
        if self.log {
            (v / self.lo).ln() / (self.hi / self.lo).ln()
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }
}

/// The 1-2-5 step at or above `raw`.
pub(super) fn nice_step(raw: f64) -> f64 {
    let mag = 10f64.powf(raw.log10().floor());
    let m = [1.0, 2.0, 5.0]
        .into_iter()
        .find(|&m| m * mag >= raw * (1.0 - 1e-9));
    m.unwrap_or(10.0) * mag
}

/// Labels for ticks `k * step`: plain decimals, or scientific ("1.5e6") for very large or
/// small values.
pub(super) fn linear_labels(ks: &[i64], step: f64) -> Vec<String> {
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
pub(super) fn linear_axis(
    min: f64,
    max: f64,
    len: f64,
    min_gap: f64,
    extent: &dyn Fn(&str) -> f64,
) -> Axis {
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
pub(super) fn log_axis(min: f64, max: f64, len: f64, extent: &dyn Fn(&str) -> f64) -> Axis {
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
