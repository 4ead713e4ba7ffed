//! Single-camera calibration from views of a planar target (work in progress: see issue 4).
#![deny(missing_docs)]
