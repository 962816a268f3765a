use super::text_with;
use crate::terrain::format::ParseErrorKind;
use crate::terrain::{generate, parse, to_text, GenParams, Terrain};
use crate::Vec2;

fn kind(text: &str) -> (usize, usize, ParseErrorKind) {
    let e = parse(text).expect_err("should not parse");
    (e.line, e.column, e.kind)
}

#[test]
fn first_line_is_the_highest_row() {
    let t = parse(&text_with(60, 60, &[(1, 1, '#')])).unwrap();
    assert!(t.cell_blocked(0, 59));
    assert_eq!(t.blocked_count(), 1);
    assert_eq!(t.start(), Vec2::new(15.5, 15.5));
    assert_eq!(t.goal(), Vec2::new(44.5, 44.5));
}

#[test]
fn start_and_goal_letters_give_cell_centres() {
    let t = parse("..G\n#..\nS..\n").unwrap();
    assert_eq!(t.start(), Vec2::new(0.5, 0.5));
    assert_eq!(t.goal(), Vec2::new(2.5, 2.5));
    assert!(t.cell_blocked(0, 1));
    assert!(!t.cell_blocked(0, 0) && !t.cell_blocked(2, 2));
}

#[test]
fn crlf_and_missing_final_newline_are_fine() {
    let a = parse("S.\r\n.G\r\n").unwrap();
    let b = parse("S.\n.G").unwrap();
    assert_eq!(a, b);
    assert_eq!(a.start(), Vec2::new(0.5, 1.5));
}

#[test]
fn round_trip_is_exact() {
    let mut t = Terrain::paper();
    t.set_blocked(3, 7, true);
    t.set_blocked(59, 59, true);
    t.set_start(Vec2::new(0.5, 0.5));
    let text = to_text(&t);
    assert_eq!(parse(&text).unwrap(), t);
    assert_eq!(text.lines().count(), 60);
    assert!(text.lines().next().unwrap().ends_with('#'));
    for seed in 0..20 {
        let g = generate(seed, &GenParams::default());
        assert_eq!(parse(&to_text(&g.terrain)).unwrap(), g.terrain, "seed {seed}");
    }
    let default = Terrain::paper();
    assert_eq!(to_text(&default).matches('S').count(), 1);
    assert_eq!(to_text(&default).matches('G').count(), 1);
}

#[test]
fn from_str_is_parse() {
    let t: Terrain = "S.\n.G\n".parse().unwrap();
    assert_eq!(t, parse("S.\n.G\n").unwrap());
}

#[test]
fn empty() {
    for text in ["", "\n", "\r\n", "\n\n\r\n"] {
        assert_eq!(kind(text), (1, 1, ParseErrorKind::Empty), "{text:?}");
    }
}

#[test]
fn a_leading_blank_line_is_named_not_called_empty() {
    for text in ["\nS.\n.G\n", "\r\nS.\r\n.G\r\n", "\n\nS.\n.G"] {
        assert_eq!(kind(text), (1, 1, ParseErrorKind::FirstLineBlank), "{text:?}");
    }
    let e = parse("\nS.\n.G\n").unwrap_err();
    assert_eq!(
        e.to_string(),
        "line 1, column 1: the first line is blank (a terrain's rows start on line 1, with no blank line before)"
    );
}

#[test]
fn ragged_names_the_lines() {
    let mut text = text_with(60, 60, &[]);
    // Drop one cell from line 4.
    let start_of_line4 = 3 * 61;
    text.remove(start_of_line4);
    let e = parse(&text).unwrap_err();
    assert_eq!((e.line, e.column), (4, 60));
    assert_eq!(e.kind, ParseErrorKind::Ragged { line: 4, cells: 59, expected: 60 });
    assert_eq!(e.to_string(), "line 4, column 60: line 4 has 59 cells, line 1 has 60");
    let long = kind("S..\n....\n..G\n");
    assert_eq!(long, (2, 4, ParseErrorKind::Ragged { line: 2, cells: 4, expected: 3 }));
}

#[test]
fn unknown_character_has_line_and_column() {
    let e = parse(&text_with(10, 5, &[(3, 7, 'x')])).unwrap_err();
    assert_eq!((e.line, e.column, e.kind.clone()), (3, 7, ParseErrorKind::UnknownChar('x')));
    assert_eq!(e.to_string(), "line 3, column 7: unknown character 'x' (expected '#', '.', 'S' or 'G')");
    assert_eq!(kind("S.é\n..G\n").0, 1);
    assert_eq!(kind("S.é\n..G\n").1, 3);
}

