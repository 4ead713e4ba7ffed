//! Extractors of the plain keyword arguments (flags, numbers, names) for pyo3's `from_py_with`,
//! so that a value of the wrong type raises a `TypeError` whose message names the argument
//! (`max_iterations: expected an int, got str`); pyo3's own extraction puts the name only in the
//! exception's `__notes__`.

use crate::convert::{short_repr, type_name};
use pyo3::exceptions::{PyOverflowError, PyTypeError, PyValueError};
use pyo3::prelude::*;

/// `obj` as a `T`, or an error of the same type naming the argument `name` (a `TypeError` says
/// `expected`).
fn named<'a, 'py, T>(obj: &'a Bound<'py, PyAny>, name: &str, expected: &str) -> PyResult<T>
where
    T: FromPyObject<'a, 'py>,
    T::Error: Into<PyErr>,
{
    obj.extract::<T>().map_err(|e| {
        let e: PyErr = e.into();
        let py = obj.py();
        if e.is_instance_of::<PyTypeError>(py) {
            PyTypeError::new_err(format!(
                "{name}: expected {expected}, got {}",
                type_name(obj)
            ))
        } else if e.is_instance_of::<PyOverflowError>(py) {
            // An int beyond i64 (or f64): out of range, as a smaller out-of-range value is.
            PyValueError::new_err(format!("{name}: {} is out of range", short_repr(obj)))
        } else {
            PyErr::from_type(e.get_type(py), format!("{name}: {}", e.value(py)))
        }
    })
}

/// One extractor function per argument name: `name: Type = "what is expected"`.
macro_rules! extractors {
    ($($name:ident: $ty:ty = $expected:literal),* $(,)?) => {
        $(
            #[allow(non_snake_case)]
            pub fn $name(obj: &Bound<'_, PyAny>) -> PyResult<$ty> {
                named(obj, stringify!($name), $expected)
            }
        )*
    };
}

extractors! {
    model: Option<String> = "a model name (str) or None",
    model2: Option<String> = "a model name (str) or None",
    loss: Option<String> = "None, 'huber' or 'cauchy'",
    rotation: Option<String> = "None, 'euler', 'axis-angle' or 'so3'",
    rig_init: String = "'least-squares' or 'median'",
    format: String = "a format name (str): 'opencv', 'ros' or 'kalibr'",
    reject_outliers: bool = "True or False",
    skip_bad_views: bool = "True or False",
    skip_bad_pairs: bool = "True or False",
    drop_duplicate_views: bool = "True or False",
    compute_std: bool = "True or False",
    fix_intrinsics: bool = "True or False",
    fix_intrinsics1: bool = "True or False",
    fix_intrinsics2: bool = "True or False",
    same_focal_length: bool = "True or False",
    raise_on_failure: bool = "True or False",
    outlier_threshold: f64 = "a number",
    loss_scale: f64 = "a number",
    translation_scale: f64 = "a number",
    square: f64 = "a number",
    alpha: Option<f64> = "a number or None",
    max_iterations: i64 = "an int",
    bootstrap: Option<i64> = "an int or None",
    threads: i64 = "an int",
    min_views: i64 = "an int",
    names: Option<Vec<String>> = "a list of strings or None",
    path: std::path::PathBuf = "a path (str or os.PathLike)",
}
