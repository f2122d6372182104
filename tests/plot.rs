//! Report charts: well-formed SVG with the expected text, PNGs that decode to the requested
//! size with the series drawn where they belong, and errors (never panics) on degenerate input.

use powertwin::Error;
use powertwin::report::plot::{Annotation, Chart, Series, Style, XAxis, write_chart};
use proptest::prelude::*;

/// The first Okabe–Ito colour, which the first series takes.
const BLUE: [u8; 3] = [0x00, 0x72, 0xB2];
const VERMILLION: [u8; 3] = [0xD5, 0x5E, 0x00];

fn energy_chart() -> Chart {
    let fast: Vec<(f64, f64)> = (1..=20)
        .map(|i| (0.1 * i as f64, 100.0 + 10.0 * i as f64))
        .collect();
    Chart::new(
        "Energy <vs> speed & \"payload\"",
        "TCP speed (m/s)",
        "Energy (J)",
    )
    .with_series(Series::new("model", fast, Style::Line))
    .with_series(Series::new("measured", vec![(0.5, 160.0), (1.5, 240.0)], Style::Markers).dashed())
    .with_annotation(Annotation::Point {
        x: 0.5,
        y: 160.0,
        label: "optimum".into(),
    })
    .with_annotation(Annotation::HLine {
        y: 200.0,
        label: "budget".into(),
    })
}

/// Tags of an SVG document balance (a minimal XML well-formedness check); returns the text
/// contents of the `<text>` elements.
fn check_xml(svg: &str) -> Vec<String> {
    let body = svg
        .strip_prefix("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n")
        .expect("XML declaration");
    let (mut stack, mut texts, mut rest) = (Vec::new(), Vec::new(), body);
    while let Some(open) = rest.find('<') {
        let content = &rest[..open];
        assert!(!content.contains('>'), "stray '>' in {content:?}");
        for (i, _) in content.match_indices('&') {
            let entity = &content[i..content[i..].find(';').map_or(content.len(), |e| i + e + 1)];
            assert!(
                ["&amp;", "&lt;", "&gt;"].contains(&entity),
                "bad entity {entity:?}"
            );
        }
        if stack.last() == Some(&"text") {
            texts.push(
                content
                    .replace("&lt;", "<")
                    .replace("&gt;", ">")
                    .replace("&amp;", "&"),
            );
        }
        let close = rest[open..].find('>').expect("tag closes") + open;
        let tag = &rest[open + 1..close];
        assert_eq!(
            tag.matches('"').count() % 2,
            0,
            "unbalanced quotes in <{tag}>"
        );
        if let Some(name) = tag.strip_prefix('/') {
            assert_eq!(stack.pop(), Some(name), "closing </{name}>");
        } else if !tag.ends_with('/') {
            stack.push(tag.split_whitespace().next().expect("tag name"));
        }
        rest = &rest[close + 1..];
    }
    assert!(
        stack.is_empty() && rest.trim().is_empty(),
        "unclosed {stack:?}"
    );
    texts
}

fn decode(png_bytes: &[u8]) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::Cursor::new(png_bytes));
    let mut reader = decoder.read_info().expect("PNG header");
    let mut buf = vec![0; reader.output_buffer_size().expect("buffer size")];
    let info = reader.next_frame(&mut buf).expect("PNG frame");
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Rgb, png::BitDepth::Eight)
    );
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn pixel(rgb: &[u8], w: u32, x: u32, y: u32) -> [u8; 3] {
    let i = 3 * (y * w + x) as usize;
    [rgb[i], rgb[i + 1], rgb[i + 2]]
}

/// Rows of the pixels of exactly colour `c` in each column.
fn rows_of(rgb: &[u8], w: u32, h: u32, c: [u8; 3]) -> Vec<Vec<u32>> {
    (0..w)
        .map(|x| (0..h).filter(|&y| pixel(rgb, w, x, y) == c).collect())
        .collect()
}

fn invalid(r: powertwin::Result<impl std::fmt::Debug>) -> String {
    match r {
        Err(Error::InvalidInput(m)) => m,
        other => panic!("expected InvalidInput, got {other:?}"),
    }
}

#[test]
fn svg_is_well_formed_with_title_legend_and_ticks() {
    let svg = energy_chart().to_svg(800, 500).unwrap();
    assert!(svg.contains("width=\"800\" height=\"500\""));
    let texts = check_xml(&svg);
    for want in [
        "Energy <vs> speed & \"payload\"",
        "TCP speed (m/s)",
        "Energy (J)",
        "model",
        "measured",
        "optimum",
        "budget",
    ] {
        assert!(
            texts.iter().any(|t| t == want),
            "{want:?} missing from {texts:?}"
        );
    }
    // Tick labels: 0 to 2 m/s on x, 100 to 300 J on y, on 1-2-5 steps.
    for want in ["0", "0.5", "1.0", "2.0", "100", "200", "300"] {
        assert!(
            texts.iter().any(|t| t == want),
            "tick {want:?} missing from {texts:?}"
        );
    }
    let numbers: Vec<f64> = texts.iter().filter_map(|t| t.parse().ok()).collect();
    for w in numbers.windows(2).filter(|w| w[1] > w[0]) {
        let step = w[1] - w[0];
        let m = step / 10f64.powf(step.log10().floor());
        assert!(
            [1.0, 2.0, 5.0].iter().any(|n| (m - n).abs() < 1e-6),
            "step {step} in {numbers:?}"
        );
    }
    assert!(svg.contains("stroke-dasharray"), "dashed series");
}

