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
mod convert;
mod detect;
mod export;
mod options;
mod rig;
mod single;
mod stereo;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
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

/// Something in a result that deserves attention: a stable `code` (e.g. `"poorly-determined"`)
/// and a `message` saying what to do.
#[pyclass(module = "calib", frozen, get_all)]
#[derive(Clone)]
pub struct CalibrationWarning {
    /// The stable code, as in the JSON results (`docs/calib-single.md` lists them).
    code: String,
    /// What happened and what to do.
    message: String,
}

#[pymethods]
impl CalibrationWarning {
    fn __repr__(&self) -> String {
        format!(
            "CalibrationWarning(code={:?}, message={:?})",
            self.code, self.message
        )
    }

    fn __str__(&self) -> String {
        format!("warning [{}]: {}", self.code, self.message)
    }
}

impl From<&calib_core::Warning> for CalibrationWarning {
    fn from(w: &calib_core::Warning) -> Self {
        Self {
            code: w.code.name().to_string(),
            message: w.message.clone(),
        }
    }
}

/// Warnings as a Python list.
pub(crate) fn warnings_out<'py>(
    py: Python<'py>,
    warnings: &[calib_core::Warning],
) -> PyResult<Bound<'py, pyo3::types::PyList>> {
    pyo3::types::PyList::new(py, warnings.iter().map(CalibrationWarning::from))
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
    m.add_class::<CalibrationWarning>()?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    single::register(m)?;
    stereo::register(m)?;
    rig::register(m)?;
    detect::register(m)?;
    camera::register(m)?;
    export::register(m)?;
    Ok(())
}
