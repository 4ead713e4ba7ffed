//! Camera model (work in progress).
#![deny(missing_docs)]
