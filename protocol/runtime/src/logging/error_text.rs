//! The one text of an error that ends a program: its chain of causes, each
//! said once.
//!
//! Why: many of our errors name their cause in their own message (`cannot
//! open recording F: No such file or directory (os error 2)`) and also
//! return it as their `source()`, so the usual "message: cause: cause"
//! rendering (anyhow's `{:#}`) says the cause twice. Rather than keep every
//! error type from doing both, the one place that renders a chain for the
//! user skips a cause whose text the line already holds.

use std::error::Error;

/// `err` and its causes joined by ": ", leaving out any cause whose text
/// is already part of what came before it.
pub fn error_text(err: &(dyn Error + 'static)) -> String {
    let mut text = err.to_string();
    let mut cause = err.source();
    while let Some(e) = cause {
        let said = e.to_string();
        if !said.is_empty() && !text.contains(&said) {
            text.push_str(": ");
            text.push_str(&said);
        }
        cause = e.source();
    }
    text
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fmt;

    #[derive(Debug)]
    struct Wrap(&'static str, Option<Box<dyn Error + 'static>>);

    impl fmt::Display for Wrap {
        fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(self.0)
        }
    }

    impl Error for Wrap {
        fn source(&self) -> Option<&(dyn Error + 'static)> {
            self.1.as_deref()
        }
    }

    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        let io = std::io::Error::from(std::io::ErrorKind::NotFound);
        let said = format!("cannot open F: {io}");
        let top = Wrap(Box::leak(said.into_boxed_str()), Some(Box::new(io)));
        assert_eq!(error_text(&top), "cannot open F: entity not found");
    }

    #[test]
    fn causes_not_yet_said_are_joined_in_order() {
        let inner = Wrap("disk full", None);
        let middle = Wrap("cannot write r.mcap", Some(Box::new(inner)));
        let top = Wrap("recording failed", Some(Box::new(middle)));
        assert_eq!(error_text(&top), "recording failed: cannot write r.mcap: disk full");
        assert_eq!(error_text(&Wrap("alone", None)), "alone");
        let empty = Wrap("outer", Some(Box::new(Wrap("", None))));
        assert_eq!(error_text(&empty), "outer");
    }
}
