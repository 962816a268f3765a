//! Numbers and foreign text in the words a terminal shows, written once.
//!
//! Why here: the doctor of every host (this crate), the launch and the
//! study all count things in sentences ("1 robot", "3 robots"), print
//! signed figures, and show text someone else typed (`stop --why`, which a
//! foreign client may send as anything). Always built, with no
//! dependencies, like [`crate::stats`].

/// `n` and the noun, singular or plural: "1 robot", "3 robots".
pub fn count(n: u64, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// `value` with a sign and `decimals` decimals, a value that rounds to
/// zero shown as `+0.0` (never `-0.0`).
pub fn signed(value: f64, decimals: usize) -> String {
    let scale = 10f64.powi(i32::try_from(decimals).unwrap_or(i32::MAX));
    // (−0.0 + 0.0 is +0.0.)
    let rounded = (value * scale).round() / scale + 0.0;
    format!("{rounded:+.decimals$}")
}

/// Foreign `text` fit for a terminal: every control character (newline,
/// escape, bell, …) and every bidirectional override escaped as Rust
/// writes it (`\n`, `\u{1b}`, `\u{202e}`), and at most `max_chars`
/// characters in all: longer text is cut, the cut said with the text's
/// length. What comes back is printable and at most `max_chars` long, so
/// applying it again changes nothing.
pub fn printable(text: &str, max_chars: usize) -> String {
    let mut escaped = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            escaped.extend(c.escape_debug());
        } else if is_bidi_control(c) {
            escaped.extend(c.escape_unicode());
        } else {
            escaped.push(c);
        }
    }
    if escaped.chars().count() <= max_chars {
        return escaped;
    }
    let cut = format!("… (cut from {})", count(text.chars().count() as u64, "character"));
    let keep = max_chars.saturating_sub(cut.chars().count());
    escaped.chars().take(keep).chain(cut.chars()).take(max_chars).collect()
}

/// Characters that reorder what a terminal shows after them (Unicode's
/// bidirectional embeddings, overrides and isolates).
fn is_bidi_control(c: char) -> bool {
    matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_say_one_in_the_singular() {
        assert_eq!(count(1, "dead iceoryx2 node"), "1 dead iceoryx2 node");
        assert_eq!(count(0, "robot"), "0 robots");
        assert_eq!(count(3, "robot"), "3 robots");
    }

    #[test]
    fn a_value_that_rounds_to_zero_has_no_minus() {
        assert_eq!(signed(-0.04, 1), "+0.0");
        assert_eq!(signed(-0.0, 1), "+0.0");
        assert_eq!(signed(-42.46, 1), "-42.5");
        assert_eq!(signed(3.0, 2), "+3.00");
    }

    #[test]
    fn control_characters_are_escaped_and_long_text_is_cut() {
        assert_eq!(printable("robot 2 near the stairs", 200), "robot 2 near the stairs");
        assert_eq!(printable("a\nb\u{1b}[31mred\u{7}", 200), "a\\nb\\u{1b}[31mred\\u{7}");
        assert_eq!(printable("evil\u{202e}txt", 200), "evil\\u{202e}txt");
        let long = "x".repeat(120_000);
        let shown = printable(&long, 200);
        assert_eq!(shown.chars().count(), 200);
        assert!(shown.ends_with("x… (cut from 120000 characters)"), "{shown}");
        assert_eq!(printable(&shown, 200), shown, "twice is once");
        assert_eq!(printable(&printable("a\tb", 200), 200), "a\\tb");
        assert_eq!(printable("abcdef", 3), "… (", "a limit below the note keeps what fits");
    }
}
