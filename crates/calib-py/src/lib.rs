//! Python bindings of the calibration crates: the package `calib` (this is its extension module
//! `calib._calib`; `python/calib/__init__.py` re-exports it, `python/calib/__init__.pyi` types
//! it). The functions take and return NumPy arrays in the shapes OpenCV's Python functions use.
//!
//! The bindings add no algorithm: each function converts its arguments, calls one function of
//! `calib-single`, `calib-stereo`, `calib-rig`, `board-detect`, `camera-model` or `calib-export`
//! with the GIL released, and converts the result. Errors of the Rust crates become `calib.CalibrationError`
//! with the crates' messages (their command-line hints in Python's words, [`python_wording`]),
//! except that a file that cannot be read or written raises the
//! `OSError` subclass `open()` would ([`os_error`]); bad arguments become `TypeError` /
//! `ValueError` naming the argument.
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
    "A calibration (or detection, or a file's content) failed; the message is the Rust crate's (its command-line hints in Python's words, e.g. model='rational8' for --model rational8), naming the view and point (or file and key) at fault. A file that cannot be opened raises OSError (FileNotFoundError, PermissionError, ...) instead, as open() does."
);

/// `calib.CalibrationError` with the message of a Rust error, in Python's words
/// ([`python_wording`]).
pub(crate) fn calibration_error(e: impl std::fmt::Display) -> PyErr {
    CalibrationError::new_err(python_wording(&e.to_string()))
}

/// Hints of the crates' messages written for the `calib` command, and what they are from
/// Python. Those written for both front ends (`--skip-bad-views; Python: skip_bad_views=True`)
/// are left as they are.
const CLI_HINTS: [(&str, &str); 3] = [
    // calib-export's advice when a lens model cannot be rectified.
    ("calib single --compare-models", "calib.compare_models"),
    // calib-export's advice when two cameras cannot share rectified images: the package has no
    // image undistortion, but points undistort without `R`, and the command is still there.
    (
        "(undistort each camera alone: calib undistort)",
        "(undistort each camera alone: undistort_points without R, or images with the command `calib undistort`)",
    ),
    // calib-core's `ReadError::TooLarge`: the package has no such option (read_calibration is
    // the only reader of files that reaches it).
    (
        "; raise the limit (--max-input-mb) if it really is an input file",
        ", the most the Python package reads from a calibration file",
    ),
];

/// A crate's message with its command-line hints in Python's words: `--model NAME` (and
/// `--model A or B`) becomes `model='NAME'` (`model='A' or model='B'`), and the hints of
/// [`CLI_HINTS`] their Python equivalents; a hint followed by `; Python: ...` already names
/// both and is kept. The `calib` command's own messages are unchanged (they are the crates').
pub(crate) fn python_wording(message: &str) -> String {
    const PYTHON_TOO: &str = "; Python: ";
    let mut text = message.to_string();
    for (cli, python) in CLI_HINTS {
        let mut out = String::with_capacity(text.len());
        let mut rest = text.as_str();
        while let Some(at) = rest.find(cli) {
            let after = &rest[at + cli.len()..];
            out.push_str(&rest[..at]);
            out.push_str(if after.starts_with(PYTHON_TOO) {
                cli
            } else {
                python
            });
            rest = after;
        }
        out.push_str(rest);
        text = out;
    }
    model_flags(&text)
}

