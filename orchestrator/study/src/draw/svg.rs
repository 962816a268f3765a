//! A minimal SVG writer: just what the snapshots, heatmaps and plots need.

use std::fmt::Write;

/// An SVG document being written.
pub struct Svg {
    body: String,
    width: f64,
    height: f64,
}

/// Estimated width of `text` at font size `size` in a sans-serif font: 0.62
/// em per character, a little above the average of common sans fonts, so
/// layouts that reserve this much room do not clip labels.
pub fn text_width(text: &str, size: f64) -> f64 {
    text.chars().count() as f64 * 0.62 * size
}

/// A number for a label: at most three decimals, no trailing zeros
/// (so ε = 1.9000000000000001 reads "1.9").
pub fn number(x: f64) -> String {
    let s = format!("{x:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_owned()
    } else {
        s.to_owned()
    }
}

/// Escapes text for SVG content and attribute values.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

impl Svg {
    pub fn new(width: f64, height: f64) -> Self {
        Self { body: String::new(), width, height }
    }

    pub fn rect(&mut self, x: f64, y: f64, w: f64, h: f64, style: &str) {
        let _ =
            writeln!(self.body, r#"<rect x="{x:.2}" y="{y:.2}" width="{w:.2}" height="{h:.2}" {style}/>"#);
    }

    pub fn circle(&mut self, cx: f64, cy: f64, r: f64, style: &str) {
        let _ = writeln!(self.body, r#"<circle cx="{cx:.2}" cy="{cy:.2}" r="{r:.2}" {style}/>"#);
    }

    pub fn line(&mut self, x1: f64, y1: f64, x2: f64, y2: f64, style: &str) {
        let _ = writeln!(self.body, r#"<line x1="{x1:.2}" y1="{y1:.2}" x2="{x2:.2}" y2="{y2:.2}" {style}/>"#);
    }

    pub fn polyline(&mut self, points: impl IntoIterator<Item = (f64, f64)>, style: &str) {
        let mut pts = String::new();
        for (x, y) in points {
            let _ = write!(pts, "{x:.2},{y:.2} ");
        }
        let _ = writeln!(self.body, r#"<polyline points="{}" fill="none" {style}/>"#, pts.trim_end());
    }

    pub fn polygon(&mut self, points: impl IntoIterator<Item = (f64, f64)>, style: &str) {
        let mut pts = String::new();
        for (x, y) in points {
            let _ = write!(pts, "{x:.2},{y:.2} ");
        }
        let _ = writeln!(self.body, r#"<polygon points="{}" {style}/>"#, pts.trim_end());
    }

    /// Text anchored at (x, y); `anchor` is start, middle or end.
    pub fn text(&mut self, x: f64, y: f64, size: f64, anchor: &str, text: &str) {
        self.text_coloured(x, y, size, anchor, "black", text);
    }

    /// Text in the given fill colour.
    pub fn text_coloured(&mut self, x: f64, y: f64, size: f64, anchor: &str, fill: &str, text: &str) {
        let _ = writeln!(
            self.body,
            r#"<text x="{x:.2}" y="{y:.2}" font-family="sans-serif" font-size="{size}" text-anchor="{anchor}" fill="{fill}">{}</text>"#,
            escape(text)
        );
    }

    /// Text rotated by −90° (for a vertical axis label).
    pub fn vtext(&mut self, x: f64, y: f64, size: f64, text: &str) {
        let _ = writeln!(
            self.body,
            r#"<text x="{x:.2}" y="{y:.2}" font-family="sans-serif" font-size="{size}" text-anchor="middle" transform="rotate(-90 {x:.2} {y:.2})">{}</text>"#,
            escape(text)
        );
    }

    /// Opens a group `<g id="…">` (close it with [`Svg::close_group`]), so
    /// a reader or a test can find a part of the picture by name.
    pub fn open_group(&mut self, id: &str) {
        let _ = writeln!(self.body, r#"<g id="{}">"#, escape(id));
    }

    pub fn close_group(&mut self) {
        self.body.push_str("</g>\n");
    }

    /// Appends raw SVG markup (for elements this writer has no method for).
    pub fn raw(&mut self, markup: &str) {
        self.body.push_str(markup);
        if !markup.ends_with('\n') {
            self.body.push('\n');
        }
    }

    pub fn finish(self) -> String {
        format!(
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n{}</svg>\n",
            self.body,
            w = self.width,
            h = self.height
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_text_and_closes_document() {
        let mut s = Svg::new(10.0, 20.0);
        s.text(1.0, 2.0, 12.0, "start", "a<b & \"c\"");
        let out = s.finish();
        assert!(out.starts_with("<svg "));
        assert!(out.contains("a&lt;b &amp; &quot;c&quot;"));
        assert!(out.trim_end().ends_with("</svg>"));
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(number(1.9000000000000001), "1.9");
        assert_eq!(number(2.0), "2");
        assert_eq!(number(0.125), "0.125");
        assert_eq!(number(-0.0001), "0");
    }
}
