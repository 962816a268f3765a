//! The robot-budget plot: success rate against the robot budget N, one line
//! per ε (see `crate::sweep::budget`). The budgets are spaced evenly (1, 2,
//! 3, 5, 10, 20, 50, ∞ are roughly logarithmic already); an unknown point
//! (beyond the sweep's robot cap) breaks the line instead of being drawn.

use super::svg::{number, text_width, Svg};

const PAD: f64 = 12.0;
const TITLE: f64 = 15.0;
const SUBTITLE: f64 = 12.0;
const TICK: f64 = 12.0;
const AXIS: f64 = 13.0;
const STEP: f64 = 56.0;
const PLOT_H: f64 = 240.0;
const PALETTE: &[&str] =
    &["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf", "#7f7f7f"];
const X_AXIS_TITLE: &str = "robot budget N (robots deployed at most)";
const Y_AXIS_TITLE: &str = "success [%]";

/// `curves[e][k]`: success rate (0–1) of radius `eps[e]` within budget `budgets[k]`.
pub struct BudgetPlot<'a> {
    pub title: &'a str,
    pub subtitle: &'a str,
    pub budgets: &'a [String],
    pub eps: &'a [f64],
    pub curves: &'a [Vec<Option<f64>>],
}

pub fn render(p: &BudgetPlot) -> String {
    let left = PAD + AXIS + 8.0 + text_width("100", TICK) + 8.0;
    let top = PAD + TITLE + 6.0 + SUBTITLE + 18.0;
    let plot_w = STEP * p.budgets.len().max(1) as f64;
    let legend_x = left + plot_w + 24.0;
    let legend_w =
        p.eps.iter().map(|e| text_width(&format!("ε = {}", number(*e)), TICK)).fold(0.0, f64::max) + 30.0;
    let x_title_w = text_width(X_AXIS_TITLE, AXIS);
    let x_centre = (left + plot_w / 2.0).max(PAD + x_title_w / 2.0);
    let right = [
        legend_x + legend_w,
        PAD + text_width(p.title, TITLE),
        PAD + text_width(p.subtitle, SUBTITLE),
        x_centre + x_title_w / 2.0,
    ]
    .into_iter()
    .fold(0.0, f64::max);
    let legend_h = 20.0 * p.eps.len() as f64;
    let plot_h = PLOT_H.max(legend_h);
    let mut svg = Svg::new((right + PAD).ceil(), (top + plot_h + 50.0 + PAD).ceil());
    svg.text(PAD, PAD + TITLE, TITLE, "start", p.title);
    svg.text_coloured(PAD, PAD + TITLE + 6.0 + SUBTITLE, SUBTITLE, "start", "#444", p.subtitle);
    let x_of = |k: usize| left + STEP * (k as f64 + 0.5);
    let y_of = |rate: f64| top + plot_h * (1.0 - rate);
    for pct in [0, 25, 50, 75, 100] {
        let y = y_of(f64::from(pct) / 100.0);
        svg.line(left, y, left + plot_w, y, r##"stroke="#ddd" stroke-width="1""##);
        svg.text(left - 6.0, y + 4.0, TICK, "end", &pct.to_string());
    }
    svg.rect(left, top, plot_w, plot_h, r##"fill="none" stroke="#444" stroke-width="1""##);
    for (k, label) in p.budgets.iter().enumerate() {
        svg.text(x_of(k), top + plot_h + 18.0, TICK, "middle", label);
    }
    svg.text(x_centre, top + plot_h + 42.0, AXIS, "middle", X_AXIS_TITLE);
    svg.vtext(PAD + AXIS, top + plot_h / 2.0, AXIS, Y_AXIS_TITLE);
    svg.open_group("curves");
    for (e, curve) in p.curves.iter().enumerate() {
        let colour = PALETTE[e % PALETTE.len()];
        // Unknown points split the line into runs of known ones.
        for run in curve.iter().enumerate().collect::<Vec<_>>().split(|(_, r)| r.is_none()) {
            let pts: Vec<(f64, f64)> =
                run.iter().filter_map(|&(k, r)| r.map(|r| (x_of(k), y_of(r)))).collect();
            if pts.len() > 1 {
                svg.polyline(pts.iter().copied(), &format!(r#"stroke="{colour}" stroke-width="2""#));
            }
            for (x, y) in pts {
                svg.circle(x, y, 3.0, &format!(r#"fill="{colour}""#));
            }
        }
    }
    svg.close_group();
    svg.open_group("legend");
    for (e, eps) in p.eps.iter().enumerate() {
        let colour = PALETTE[e % PALETTE.len()];
        let y = top + 10.0 + 20.0 * e as f64;
        svg.line(legend_x, y, legend_x + 20.0, y, &format!(r#"stroke="{colour}" stroke-width="2""#));
        svg.text(legend_x + 26.0, y + 4.0, TICK, "start", &format!("ε = {}", number(*eps)));
    }
    svg.close_group();
    svg.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_per_eps_and_unknown_points_break_it() {
        let budgets: Vec<String> = ["1", "2", "∞"].map(String::from).to_vec();
        let curves = vec![vec![Some(0.0), Some(0.5), Some(1.0)], vec![Some(0.2), Some(0.4), None]];
        let svg = render(&BudgetPlot {
            title: "t",
            subtitle: "s",
            budgets: &budgets,
            eps: &[1.0, 2.5],
            curves: &curves,
        });
        assert_eq!(svg.matches("<polyline").count(), 2);
        assert_eq!(svg.matches(r#"<circle"#).count(), 5, "five known points");
        assert!(svg.contains(">ε = 2.5<") && svg.contains(">∞<"));
    }
}
