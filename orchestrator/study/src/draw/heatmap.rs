//! The success-rate heatmap of the paper's `fig:result_width` and
//! `fig:result_width_noise`: circumferential radius ε across, minimum path
//! width up, each cell the percentage of terrains where a robot arrived.
//!
//! The layout is computed from the text it has to hold, not fixed: a sweep
//! of two radii and one width bin gets a picture wide enough for its title
//! and axis titles, and the vertical axis title never reaches the title
//! above. Every cell also shows its number of runs (a cell of one run must
//! not look like a cell of a hundred), and a colour bar gives the scale.

use super::svg::{number, text_width, Svg};

const CELL: f64 = 56.0;
const PAD: f64 = 12.0;
const TITLE: f64 = 15.0;
const SUBTITLE: f64 = 12.0;
const TICK: f64 = 13.0;
const AXIS: f64 = 14.0;
const BAR_WIDTH: f64 = 14.0;
const BAR_STEPS: usize = 20;
const X_AXIS_TITLE: &str = "circumferential radius ε [cells]";
const Y_AXIS_TITLE: &str = "minimum path width [cells]";

/// One heatmap: `cells[row][col]` is (successes, runs) for width bin
/// `widths[row]` and radius `eps[col]`.
pub struct Heatmap<'a> {
    pub title: &'a str,
    pub subtitle: &'a str,
    pub eps: &'a [f64],
    pub widths: &'a [f64],
    pub cells: &'a [Vec<(usize, usize)>],
}

/// White (0 %) to deep blue (100 %).
pub fn colour(rate: f64) -> String {
    let t = rate.clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    format!("#{:02x}{:02x}{:02x}", lerp(255.0, 8.0), lerp(255.0, 48.0), lerp(255.0, 107.0))
}

/// Where things go, from the sizes of the texts.
struct Layout {
    left: f64,
    plot_top: f64,
    region_top: f64,
    region_h: f64,
    width: f64,
    height: f64,
}

fn layout(h: &Heatmap) -> Layout {
    let (cols, rows) = (h.eps.len() as f64, h.widths.len() as f64);
    let tick_w = h.widths.iter().map(|w| text_width(&number(*w), TICK)).fold(0.0, f64::max);
    // Vertical axis title (rotated) in the first column, then the tick labels.
    let left = PAD + AXIS + 8.0 + tick_w + 8.0;
    let region_top = PAD + TITLE + 6.0 + SUBTITLE + 14.0;
    let plot_h = rows * CELL;
    // The rotated axis title is as tall as it is long: the plot's region is
    // at least that tall, so it never reaches the title lines above.
    let region_h = plot_h.max(text_width(Y_AXIS_TITLE, AXIS) + 12.0);
    // The plot sits at the bottom of its region, above its tick labels.
    let plot_top = region_top + region_h - plot_h;
    let plot_w = cols * CELL;
    let bar_right = left + plot_w + 20.0 + BAR_WIDTH + 6.0 + text_width("100 %", 11.0);
    let x_title_w = text_width(X_AXIS_TITLE, AXIS);
    let right = [
        bar_right,
        PAD + text_width(h.title, TITLE),
        PAD + text_width(h.subtitle, SUBTITLE),
        x_centre(left, plot_w, x_title_w) + x_title_w / 2.0,
    ]
    .into_iter()
    .fold(0.0, f64::max);
    Layout {
        left,
        plot_top,
        region_top,
        region_h,
        width: right + PAD,
        height: region_top + region_h + 52.0 + PAD,
    }
}

/// Centre of the horizontal axis title: under the plot, but never cut at the left.
fn x_centre(left: f64, plot_w: f64, title_w: f64) -> f64 {
    (left + plot_w / 2.0).max(PAD + title_w / 2.0)
}

