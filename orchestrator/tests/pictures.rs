//! The pictures `orchestrator` draws, end to end: heatmaps of small sweeps
//! that are readable, snapshots with legend, scale, robot numbers and the
//! potential contours, strips of moments, the animation, and the
//! trajectories in `simulate --json` that all of them are drawn from.

use std::path::Path;
use std::process::{Command, Output};

fn orchestrator(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_orchestrator")).args(args).output().expect("spawn orchestrator")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The value of attribute `name` in the markup of one element.
fn attr<'a>(element: &'a str, name: &str) -> Option<&'a str> {
    let key = format!(" {name}=\"");
    let start = element.find(&key)? + key.len();
    let len = element[start..].find('"')?;
    Some(&element[start..start + len])
}

fn num(element: &str, name: &str) -> f64 {
    attr(element, name).unwrap_or_else(|| panic!("no {name} in {element}")).parse().unwrap()
}

/// Every `<tag …>` start tag (up to its `>`) in `svg`.
fn elements<'a>(svg: &'a str, tag: &str) -> Vec<&'a str> {
    let open = format!("<{tag} ");
    svg.match_indices(&open).map(|(i, _)| &svg[i..i + svg[i..].find('>').unwrap()]).collect()
}

/// The markup of the group `<g id="id">…</g>`, nested groups included.
fn group<'a>(svg: &'a str, id: &str) -> &'a str {
    let start = svg.find(&format!("<g id=\"{id}\">")).unwrap_or_else(|| panic!("no group {id}"));
    let mut depth = 0;
    let mut at = start;
    loop {
        let rest = &svg[at..];
        let open = rest.find("<g ").unwrap_or(usize::MAX);
        let close = rest.find("</g>").expect("closed group");
        if open < close {
            depth += 1;
            at += open + 2;
        } else {
            depth -= 1;
            at += close + 4;
            if depth == 0 {
                return &svg[start..at];
            }
        }
    }
}

/// A text element: its box (x0, y0, x1, y1) and content. The width is
/// estimated at 0.6 em per character, an average sans-serif advance.
fn text_boxes(svg: &str) -> Vec<((f64, f64, f64, f64), String)> {
    svg.match_indices("<text ")
        .map(|(i, _)| {
            let rest = &svg[i..];
            let tag = &rest[..rest.find('>').unwrap()];
            let content = &rest[tag.len() + 1..rest.find("</text>").unwrap()];
            let (x, y, size) = (num(tag, "x"), num(tag, "y"), num(tag, "font-size"));
            let len = content.chars().count() as f64 * 0.6 * size;
            let (lo, hi) = match attr(tag, "text-anchor").unwrap_or("start") {
                "middle" => (-len / 2.0, len / 2.0),
                "end" => (-len, 0.0),
                _ => (0.0, len),
            };
            let rect = if tag.contains("rotate(-90") {
                // Rotated about (x, y): the text runs upwards from y.
                (x - size, y - hi, x + 0.25 * size, y - lo)
            } else {
                (x + lo, y - size, x + hi, y + 0.25 * size)
            };
            (rect, content.to_owned())
        })
        .collect()
}

fn viewbox(svg: &str) -> (f64, f64) {
    let svg_tag = elements(svg, "svg")[0];
    (num(svg_tag, "width"), num(svg_tag, "height"))
}

fn overlap(a: (f64, f64, f64, f64), b: (f64, f64, f64, f64)) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

