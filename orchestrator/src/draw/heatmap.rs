//! The success-rate heatmap of the paper's `fig:result_width` and
//! `fig:result_width_noise`: circumferential radius ε across, minimum path
//! width up, each cell the percentage of terrains where a robot arrived.

use super::svg::Svg;

const CELL: f64 = 56.0;
const LEFT: f64 = 80.0;
const TOP: f64 = 40.0;
const BOTTOM: f64 = 60.0;
const RIGHT: f64 = 20.0;

/// One heatmap: `rates[row][col]` is the success rate (0–1) for width bin
/// `widths[row]` and radius `eps[col]`, `None` where there were no runs.
pub struct Heatmap<'a> {
    pub title: &'a str,
    pub eps: &'a [f64],
    pub widths: &'a [f64],
    pub rates: &'a [Vec<Option<f64>>],
}

/// White (0 %) to deep blue (100 %).
fn colour(rate: f64) -> String {
    let t = rate.clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    format!("#{:02x}{:02x}{:02x}", lerp(255.0, 8.0), lerp(255.0, 48.0), lerp(255.0, 107.0))
}

pub fn render(h: &Heatmap) -> String {
    let (cols, rows) = (h.eps.len() as f64, h.widths.len() as f64);
    let mut svg = Svg::new(LEFT + cols * CELL + RIGHT, TOP + rows * CELL + BOTTOM);
    svg.text(LEFT + cols * CELL / 2.0, 24.0, 15.0, "middle", h.title);
    for (r, row) in h.rates.iter().enumerate() {
        // Widest paths at the top, as in the paper.
        let y = TOP + (rows - 1.0 - r as f64) * CELL;
        for (c, rate) in row.iter().enumerate() {
            let x = LEFT + c as f64 * CELL;
            match rate {
                Some(rate) => {
                    svg.rect(x, y, CELL, CELL, &format!(r##"fill="{}" stroke="#fff""##, colour(*rate)));
                    let label = format!("{:.0}", rate * 100.0);
                    let ink = if *rate > 0.55 { "white" } else { "black" };
                    svg.text_coloured(x + CELL / 2.0, y + CELL / 2.0 + 5.0, 14.0, "middle", ink, &label);
                }
                None => svg.rect(x, y, CELL, CELL, r##"fill="#eee" stroke="#fff""##),
            }
        }
        svg.text(LEFT - 8.0, y + CELL / 2.0 + 5.0, 13.0, "end", &format!("{}", h.widths[r]));
    }
    for (c, eps) in h.eps.iter().enumerate() {
        let x = LEFT + c as f64 * CELL + CELL / 2.0;
        svg.text(x, TOP + rows * CELL + 20.0, 13.0, "middle", &format!("{eps}"));
    }
    svg.text(
        LEFT + cols * CELL / 2.0,
        TOP + rows * CELL + 45.0,
        14.0,
        "middle",
        "circumferential radius ε [cells]",
    );
    svg.vtext(24.0, TOP + rows * CELL / 2.0, 14.0, "minimum path width [cells]");
    svg.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_runs_from_white_to_blue() {
        assert_eq!(colour(0.0), "#ffffff");
        assert_eq!(colour(1.0), "#08306b");
    }

    #[test]
    fn renders_every_cell_with_its_percentage() {
        let rates = vec![vec![Some(1.0), Some(0.25)], vec![None, Some(0.5)]];
        let svg = render(&Heatmap { title: "t", eps: &[1.0, 2.0], widths: &[1.0, 1.5], rates: &rates });
        assert!(svg.contains(">100<") && svg.contains(">25<") && svg.contains(">50<"));
        assert_eq!(svg.matches("<rect").count(), 1 + 4, "background and four cells");
        assert!(svg.contains(r#"fill="white">100<"#), "dark cells get white labels");
    }
}
