//! Python bindings of the calibration crates: the package `calib` (this is its extension module
//! `calib._calib`; `python/calib/__init__.py` re-exports it, `python/calib/__init__.pyi` types
//! it). The functions take and return NumPy arrays in the shapes OpenCV's Python functions use.
//!
//! The bindings add no algorithm: each function converts its arguments, calls one function of
//! `calib-single`, `calib-stereo`, `calib-rig`, `board-detect`, `camera-model` or `calib-export`
//! with the GIL released, and converts the result. Errors of the Rust crates become `calib.CalibrationError`
//! with the crates' messages; bad arguments become `TypeError` / `ValueError` naming the argument.
//! Documentation: `docs/python.md`.

#[macro_use]
mod result_object;
mod args;
mod camera;
mod compare;
mod convert;
mod detect;
mod export;
mod options;
mod rig;
mod single;
mod stereo;

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyUserWarning};
use pyo3::prelude::*;

create_exception!(
    calib,
    CalibrationError,
    PyException,
    "A calibration (or detection, or file) failed; the message is the Rust crate's, naming the view and point at fault."
);

/// `calib.CalibrationError` with the message of a Rust error.
pub(crate) fn calibration_error(e: impl std::fmt::Display) -> PyErr {
    CalibrationError::new_err(e.to_string())
}

create_exception!(
    calib,
    CalibrationWarning,
    PyUserWarning,
    "Something in a calibration result that deserves attention, a subclass of UserWarning: the calibration functions emit one with warnings.warn for each entry of the result's ``warnings`` (filter them with ``warnings.simplefilter('ignore', calib.CalibrationWarning)``), and the entries are instances of it, with ``code`` (stable, e.g. \"poorly-determined\") and ``message`` (what happened and what to do); ``str()`` is ``[code] message``."
);

/// A warning of a result as a `CalibrationWarning` instance: `args[0]` is `"[code] message"`
/// (what `warnings` prints), with the attributes `code` and `message`.
fn warning_object<'py>(py: Python<'py>, w: &calib_core::Warning) -> PyResult<Bound<'py, PyAny>> {
    let code = w.code.name();
    let object = py
        .get_type::<CalibrationWarning>()
        .call1((format!("[{code}] {}", w.message),))?;
    object.setattr("code", code)?;
    object.setattr("message", &w.message)?;
    Ok(object)
}

/// Warnings as a Python list of `CalibrationWarning`.
pub(crate) fn warnings_out<'py>(
    py: Python<'py>,
    warnings: &[calib_core::Warning],
) -> PyResult<Bound<'py, pyo3::types::PyList>> {
    let items = warnings
        .iter()
        .map(|w| warning_object(py, w))
        .collect::<PyResult<Vec<_>>>()?;
    pyo3::types::PyList::new(py, items)
}

/// Emits each warning with `warnings.warn`, attributed to the Python line that called the
/// calibration (stacklevel 1 is the innermost Python frame: this function runs in Rust, called
/// from that line). A filter that turns warnings into errors makes the call raise.
pub(crate) fn emit_warnings(py: Python<'_>, warnings: &[calib_core::Warning]) -> PyResult<()> {
    if warnings.is_empty() {
        return Ok(());
    }
    let warn = py.import("warnings")?.getattr("warn")?;
    for w in warnings {
        warn.call1((warning_object(py, w)?,))?;
    }
    Ok(())
}

/// Where a camera's lens model is one-to-one (`AnyCamera::validity`, docs/camera-model.md), as
/// the dict the results' `validity` attribute holds: `valid_radius_px` (pixels from the principal
/// point to the nearest fold; `None` when no fold was found), `image_radius_px` (to the farthest
/// image corner), `coverage` (the fold's distance over the image border's along the worst
/// direction; `None` with no fold) and `covers_image` (valid over the image with the 5% margin the
/// `model-invalid` warning checks).
pub(crate) fn validity_out<'py>(
    py: Python<'py>,
    camera: &camera_model::AnyCamera,
    size: calib_core::ImageSize,
) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
    let v = camera.validity(size.width, size.height);
    let finite = |x: f64| x.is_finite().then_some(x);
    let d = pyo3::types::PyDict::new(py);
    d.set_item("valid_radius_px", finite(v.valid_radius_px))?;
    d.set_item("image_radius_px", v.image_radius_px)?;
    d.set_item("coverage", finite(v.coverage))?;
    d.set_item(
        "covers_image",
        v.covers_image(calib_core::diagnostics::VALIDITY_MARGIN),
    )?;
    Ok(d)
}

/// Camera calibration (single cameras, stereo pairs, rigs of N cameras) and chessboard detection,
/// with NumPy arrays shaped like OpenCV's. See `help(calib)` and docs/python.md.
#[pymodule]
#[pyo3(name = "_calib")]
fn calib_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("CalibrationError", py.get_type::<CalibrationError>())?;
    m.add("CalibrationWarning", py.get_type::<CalibrationWarning>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    single::register(m)?;
    compare::register(m)?;
    stereo::register(m)?;
    rig::register(m)?;
    detect::register(m)?;
    camera::register(m)?;
    export::register(m)?;
    Ok(())
}
