//! Homography estimation (work in progress).
#![deny(missing_docs)]
