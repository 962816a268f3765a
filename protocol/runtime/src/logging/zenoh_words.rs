//! zenoh's warnings and errors, said in our words.
//!
//! Why: zenoh says why a connection failed only in its own log lines,
//! worded for its developers: `Unable to connect to quic/…! … invalid peer
//! certificate: BadSignature at /root/.cargo/registry/src/…/unicast.rs:597.`,
//! and on the other end `QUIC acceptor failed: … Hint: increase the system
//! open file limit.` — for a certificate of another lab, an expired one,
//! an address in use, a host not found, a refused connection. Each such
//! line is printed here as what happened
//! (`bycoms_protocol::bus::zenoh::zenoh_words`), in the same place, format
//! and span as zenoh's line would have been; the summary line zenoh adds
//! after each failed attempt is left out (it repeats the line before).
//! zenoh's own lines are still there with `RUST_LOG=zenoh=debug` and
//! above: only its warnings and errors are reworded.

use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::fmt::format::Writer;
use tracing_subscriber::fmt::{FmtContext, FormatEvent, FormatFields};
use tracing_subscriber::registry::LookupSpan;

/// An event formatter that rewords zenoh's warnings and errors and formats
/// every event with `inner`.
pub struct Reworded<F>(pub F);

/// Whether an event is one of zenoh's warnings or errors.
fn is_zenoh_alarm(event: &Event<'_>) -> bool {
    let meta = event.metadata();
    meta.target().starts_with("zenoh") && *meta.level() <= Level::WARN
}

/// zenoh's words in ours (the process runtime has the zenoh bus; without
/// it there is no zenoh to reword).
#[cfg(feature = "process")]
fn in_our_words(message: &str) -> Option<String> {
    bycoms_protocol::bus::zenoh::zenoh_words(message)
}

#[cfg(not(feature = "process"))]
fn in_our_words(message: &str) -> Option<String> {
    Some(message.to_owned())
}

/// An event's message.
struct Message(String);

impl Visit for Message {
    fn record_debug(&mut self, field: &Field, value: &dyn core::fmt::Debug) {
        if field.name() == "message" {
            self.0 = format!("{value:?}");
        }
    }
    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.0 = value.to_owned();
        }
    }
}

impl<S, N, F> FormatEvent<S, N> for Reworded<F>
where
    S: Subscriber + for<'a> LookupSpan<'a>,
    N: for<'a> FormatFields<'a> + 'static,
    F: FormatEvent<S, N>,
{
    fn format_event(
        &self,
        ctx: &FmtContext<'_, S, N>,
        writer: Writer<'_>,
        event: &Event<'_>,
    ) -> core::fmt::Result {
        if !is_zenoh_alarm(event) {
            return self.0.format_event(ctx, writer, event);
        }
        let mut message = Message(String::new());
        event.record(&mut message);
        // Nothing to say: nothing written, no line.
        let Some(words) = in_our_words(&message.0) else { return Ok(()) };
        let meta = event.metadata();
        let Some(field) = meta.fields().field("message") else {
            return self.0.format_event(ctx, writer, event);
        };
        let text = format_args!("{words}");
        let values = [(&field, Some(&text as &dyn tracing::Value))];
        let fields = meta.fields().value_set(&values);
        self.0.format_event(ctx, writer, &Event::new(meta, &fields))
    }
}