#[test]
fn heatmaps_of_a_tiny_sweep_are_readable_with_colour_bar_and_run_counts() {
    let dir = tempfile::tempdir().unwrap();
    let o = orchestrator(&[
        "sweep",
        "--eps",
        "1",
        "--widths",
        "2",
        "--terrains-per-bin",
        "1",
        "--seed",
        "7",
        "--time-limit",
        "500",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    for noise in ["off", "on"] {
        let svg = std::fs::read_to_string(dir.path().join(format!("heatmap-noise-{noise}.svg"))).unwrap();
        let (w, h) = viewbox(&svg);
        let texts = text_boxes(&svg);
        for (b, t) in &texts {
            assert!(
                b.0 >= 0.0 && b.1 >= 0.0 && b.2 <= w && b.3 <= h,
                "{t:?} at {b:?} is cut by the {w}×{h} picture"
            );
        }
        let find = |needle: &str| {
            texts.iter().find(|(_, t)| t.contains(needle)).unwrap_or_else(|| panic!("no text {needle:?}")).0
        };
        let title = find(&format!("noise {noise}"));
        let y_label = texts.iter().find(|(_, t)| t == "minimum path width [cells]").expect("a y label").0;
        assert!(!overlap(title, y_label), "the y label {y_label:?} overlaps the title {title:?}");
        for (b, t) in &texts {
            if t != "minimum path width [cells]" {
                assert!(!overlap(*b, y_label), "the y label overlaps {t:?}");
            }
        }
        let bar = group(&svg, "colour-bar");
        assert!(elements(bar, "rect").len() >= 10 && bar.contains(">0 %<") && bar.contains(">100 %<"));
        assert!(svg.contains(">n=1<"), "the run count of a one-run cell is shown");
    }
}

/// `simulate --json` of the default scenario, and its snapshot.
fn simulate(dir: &Path, extra: &[&str]) -> (serde_json::Value, String, Output) {
    let svg = dir.join("snap.svg");
    let mut args = vec!["simulate", "--json", "--svg", svg.to_str().unwrap()];
    args.extend(extra);
    let o = orchestrator(&args);
    assert!(matches!(o.status.code(), Some(0) | Some(3)), "{}", stderr(&o));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
    (report, std::fs::read_to_string(svg).unwrap(), o)
}

fn point(v: &serde_json::Value) -> (f64, f64) {
    (v["x"].as_f64().unwrap(), v["y"].as_f64().unwrap())
}

#[test]
fn json_has_every_robots_trajectory() {
    let dir = tempfile::tempdir().unwrap();
    let (r, _, _) = simulate(dir.path(), &[]);
    let robots = r["robots"].as_array().unwrap();
    assert_eq!(robots.len() as u64, r["robots_used"].as_u64().unwrap());
    assert_eq!(r["dt_s"].as_f64(), Some(0.1));
    let mut total = 0;
    let mut stuck = Vec::new();
    for (k, robot) in robots.iter().enumerate() {
        assert_eq!(robot["id"].as_u64(), Some(k as u64 + 1));
        let steps = robot["steps"].as_u64().unwrap();
        let traj = robot["trajectory"].as_array().unwrap();
        assert_eq!(traj.len() as u64, steps + 1, "start point plus one position per period");
        assert_eq!(point(&traj[0]), point(&robots[0]["trajectory"][0]), "every robot starts at the start");
        assert_eq!(point(traj.last().unwrap()), point(&robot["position"]));
        if robot["end"] == "stuck" {
            stuck.push(point(&robot["position"]));
        }
        total += steps;
    }
    assert_eq!(total, r["steps"].as_u64().unwrap());
    let beacons: Vec<_> = r["beacons"].as_array().unwrap().iter().map(point).collect();
    assert_eq!(beacons, stuck);
}

/// World point → pixel, from the (first) arena frame in `svg`.
fn to_px(svg: &str, p: (f64, f64)) -> (f64, f64) {
    let frame =
        elements(svg, "rect").into_iter().find(|r| r.contains(r##"fill="none" stroke="#444""##)).unwrap();
    let (x0, y0, h) = (num(frame, "x"), num(frame, "y"), num(frame, "height"));
    (x0 + p.0 * 10.0, y0 + h - p.1 * 10.0)
}

#[test]
fn snapshot_has_legend_scale_bar_robot_numbers_and_true_contours() {
    let dir = tempfile::tempdir().unwrap();
    let (r, svg, _) = simulate(dir.path(), &["--scenario", "long-obstacle", "--eps", "3"]);
    let legend = group(&svg, "legend");
    for item in ["start", "goal", "robot (number: deployment order)", "stuck robot (beacon), ε circle"] {
        assert!(legend.contains(&format!(">{item}<")), "legend lacks {item}");
    }
    let scale = group(&svg, "scale-bar");
    assert!(scale.contains("20 cells"), "{scale}");
    let bar = elements(scale, "line")[0];
    assert_eq!(num(bar, "x2") - num(bar, "x1"), 200.0, "20 cells at 10 px per cell");
    let used = r["robots_used"].as_u64().unwrap();
    let numbers: Vec<&str> =
        svg.match_indices("class=\"robot-number\">").map(|(i, m)| &svg[i + m.len()..]).collect();
    assert_eq!(numbers.len() as u64, used);
    for (k, n) in numbers.iter().enumerate() {
        assert!(n.starts_with(&format!("{}<", k + 1)), "robot {} numbered", k + 1);
    }
    // The bold contour is where the beacons' field c Σ 1/d² equals g_th = 1/ε².
    let beacons: Vec<(f64, f64)> = r["beacons"].as_array().unwrap().iter().map(point).collect();
    assert!(!beacons.is_empty(), "long-obstacle leaves beacons");
    let contours = group(&svg, "potential-contours");
    let bold = elements(contours, "path").into_iter().find(|p| num(p, "data-level") == 1.0 / 9.0).unwrap();
    let d = attr(bold, "d").unwrap();
    let frame =
        elements(&svg, "rect").into_iter().find(|r| r.contains(r##"fill="none" stroke="#444""##)).unwrap();
    let (x0, y0, h) = (num(frame, "x"), num(frame, "y"), num(frame, "height"));
    let mut checked = 0;
    for pair in d.split(['M', 'L']).filter(|s| !s.is_empty()) {
        let (px, py) = pair.split_once(',').unwrap();
        let (x, y) =
            ((px.parse::<f64>().unwrap() - x0) / 10.0, (h - (py.parse::<f64>().unwrap() - y0)) / 10.0);
        let g: f64 = beacons.iter().map(|(bx, by)| 1.0 / ((x - bx).powi(2) + (y - by).powi(2))).sum();
        assert!((g * 9.0 - 1.0).abs() < 0.05, "g = {g} at ({x}, {y}), not 1/9");
        checked += 1;
    }
    assert!(checked > 50, "{checked} contour points");
}

#[test]
fn a_strip_of_moments_shows_each_time_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    // long-obstacle, ε = 3: robots of 206, 290 and 487 periods; robot 3 arrives at 98.3 s.
    let times = [10.0, 30.0, 60.0, 98.3];
    let (r, svg, _) =
        simulate(dir.path(), &["--scenario", "long-obstacle", "--eps", "3", "--snapshots", "10,30,60,98.3"]);
    let robots = r["robots"].as_array().unwrap();
    let mut firsts = Vec::new();
    let mut at = 0;
    for robot in robots {
        firsts.push(at);
        at += robot["steps"].as_u64().unwrap();
    }
    for (k, t) in times.iter().enumerate() {
        let moment = group(&svg, &format!("moment-{}", k + 1));
        assert!(moment.contains(&format!(">t = {t} s<")), "caption of moment {}", k + 1);
        let step = (t / 0.1_f64).round() as u64;
        let shown: Vec<usize> = (0..robots.len()).filter(|&i| firsts[i] <= step).collect();
        let markers: Vec<&str> =
            elements(moment, "circle").into_iter().filter(|c| attr(c, "r") == Some("3.50")).collect();
        assert_eq!(markers.len(), shown.len(), "robots deployed by {t} s");
        for (&i, marker) in shown.iter().zip(&markers) {
            let walked = (step - firsts[i]).min(robots[i]["steps"].as_u64().unwrap());
            let (x, y) = to_px(moment, point(&robots[i]["trajectory"][walked as usize]));
            assert!(
                (num(marker, "cx") - x).abs() < 0.01 && (num(marker, "cy") - y).abs() < 0.01,
                "robot {} at {t} s",
                i + 1
            );
        }
        let beacons = moment.matches("stroke-dasharray=\"4 3\"").count();
        let expected = (0..robots.len())
            .filter(|&i| {
                robots[i]["end"] == "stuck" && firsts[i] + robots[i]["steps"].as_u64().unwrap() <= step
            })
            .count();
        assert_eq!(beacons, expected, "ε circles of the robots stuck by {t} s");
    }
    // A moment after the end of the run: the result is printed, then the error.
    let late = dir.path().join("late.svg");
    let o = orchestrator(&[
        "simulate",
        "--scenario",
        "long-obstacle",
        "--eps",
        "3",
        "--snapshots",
        "10,500",
        "--svg",
        late.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stdout).contains("robot 3 arrived after 98.3 s"));
    assert!(stderr(&o).contains("--snapshots 500: the run ended at 98.3 s"), "{}", stderr(&o));
    assert!(!late.exists());
}

#[test]
fn the_animation_moves_each_robot_over_its_own_time() {
    let dir = tempfile::tempdir().unwrap();
    let movie = dir.path().join("movie.svg");
    let (r, _, o) = simulate(
        dir.path(),
        &[
            "--scenario",
            "long-obstacle",
            "--eps",
            "3",
            "--animate",
            movie.to_str().unwrap(),
            "--animate-seconds",
            "12",
        ],
    );
    assert!(stderr(&o).contains(&format!("animation: {}", movie.display())), "{}", stderr(&o));
    let svg = std::fs::read_to_string(&movie).unwrap();
    let motions = elements(&svg, "animateMotion");
    let robots = r["robots"].as_array().unwrap();
    assert_eq!(motions.len(), robots.len());
    let total = r["steps"].as_f64().unwrap();
    let mut first = 0.0;
    for (motion, robot) in motions.iter().zip(robots) {
        assert_eq!(attr(motion, "dur"), Some("12.000s"));
        assert_eq!(attr(motion, "repeatCount"), Some("indefinite"));
        let keys: Vec<f64> =
            attr(motion, "keyTimes").unwrap().split(';').map(|k| k.parse().unwrap()).collect();
        let last = first + robot["steps"].as_f64().unwrap();
        assert_eq!(keys.len(), 4);
        assert!((keys[1] - first / total).abs() < 1e-5 && (keys[2] - last / total).abs() < 1e-5, "{keys:?}");
        assert!(keys.windows(2).all(|w| w[0] <= w[1]) && keys[0] == 0.0 && keys[3] == 1.0);
        first = last;
    }
    // The threshold contour appears once per beacon.
    let beacons = r["beacons"].as_array().unwrap().len();
    assert_eq!(elements(group(&svg, "potential-contours"), "path").len(), beacons);
}

#[test]
fn the_summary_the_launch_picture_and_the_recordings_picture_give_one_run_time() {
    // The default launch (lockstep, long-obstacle, 3 robots: two get stuck
    // and stand still for the gate's dwell, the third arrives).
    let dir = tempfile::tempdir().unwrap();
    let (rec, launch_svg, draw_svg) =
        (dir.path().join("run.mcap"), dir.path().join("launch.svg"), dir.path().join("draw.svg"));
    let swarm = format!("onetime{}", std::process::id());
    let o = orchestrator(&[
        "launch",
        "--swarm",
        &swarm,
        "--json",
        "--record",
        rec.to_str().unwrap(),
        "--svg",
        launch_svg.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON summary");
    let o = orchestrator(&["draw", rec.to_str().unwrap(), "--out", draw_svg.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let arrived = summary["robots"].as_array().unwrap().iter().find(|r| r["end"] == "arrived").unwrap();
    let time = summary["time_s"].as_f64().unwrap();
    assert!(summary["ticks"].as_u64().unwrap() as f64 * 0.1 > time + 2.0, "the dwell is not run time");
    let verdict = format!("robot {} arrived after {time:.1} s (2 beacons)", arrived["id"]);
    for svg in [&launch_svg, &draw_svg] {
        let text = std::fs::read_to_string(svg).unwrap();
        let titles: Vec<String> = text_boxes(&text).into_iter().map(|(_, t)| t).collect();
        assert!(titles.contains(&verdict), "{} says {titles:?}, the summary {verdict:?}", svg.display());
    }
}

/// Relative luminance (0 black … 1 white) of a `#rrggbb` colour.
fn luminance(hex: &str) -> f64 {
    let c = |i: usize| f64::from(u8::from_str_radix(&hex[i..i + 2], 16).unwrap()) / 255.0;
    0.2126 * c(1) + 0.7152 * c(3) + 0.0722 * c(5)
}

#[test]
fn walls_read_as_walls_and_no_robot_number_covers_the_goal() {
    let dir = tempfile::tempdir().unwrap();
    let (_, svg, _) = simulate(dir.path(), &[]);
    // The impassable cells: solid and dark enough to stand out under the contours.
    let legend = group(&svg, "legend");
    let wall = elements(legend, "rect").into_iter().next().expect("legend swatch of the wall");
    let fill = attr(wall, "fill").unwrap();
    assert!(luminance(fill) < 0.45, "wall colour {fill} is too pale");
    // The goal star (the polygon filled gold) and the robot numbers.
    let star = elements(&svg, "polygon").into_iter().find(|p| p.contains("#ffd700")).unwrap();
    let xs: Vec<(f64, f64)> = attr(star, "points")
        .unwrap()
        .split(' ')
        .map(|p| {
            let (x, y) = p.split_once(',').unwrap();
            (x.parse().unwrap(), y.parse().unwrap())
        })
        .collect();
    let bbox = xs.iter().fold((f64::MAX, f64::MAX, f64::MIN, f64::MIN), |b, &(x, y)| {
        (b.0.min(x), b.1.min(y), b.2.max(x), b.3.max(y))
    });
    let numbers: Vec<_> = text_boxes(&svg).into_iter().filter(|(_, t)| t.parse::<u32>().is_ok()).collect();
    assert!(!numbers.is_empty());
    for (rect, n) in numbers {
        assert!(!overlap(rect, bbox), "robot number {n} at {rect:?} covers the goal star {bbox:?}");
    }
}
