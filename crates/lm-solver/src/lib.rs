//! Generic sparse Levenberg-Marquardt engine (work in progress: see issue 3).
#![deny(missing_docs)]

pub mod numdiff;