#[test]
fn png_decodes_to_the_requested_size_and_draws_the_rising_line() {
    let (w, h) = (640, 400);
    let (dw, dh, rgb) = decode(&energy_chart().to_png(w, h).unwrap());
    assert_eq!((dw, dh), (w, h));
    assert_eq!(pixel(&rgb, w, 0, 0), [255, 255, 255], "white background");
    // The "model" line rises from left to right across most of the width: the lowest pixel
    // of its colour in each column (below the legend swatch) moves up column by column.
    let lowest: Vec<(u32, u32)> = rows_of(&rgb, w, h, BLUE)
        .iter()
        .enumerate()
        .filter_map(|(x, r)| r.last().map(|&y| (x as u32, y)))
        .collect();
    let (first, last) = (lowest[0].0, lowest[lowest.len() - 1].0);
    assert!(last - first > w / 2, "line spans {first}..{last}");
    assert!(
        lowest.len() as u32 > (last - first) * 3 / 4,
        "line has gaps"
    );
    let falls = lowest.windows(2).filter(|p| p[1].1 > p[0].1 + 1).count();
    assert!(falls <= 2, "line does not rise steadily: {lowest:?}");
    assert!(
        lowest[0].1 - lowest[lowest.len() - 1].1 > h / 3,
        "line rise too small"
    );
    // The markers of the second series are there too (legend and data).
    assert!(rows_of(&rgb, w, h, VERMILLION).iter().flatten().count() > 40);
}

#[test]
fn bar_chart_draws_bars_of_both_series() {
    let cats: Vec<String> = (1..=6).map(|i| format!("cell {i}")).collect();
    let chart = Chart::new("Error per sweep cell", "Sweep cell", "Error (%)")
        .with_x_axis(XAxis::Categories(cats))
        .with_series(Series::bars("identified", &[1.0, 2.0, 0.5, 3.0, 1.5, 2.5]))
        .with_series(Series::bars("nominal", &[-2.0, 4.0, 6.0, 5.0, 7.0, 3.0]));
    let texts = check_xml(&chart.to_svg(700, 450).unwrap());
    assert!(
        ["cell 1", "cell 6", "identified", "nominal", "-2", "6"]
            .iter()
            .all(|w| texts.iter().any(|t| t == w)),
        "{texts:?}"
    );
    let (w, h, rgb) = decode(&chart.to_png(700, 450).unwrap());
    // Six filled blue bars (plus the legend swatch): columns with a tall run of blue.
    let tall = |c| {
        rows_of(&rgb, w, h, c)
            .iter()
            .filter(|r| r.len() >= 10)
            .count()
    };
    assert!(
        tall(BLUE) > 6 * 10 && tall(VERMILLION) > 6 * 10,
        "bars missing"
    );
}

#[test]
fn log_axis_labels_decades_and_rejects_non_positive_x() {
    let pts = vec![(0.01, 5.0), (1.0, 3.0), (100.0, 4.0)];
    let chart = Chart::new("Log", "Frequency (Hz)", "Gain (1)")
        .with_x_axis(XAxis::Log)
        .with_series(Series::new("g", pts, Style::LineMarkers));
    let texts = check_xml(&chart.to_svg(800, 500).unwrap());
    for want in ["0.01", "0.1", "1", "10", "100"] {
        assert!(
            texts.iter().any(|t| t == want),
            "decade {want} missing from {texts:?}"
        );
    }
    chart.to_png(800, 500).unwrap();
    for bad_x in [0.0, -1.0] {
        let c = chart
            .clone()
            .with_series(Series::new("bad", vec![(bad_x, 1.0)], Style::Line));
        assert!(invalid(c.to_svg(800, 500)).contains("log axis"));
        assert!(invalid(c.to_png(800, 500)).contains("log axis"));
        let a = chart.clone().with_annotation(Annotation::Point {
            x: bad_x,
            y: 1.0,
            label: "x".into(),
        });
        assert!(invalid(a.to_png(800, 500)).contains("log axis"));
    }
}

