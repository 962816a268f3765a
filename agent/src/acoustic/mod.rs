//! The acoustic robot of the paper's experiments (§VI).
//!
//! The simulation's point robot senses an ideal field. The physical robot
//! makes one: each robot plays its own sine through a speaker, and hears the
//! others through six microphones on a ring. Turning sound into the
//! controller's inputs, and the controller's decision into track voltages,
//! takes three pieces, each usable alone (a simulator can feed the gradient
//! estimator synthetic readings; firmware runs all three):
//!
//! * [`tones`] — per microphone frame, a fixed-point DFT of the few bins
//!   needed isolates the *other* robots' tones (the own tone is loudest and would swamp the gradient) and sums
//!   their amplitudes into that microphone's reading V_n;
//! * [`gradient`] — the six readings give V_ave (intensity at the centre) and
//!   the direction of Σ (V_n − V_ave)·m_n, the field gradient;
//! * [`drive`] — the two-mode differential-drive law: mode 1 steers at the
//!   goal, mode 2 follows the field's contour at V_target; left/right track
//!   voltages v_m ± u.
//!
//! Like the rest of the crate: no_std, no allocation, no clocks, no
//! randomness; all math through `libm`.

pub mod drive;
pub mod gradient;
pub mod tones;

pub use drive::{DriveConfig, DriveController, DriveInput, DriveOutput, Tangent};
pub use gradient::{GradientEstimate, MicRing};
pub use tones::{Frame, ToneAmplitudes, ToneConfig, ToneError, ToneIsolator, ADC_MAX, FRAME_LEN};