#[test]
fn two_starts_or_goals_name_the_second() {
    let e = parse(&text_with(8, 8, &[(2, 3, 'S'), (5, 6, 'S')])).unwrap_err();
    assert_eq!((e.line, e.column), (5, 6));
    assert_eq!(e.kind, ParseErrorKind::SecondStart { first: (2, 3) });
    assert!(e.to_string().contains("second start"), "{e}");
    let e = parse(&text_with(8, 8, &[(7, 1, 'G'), (8, 8, 'G')])).unwrap_err();
    assert_eq!((e.line, e.column), (8, 8));
    assert_eq!(e.kind, ParseErrorKind::SecondGoal { first: (7, 1) });
}

#[test]
fn default_start_or_goal_on_an_impassable_cell() {
    // 60 × 60: default start cell (15, 15) is line 45, column 16;
    // default goal cell (44, 44) is line 16, column 45.
    let (l, c, k) = kind(&text_with(60, 60, &[(45, 16, '#')]));
    assert_eq!((l, c, k), (45, 16, ParseErrorKind::StartBlocked));
    let (l, c, k) = kind(&text_with(60, 60, &[(16, 45, '#')]));
    assert_eq!((l, c, k), (16, 45, ParseErrorKind::GoalBlocked));
    // With explicit letters the default cells may be impassable.
    let t = parse(&text_with(60, 60, &[(45, 16, '#'), (16, 45, '#'), (1, 1, 'S'), (60, 60, 'G')]));
    assert!(t.is_ok());
}

#[test]
fn start_equal_to_goal() {
    // 1 × 1: both defaults are cell (0, 0).
    assert_eq!(kind(".\n"), (1, 1, ParseErrorKind::StartIsGoal));
    // An explicit start on the default goal cell.
    assert_eq!(kind(&text_with(60, 60, &[(16, 45, 'S')])), (16, 45, ParseErrorKind::StartIsGoal));
}

#[test]
fn byte_order_mark_and_trailing_blank_lines_are_accepted() {
    let plain = parse("S.\n.G\n").unwrap();
    for text in ["\u{feff}S.\n.G\n", "S.\n.G\n\n", "S.\r\n.G\r\n\r\n\r\n", "\u{feff}S.\n.G\n\n\n"] {
        assert_eq!(parse(text).unwrap(), plain, "{text:?}");
    }
    // A blank line between rows is still an error, and so is a BOM anywhere else.
    assert!(matches!(kind("S.\n\n.G\n").2, ParseErrorKind::Ragged { line: 2, cells: 0, .. }));
    assert_eq!(kind("S.\n\u{feff}.G\n").2, ParseErrorKind::UnknownChar('\u{feff}'));
}

#[test]
fn grids_beyond_the_side_limit_are_refused() {
    use crate::terrain::MAX_SIDE;
    let wide = "S".to_string() + &".".repeat(MAX_SIDE) + "G\n";
    assert_eq!(kind(&wide), (1, MAX_SIDE + 1, ParseErrorKind::TooWide));
    let tall = "S.\n".to_string() + &"..\n".repeat(MAX_SIDE - 1) + ".G\n";
    assert_eq!(kind(&tall), (MAX_SIDE + 1, 1, ParseErrorKind::TooTall { rows: MAX_SIDE + 1 }));
    let at_limit = text_with(MAX_SIDE, MAX_SIDE, &[]);
    assert_eq!(parse(&at_limit).unwrap().width(), MAX_SIDE);
}

#[test]
fn lines_ended_by_a_carriage_return_alone_are_refused_saying_so() {
    // A wide one used to be "more than the limit of 1000 cells across".
    let row = ".".repeat(600);
    let wide = format!("S{row}\r{row}G\r");
    for text in ["S.\r.G\r", "S.\r.G", wide.as_str()] {
        let e = parse(text).unwrap_err();
        assert_eq!(e.kind, ParseErrorKind::CrOnly, "{text:?}");
        assert!(e.to_string().contains("carriage return (CR) alone"), "{e}");
        assert_eq!(e.line, 1);
    }
    assert_eq!(kind("S.\r.G").1, 3, "the column of the first CR");
}