#[test]
fn degenerate_inputs_are_errors_not_panics() {
    let base = || Chart::new("t", "x (m)", "y (J)");
    assert!(invalid(base().to_svg(400, 300)).contains("no data"));
    let empty = base().with_series(Series::new("empty", vec![], Style::Line));
    assert!(invalid(empty.to_png(400, 300)).contains("no data"));
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let c = base().with_series(Series::new("s", vec![(0.0, 1.0), (1.0, bad)], Style::Line));
        assert!(invalid(c.to_svg(400, 300)).contains("not finite"));
        assert!(invalid(c.to_png(400, 300)).contains("not finite"));
        let a = base().with_series(Series::new("s", vec![(0.0, 1.0)], Style::Line));
        let a = a.with_annotation(Annotation::HLine {
            y: bad,
            label: "l".into(),
        });
        assert!(invalid(a.to_png(400, 300)).contains("not finite"));
    }
    let huge = base().with_series(Series::new(
        "s",
        vec![(0.0, -f64::MAX), (1.0, f64::MAX)],
        Style::Line,
    ));
    assert!(invalid(huge.to_svg(400, 300)).contains("overflows"));
    let ok = base().with_series(Series::new("s", vec![(0.0, 1.0)], Style::Line));
    for (w, h) in [(0, 300), (400, 0), (100, 100), (5000, 300)] {
        assert!(invalid(ok.to_png(w, h)).contains("px"), "{w}x{h}");
    }
    let cats = base().with_x_axis(XAxis::Categories(vec!["a".into(), "b".into()]));
    for x in [-1.0, 0.5, 2.0] {
        let c = cats
            .clone()
            .with_series(Series::new("s", vec![(x, 1.0)], Style::Line));
        assert!(
            invalid(c.to_svg(400, 300)).contains("category index"),
            "x = {x}"
        );
    }
    let long = cats.with_x_axis(XAxis::Categories(vec![
        "a very long category label indeed".repeat(3),
    ]));
    let long = long.with_series(Series::bars("s", &[1.0]));
    assert!(invalid(long.to_png(300, 250)).contains("too small"));
}

#[test]
fn single_points_equal_values_and_unnamed_series_still_draw() {
    let cases = [
        vec![(1.0, 2.0)],
        vec![(0.0, 0.0)],
        vec![(0.0, 5.0), (1.0, 5.0), (2.0, 5.0)],
        vec![(3.0, 1.0), (3.0, 2.0)],
        vec![(1e-9, 1e12), (2e-9, 1.0000001e12)],
    ];
    for pts in cases {
        for style in [Style::Line, Style::Markers, Style::LineMarkers] {
            let c = Chart::new("", "", "").with_series(Series::new("", pts.clone(), style));
            check_xml(&c.to_svg(300, 200).unwrap());
            let (w, h, rgb) = decode(&c.to_png(300, 200).unwrap());
            let drawn = rows_of(&rgb, w, h, BLUE).iter().flatten().count();
            assert!(drawn > 0, "{pts:?} {style:?} drew nothing");
        }
    }
    // Equal values get a widened axis with distinct tick labels.
    let flat = Chart::new("flat", "t (s)", "P (W)").with_series(Series::new(
        "p",
        vec![(0.0, 5.0), (1.0, 5.0)],
        Style::Line,
    ));
    let texts = check_xml(&flat.to_svg(600, 400).unwrap());
    assert!(texts.iter().any(|t| t == "5.0"), "{texts:?}");
}

#[test]
fn write_chart_writes_svg_and_png_and_nothing_when_invalid() {
    let dir = std::env::temp_dir().join(format!("powertwin-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    write_chart(&energy_chart(), &dir, "energy", 640, 400).unwrap();
    let svg = std::fs::read_to_string(dir.join("energy.svg")).unwrap();
    check_xml(&svg);
    assert_eq!(
        decode(&std::fs::read(dir.join("energy.png")).unwrap()).0,
        640
    );
    let bad = Chart::new("bad", "x", "y");
    invalid(write_chart(&bad, &dir, "bad", 640, 400));
    assert!(!dir.join("bad.svg").exists() && !dir.join("bad.png").exists());
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(leftovers.len(), 2, "{leftovers:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// Any finite data, on any axis kind, renders to both formats without panicking.
    #[test]
    fn arbitrary_finite_data_renders(
        pts in prop::collection::vec((-1e9..1e9f64, -1e9..1e9f64), 1..30),
        scale in -12i32..12,
        log in any::<bool>(),
        dashed in any::<bool>(),
    ) {
        let k = 10f64.powi(scale);
        let pts: Vec<(f64, f64)> = pts.iter().map(|&(x, y)| (if log { x.abs() + 1e-3 } else { x } * k, y * k)).collect();
        let mut s = Series::new("s", pts.clone(), Style::LineMarkers);
        s.dashed = dashed;
        let axis = if log { XAxis::Log } else { XAxis::Linear };
        let c = Chart::new("p", "x", "y").with_x_axis(axis).with_series(s);
        check_xml(&c.to_svg(320, 240).unwrap());
        decode(&c.to_png(320, 240).unwrap());
        let ys: Vec<f64> = pts.iter().map(|p| p.1).collect();
        let bars = Chart::new("b", "c", "y")
            .with_x_axis(XAxis::Categories((0..ys.len()).map(|i| i.to_string()).collect()))
            .with_series(Series::bars("v", &ys));
        decode(&bars.to_png(320, 240).unwrap());
    }
}
