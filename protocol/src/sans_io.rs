//! The one shape of every sans-IO core: the launch core, the simulated
//! agent's core, the gateway's and the ROS 2 robot's session cores and the
//! firmware's core.
//!
//! Why one shape: each core is driven by a shell that does the IO and by
//! a harness in virtual time (the launch's 10 000 schedules, the cores' own
//! tests with a hand-driven clock). With one shape there is one way to
//! drive any of them, one time type to hand-drive, and one place that says
//! how time enters a core:
//!
//! - [`SansIo::handle`] takes one input at a time, at `now`;
//! - [`SansIo::advance`] runs what is due by `now` (timers, a tick, a
//!   frame to send);
//! - [`SansIo::poll`] hands out what the core asks its shell to do, in
//!   order, until it has nothing left;
//! - [`SansIo::deadline`] says when `advance` next has something to do.
//!
//! Time is [`Micros`]: microseconds since an epoch the shell picks (the
//! launch's start, the agent's or gateway's own start, the robot's boot).
//! A core never reads a clock. Why whole microseconds and not `Instant` or
//! `Duration`: a `u64` is the same on a host and on the firmware (no_std,
//! no allocator), it is what the launch's recordings store, and it is the
//! finest unit any of the cores' rules needs.

/// Microseconds since the epoch a core's shell picked.
pub type Micros = u64;

/// A core that does no IO: its shell hands it inputs and the time, and
/// carries out what it polls (see the module's docs).
pub trait SansIo {
    /// What comes in: a report, a command, a datagram, a reading.
    type Input<'a>;
    /// What [`SansIo::handle`] says at once of the input it took: a refusal
    /// the shell counts or acts on before it polls (`()` when everything
    /// goes through [`SansIo::poll`]).
    type Handled;
    /// What the core asks its shell to do (it may borrow the core: a frame
    /// in the firmware's own buffer).
    type Output<'a>
    where
        Self: 'a;

    /// Takes one input at `now`.
    fn handle(&mut self, now: Micros, input: Self::Input<'_>) -> Self::Handled;

    /// Runs what is due by `now`.
    fn advance(&mut self, now: Micros);

    /// The next thing to do, if any.
    fn poll(&mut self) -> Option<Self::Output<'_>>;

    /// When [`SansIo::advance`] next has something to do (none: only when
    /// an input comes). A time already past means now.
    fn deadline(&self) -> Option<Micros>;
}