/// `--model A` and `--model A or B` (known model names) as `model='A'` and
/// `model='A' or model='B'`, unless a `; Python: ` hint follows.
fn model_flags(message: &str) -> String {
    const FLAG: &str = "--model ";
    let name_end = |s: &str| {
        s.find(|c: char| !(c.is_ascii_alphanumeric() || c == '-' || c == '_'))
            .unwrap_or(s.len())
    };
    let is_model = |s: &str| !s.is_empty() && s.parse::<camera_model::CameraModel>().is_ok();
    let mut out = String::with_capacity(message.len());
    let mut rest = message;
    while let Some(at) = rest.find(FLAG) {
        out.push_str(&rest[..at]);
        let mut after = &rest[at + FLAG.len()..];
        let mut names = Vec::new();
        loop {
            let end = name_end(after);
            if !is_model(&after[..end]) {
                break;
            }
            names.push(&after[..end]);
            after = &after[end..];
            match after.strip_prefix(" or ") {
                Some(next) if is_model(&next[..name_end(next)]) => after = next,
                _ => break,
            }
        }
        if names.is_empty() || after.starts_with("; Python: ") {
            // Not a model name, or a hint for both front ends: as it was.
            out.push_str(&rest[at..rest.len() - after.len()]);
        } else {
            let python: Vec<String> = names.iter().map(|n| format!("model='{n}'")).collect();
            out.push_str(&python.join(" or "));
        }
        rest = after;
    }
    out.push_str(rest);
    out
}

/// A path for a message: cut to its first 60 characters when longer than 200 (a text passed
/// where a path belongs is not echoed whole).
pub(crate) fn shown_path(path: &str) -> String {
    let n = path.chars().count();
    if n > 200 {
        let short: String = path.chars().take(60).collect();
        format!("{short}... ({n} characters)")
    } else {
        path.to_string()
    }
}

/// An I/O error on the file `path` as the `OSError` subclass Python's `open()` raises for it
/// (`FileNotFoundError`, `PermissionError`, `IsADirectoryError`, `NotADirectoryError`, ...):
/// built as `OSError(errno, strerror, filename)`, which picks the subclass from the errno and
/// sets the attributes `errno`, `strerror` and `filename`, so that `str()` reads
/// `[Errno 2] No such file or directory: 'PATH'`, as `open()`'s does. The errno is the
/// operating system's where there is one; an error the crates make themselves (`calib` refusing
/// to replace a folder or a read-only file) has the errno of its kind and the crate's wording.
/// `None` for an error about the content (`InvalidData`: a file that is not UTF-8, say), which
/// stays a `CalibrationError`.
pub(crate) fn os_error(py: Python<'_>, error: &std::io::Error, path: &str) -> Option<PyErr> {
    use std::io::ErrorKind as K;
    let filename = shown_path(path);
    let attempt = || -> PyResult<Option<PyErr>> {
        let kind_errno = match error.kind() {
            K::NotFound => Some("ENOENT"),
            K::PermissionDenied => Some("EACCES"),
            K::IsADirectory => Some("EISDIR"),
            K::NotADirectory => Some("ENOTDIR"),
            K::AlreadyExists => Some("EEXIST"),
            _ => None,
        };
        // The raw code is an errno on Unix only (a Windows error code elsewhere).
        let os_errno = if cfg!(unix) {
            error.raw_os_error()
        } else {
            None
        };
        let (errno, strerror): (i64, String) = match (os_errno, kind_errno) {
            (Some(errno), _) => (
                errno.into(),
                py.import("os")?
                    .call_method1("strerror", (errno,))?
                    .extract()?,
            ),
            (None, Some(name)) => {
                let text = match error.get_ref() {
                    // The crate's own wording ("that is a folder; give a file name").
                    Some(inner) => inner.to_string(),
                    None => error.to_string(),
                };
                (py.import("errno")?.getattr(name)?.extract()?, text)
            }
            (None, None) if error.raw_os_error().is_some() => {
                return Ok(Some(pyo3::exceptions::PyOSError::new_err(format!(
                    "{filename}: {error}"
                ))));
            }
            (None, None) => return Ok(None),
        };
        let object = py.get_type::<pyo3::exceptions::PyOSError>().call1((
            errno,
            strerror,
            filename.as_str(),
        ))?;
        Ok(Some(PyErr::from_value(object)))
    };
    attempt().unwrap_or_else(Some)
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