pub fn render(h: &Heatmap) -> String {
    let l = layout(h);
    let (cols, rows) = (h.eps.len() as f64, h.widths.len() as f64);
    let (plot_w, plot_h) = (cols * CELL, rows * CELL);
    let mut svg = Svg::new(l.width.ceil(), l.height.ceil());
    svg.text(PAD, PAD + TITLE, TITLE, "start", h.title);
    svg.text_coloured(PAD, PAD + TITLE + 6.0 + SUBTITLE, SUBTITLE, "start", "#444", h.subtitle);
    for (r, row) in h.cells.iter().enumerate() {
        // Widest paths at the top, as in the paper.
        let y = l.plot_top + (rows - 1.0 - r as f64) * CELL;
        for (c, &(successes, runs)) in row.iter().enumerate() {
            let x = l.left + c as f64 * CELL;
            if runs == 0 {
                svg.rect(x, y, CELL, CELL, r##"fill="#eee" stroke="#bbb" stroke-width="0.5""##);
                svg.text_coloured(x + CELL / 2.0, y + CELL / 2.0 + 5.0, 14.0, "middle", "#888", "–");
                continue;
            }
            let rate = successes as f64 / runs as f64;
            svg.rect(
                x,
                y,
                CELL,
                CELL,
                &format!(r##"fill="{}" stroke="#bbb" stroke-width="0.5""##, colour(rate)),
            );
            let ink = if rate > 0.55 { "white" } else { "black" };
            let label = format!("{:.0}", rate * 100.0);
            svg.text_coloured(x + CELL / 2.0, y + CELL / 2.0 + 2.0, 14.0, "middle", ink, &label);
            svg.text_coloured(x + CELL / 2.0, y + CELL - 8.0, 10.0, "middle", ink, &format!("n={runs}"));
        }
        svg.text(l.left - 8.0, y + CELL / 2.0 + 5.0, TICK, "end", &number(h.widths[r]));
    }
    for (c, eps) in h.eps.iter().enumerate() {
        let x = l.left + c as f64 * CELL + CELL / 2.0;
        svg.text(x, l.plot_top + plot_h + 20.0, TICK, "middle", &number(*eps));
    }
    let x_title = x_centre(l.left, plot_w, text_width(X_AXIS_TITLE, AXIS));
    svg.text(x_title, l.region_top + l.region_h + 45.0, AXIS, "middle", X_AXIS_TITLE);
    svg.vtext(PAD + AXIS, l.region_top + l.region_h / 2.0, AXIS, Y_AXIS_TITLE);
    colour_bar(&mut svg, l.left + plot_w + 20.0, l.region_top, l.region_h);
    svg.finish()
}

/// A vertical scale from 0 % (bottom) to 100 % (top), in steps.
fn colour_bar(svg: &mut Svg, x: f64, top: f64, height: f64) {
    svg.open_group("colour-bar");
    let step = height / BAR_STEPS as f64;
    for i in 0..BAR_STEPS {
        let rate = (i as f64 + 0.5) / BAR_STEPS as f64;
        let y = top + height - (i + 1) as f64 * step;
        // Overlap by a hair so no seams show between steps.
        svg.rect(x, y, BAR_WIDTH, step + 0.5, &format!(r#"fill="{}""#, colour(rate)));
    }
    svg.rect(x, top, BAR_WIDTH, height, r##"fill="none" stroke="#444" stroke-width="0.5""##);
    for (rate, label) in [(0.0, "0 %"), (0.5, "50 %"), (1.0, "100 %")] {
        let y = top + height * (1.0 - rate);
        svg.line(x + BAR_WIDTH, y, x + BAR_WIDTH + 3.0, y, r##"stroke="#444""##);
        svg.text(x + BAR_WIDTH + 6.0, y + 4.0, 11.0, "start", label);
    }
    svg.close_group();
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
    fn renders_every_cell_with_its_percentage_and_runs() {
        let cells = vec![vec![(1, 1), (25, 100)], vec![(0, 0), (1, 2)]];
        let svg = render(&Heatmap {
            title: "t",
            subtitle: "s",
            eps: &[1.0, 2.0],
            widths: &[1.0, 1.5],
            cells: &cells,
        });
        assert!(svg.contains(">100<") && svg.contains(">25<") && svg.contains(">50<"));
        assert!(svg.contains(">n=1<") && svg.contains(">n=100<") && svg.contains(">n=2<"));
        assert!(svg.contains(r#"fill="white">100<"#), "dark cells get white labels");
        assert!(svg.contains(r#"<g id="colour-bar">"#));
    }

    #[test]
    fn a_one_cell_map_is_wide_enough_for_its_titles() {
        let title = "Success rate [%], noise off";
        let h = Heatmap { title, subtitle: "", eps: &[1.0], widths: &[2.0], cells: &[vec![(1, 1)]] };
        let l = layout(&h);
        assert!(l.width >= PAD + text_width(X_AXIS_TITLE, AXIS) + PAD);
        assert!(l.region_h >= text_width(Y_AXIS_TITLE, AXIS));
    }
}
