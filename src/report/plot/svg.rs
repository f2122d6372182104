//! The SVG back end: primitives as SVG elements, and the options `resvg` renders them with.

use std::fmt::Write as _;
use std::sync::{Arc, OnceLock};

use resvg::usvg;

use super::layout::Prim;
use super::{FONT, FONT_FAMILY, INK, Rgba};

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

pub(super) fn svg_prim(s: &mut String, p: &Prim) {
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
pub(super) fn svg_options() -> &'static usvg::Options<'static> {
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
