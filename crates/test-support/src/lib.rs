//! What the calibration crates' tests share (a dev-dependency only, never of a library):
//!
//! * [`mod@sweep`]: run a convergence sweep over a population of generated problems on two
//!   threads, classify each problem ([`Outcome`]) and print and check the tally;
//! * [`mutate`]: the byte- and number-level mutations of a JSON input file that the fuzz
//!   tests apply, and [`all_finite`] for their results.
#![deny(missing_docs)]

pub mod mutate;
pub mod sweep;

pub use mutate::{all_finite, flip_byte, replace_number};
pub use sweep::{Outcome, Tally, ended, judge, reference_from_truth, sweep};
