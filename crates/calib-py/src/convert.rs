//! NumPy and Python values in and out: point lists of the shapes cv2 accepts, image sizes,
//! camera matrices, and the arrays of the results. Every input error names the argument (and the
//! index in a list) and raises `TypeError` (wrong kind or dtype) or `ValueError` (wrong shape or
//! value), never a panic.

use calib_core::ImageSize;
use camera_model::{AxisAngle, Intrinsics, Pose, RotationParameterization};
use nalgebra::{Matrix3, Point2, Point3, Vector3};
use numpy::{
    PyArray1, PyArray2, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyList, PyString};

/// The `numpy` module, imported once.
fn numpy_module(py: Python<'_>) -> PyResult<&Bound<'_, PyModule>> {
    static NUMPY: PyOnceLock<Py<PyModule>> = PyOnceLock::new();
    NUMPY
        .get_or_try_init(py, || Ok(py.import("numpy")?.unbind()))
        .map(|m| m.bind(py))
}

/// `what` shaped like `(3, 1)` for messages.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// `obj` as a NumPy array (array-likes such as nested lists go through `numpy.asarray`).
pub fn as_array<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Bound<'py, PyUntypedArray>> {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        return Ok(a.clone());
    }
    let py = obj.py();
    let converted = numpy_module(py)?
        .call_method1("asarray", (obj,))
        .map_err(|e| {
            PyTypeError::new_err(format!(
                "{what}: expected a NumPy array, got {} ({e})",
                type_name(obj)
            ))
        })?;
    Ok(converted.cast::<PyUntypedArray>()?.clone())
}

/// `repr(obj)` for a message: on one line, cut to 60 characters (an array or a long text is
/// not echoed whole). Arrays are described by their shape.
pub fn short_repr(obj: &Bound<'_, PyAny>) -> String {
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        return format!("an array of shape {}", shape_text(a.shape()));
    }
    let text = obj
        .repr()
        .map(|r| r.to_string())
        .unwrap_or_else(|_| "?".into());
    let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
    const MAX: usize = 60;
    match text.char_indices().nth(MAX) {
        None => text,
        Some((cut, _)) => format!("{}... ({} characters)", &text[..cut], text.chars().count()),
    }
}

/// The Python type name of `obj`, for messages.
pub fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type()
        .name()
        .map(|n| n.to_string())
        .unwrap_or_else(|_| "?".into())
}

/// A real-valued array as `float64`: float32 and integers are converted exactly, longdouble
/// (float128) is rounded to float64 (nothing a calibration can see is lost). float16 is a
/// `TypeError`, as in cv2: its 11 significant bits round pixel coordinates above 2048 to whole
/// pixels (above 1024 to half pixels), so points in it were rounded by a mistake before they
/// got here. Other dtypes (bool, complex, object, ...) are a `TypeError` too.
pub fn as_f64<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let array = as_array(obj, what)?;
    let kind = array.dtype().kind();
    if !matches!(kind, b'f' | b'i' | b'u') {
        return Err(PyTypeError::new_err(format!(
            "{what}: expected a float32 or float64 array, got dtype {}",
            array.dtype()
        )));
    }
    if kind == b'f' && array.dtype().itemsize() < 4 {
        return Err(PyTypeError::new_err(format!(
            "{what}: float16 arrays are refused (cv2 refuses them too): their 11 significant bits round pixel coordinates above 2048 to whole pixels; pass float32 or float64, made from the values before they were rounded to float16"
        )));
    }
    let py = obj.py();
    let as_f64 = if array.dtype().is_equiv_to(&numpy::dtype::<f64>(py)) {
        array.into_any()
    } else {
        array.call_method1("astype", ("float64",))?
    };
    Ok(as_f64.cast::<PyArrayDyn<f64>>()?.clone())
}

/// The values of an `(N, D)`, `(N, 1, D)` or `(1, N, D)` array (the shapes cv2 accepts for point
/// lists), row by row.
pub fn point_rows<const D: usize>(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f64; D]>> {
    let array = as_f64(obj, what)?;
    let shape = array.shape().to_vec();
    let n = match shape.as_slice() {
        [n, d] if *d == D => *n,
        [n, 1, d] if *d == D => *n,
        [1, n, d] if *d == D => *n,
        _ => {
            return Err(PyValueError::new_err(format!(
                "{what}: expected an array of shape (N, {D}) or (N, 1, {D}), got shape {}",
                shape_text(&shape)
            )));
        }
    };
    let readonly = array.readonly();
    let view = readonly.as_array();
    let flat: Vec<f64> = view.iter().copied().collect();
    debug_assert_eq!(flat.len(), n * D);
    Ok(flat
        .chunks_exact(D)
        .map(|c| std::array::from_fn(|i| c[i]))
        .collect())
}

/// Board points of one view.
pub fn points3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Point3<f64>>> {
    Ok(point_rows::<3>(obj, what)?
        .into_iter()
        .map(|p| Point3::new(p[0], p[1], p[2]))
        .collect())
}

/// Pixels of one view.
pub fn points2(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<Point2<f64>>> {
    Ok(point_rows::<2>(obj, what)?
        .into_iter()
        .map(|p| Point2::new(p[0], p[1]))
        .collect())
}

/// The items of a per-view list (a list, a tuple, or any iterable; an array of shape (M, N, D)
/// counts as M views). A single 2-D array is refused with a hint, since iterating it would give
/// rows, not views.
pub fn view_list<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Vec<Bound<'py, PyAny>>> {
    if obj.is_instance_of::<PyString>() || obj.is_instance_of::<PyDict>() {
        return Err(PyTypeError::new_err(format!(
            "{what}: expected a list of arrays (one per view), got {}",
            type_name(obj)
        )));
    }
    if let Ok(a) = obj.cast::<PyUntypedArray>() {
        if a.ndim() < 3 {
            return Err(PyTypeError::new_err(format!(
                "{what}: expected a list of arrays (one per view), got one array of shape {}: wrap it in a list",
                shape_text(a.shape())
            )));
        }
        // cv2's (N, 1, D) shape of one view given without the list: iterating it would give N
        // views of one point each (cv2 reads it so and fails with "the number of points in the
        // view #0 is < 4"), which no calibration can use.
        if let [n, 1, 2 | 3] = a.shape() {
            return Err(PyTypeError::new_err(format!(
                "{what}: expected a list of arrays (one per view), got one array of shape {}, which would be {n} views of one point each: if it is one view in cv2's (N, 1, D) shape, wrap it in a list",
                shape_text(a.shape())
            )));
        }
    }
    let iter = obj.try_iter().map_err(|_| {
        PyTypeError::new_err(format!(
            "{what}: expected a list of arrays (one per view), got {}",
            type_name(obj)
        ))
    })?;
    iter.collect()
}

/// The items of a per-camera list of image sizes: a list or tuple of `(width, height)`, or an
/// array of shape (C, 2) (one row per camera).
pub fn size_list<'py>(obj: &Bound<'py, PyAny>, what: &str) -> PyResult<Vec<Bound<'py, PyAny>>> {
    let bad = || {
        PyTypeError::new_err(format!(
            "{what}: expected a list of (width, height), one per camera, got {}",
            short_repr(obj)
        ))
    };
    if obj.is_instance_of::<PyString>() || obj.is_instance_of::<PyDict>() {
        return Err(bad());
    }
    if let Ok(a) = obj.cast::<PyUntypedArray>()
        && a.ndim() != 2
    {
        return Err(bad());
    }
    obj.try_iter().map_err(|_| bad())?.collect()
}

/// Two per-view lists of equal length.
pub fn check_same_length(a: usize, what_a: &str, b: usize, what_b: &str) -> PyResult<()> {
    if a != b {
        return Err(PyValueError::new_err(format!(
            "{what_a} has {a} views but {what_b} has {b}: give one array per view in both"
        )));
    }
    Ok(())
}

/// `(width, height)` in pixels.
pub fn image_size(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<ImageSize> {
    let bad = || {
        PyValueError::new_err(format!(
            "{what}: expected (width, height) as two positive integers, got {}",
            short_repr(obj)
        ))
    };
    if obj.is_instance_of::<PyString>() {
        return Err(bad());
    }
    let items: Vec<Bound<'_, PyAny>> = obj
        .try_iter()
        .map_err(|_| bad())?
        .collect::<PyResult<_>>()?;
    let [w, h] = items.as_slice() else {
        return Err(bad());
    };
    let side = |v: &Bound<'_, PyAny>| -> PyResult<u32> {
        let index = v.call_method0("__index__").map_err(|_| bad())?;
        let value: i64 = index.extract().map_err(|_| bad())?;
        u32::try_from(value).ok().filter(|&v| v > 0).ok_or_else(bad)
    };
    Ok(ImageSize::new(side(w)?, side(h)?))
}

/// A fixed-size matrix of `R x C` values (any shape with that many values in row-major order is
/// refused unless it is `(R, C)` or, for vectors, `(N,)`, `(N, 1)` or `(1, N)`).
pub fn matrix3(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Matrix3<f64>> {
    let array = as_f64(obj, what)?;
    if array.shape() != [3, 3] {
        return Err(PyValueError::new_err(format!(
            "{what}: expected a 3x3 array, got shape {}",
            shape_text(array.shape())
        )));
    }
    let readonly = array.readonly();
    let v = readonly.as_array();
    Ok(Matrix3::from_fn(|i, j| v[[i, j]]))
}

/// A vector of any length, from an array of shape `(N,)`, `(N, 1)` or `(1, N)`.
pub fn vector(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<f64>> {
    let array = as_f64(obj, what)?;
    let shape = array.shape().to_vec();
    match shape.as_slice() {
        [_] | [_, 1] | [1, _] => {}
        _ => {
            return Err(PyValueError::new_err(format!(
                "{what}: expected a vector of shape (N,), (N, 1) or (1, N), got shape {}",
                shape_text(&shape)
            )));
        }
    }
    let readonly = array.readonly();
    Ok(readonly.as_array().iter().copied().collect())
}

/// A number as Python prints it (`nan`, `inf`, `-inf`, `500.0`), for messages.
pub fn py_float(x: f64) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 { "inf".into() } else { "-inf".into() }
    } else if x == x.trunc() && x.abs() < 1e16 {
        format!("{x:.1}")
    } else {
        format!("{x}")
    }
}

/// Refuses non-finite values, naming the first.
pub fn check_finite(values: &[f64], what: &str) -> PyResult<()> {
    match values.iter().position(|v| !v.is_finite()) {
        None => Ok(()),
        Some(i) => Err(PyValueError::new_err(format!(
            "{what}: the values must be finite, got {} at index {i}",
            py_float(values[i])
        ))),
    }
}

/// A rotation: a 3x3 rotation matrix or a Rodrigues vector of 3 values (shape (3,), (3, 1) or
/// (1, 3)), as cv2 accepts either. The matrix must pass calib-export's `check_rotation`
/// (orthonormal with determinant +1 to 1e-6), so that a rotation rounded to float32 (about 1e-7
/// off) is one; it is used as given.
pub fn rotation(r: &Bound<'_, PyAny>, what: &str) -> PyResult<Matrix3<f64>> {
    let array = as_f64(r, what)?;
    if array.shape() == [3, 3] {
        let m = matrix3(r, what)?;
        calib_export::calibration::check_rotation(&m, what)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(m)
    } else {
        let w = vector_n(r, 3, &format!("{what} (a 3x3 matrix or a rotation vector)"))?;
        check_finite(&w, what)?;
        Ok(AxisAngle::matrix(&Vector3::new(w[0], w[1], w[2])))
    }
}

/// A vector of exactly `n` values.
pub fn vector_n(obj: &Bound<'_, PyAny>, n: usize, what: &str) -> PyResult<Vec<f64>> {
    let v = vector(obj, what)?;
    if v.len() != n {
        return Err(PyValueError::new_err(format!(
            "{what}: expected {n} values, got {}",
            v.len()
        )));
    }
    Ok(v)
}

/// Intrinsics from a camera matrix `K` (3x3, no skew, last row `0 0 1`).
pub fn intrinsics_from_k(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Intrinsics> {
    let k = matrix3(obj, what)?;
    if k[(0, 1)] != 0.0
        || k[(1, 0)] != 0.0
        || k[(2, 0)] != 0.0
        || k[(2, 1)] != 0.0
        || k[(2, 2)] != 1.0
    {
        return Err(PyValueError::new_err(format!(
            "{what}: expected a camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew)"
        )));
    }
    let (fx, fy, cx, cy) = (k[(0, 0)], k[(1, 1)], k[(0, 2)], k[(1, 2)]);
    if !(fx.is_finite() && fy.is_finite() && fx > 0.0 && fy > 0.0) {
        return Err(PyValueError::new_err(format!(
            "{what}: the focal lengths must be finite and positive, got fx = {}, fy = {}",
            py_float(fx),
            py_float(fy)
        )));
    }
    if !(cx.is_finite() && cy.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{what}: the principal point must be finite, got cx = {}, cy = {}",
            py_float(cx),
            py_float(cy)
        )));
    }
    Ok(Intrinsics::new(fx, fy, cx, cy))
}

/// A rigid transform from a rotation (3x3 matrix or Rodrigues vector; the argument `r_what`) and
/// a translation (`t_what`).
pub fn pose(
    r: &Bound<'_, PyAny>,
    t: &Bound<'_, PyAny>,
    r_what: &str,
    t_what: &str,
) -> PyResult<Pose> {
    let rotation = rotation(r, r_what)?;
    let t = vector_n(t, 3, t_what)?;
    check_finite(&t, t_what)?;
    Ok(Pose::new(rotation, Vector3::new(t[0], t[1], t[2])))
}

/// A 3x3 matrix as a `(3, 3)` float64 array.
pub fn mat3_out<'py>(py: Python<'py>, m: &Matrix3<f64>) -> Bound<'py, PyArray2<f64>> {
    let rows: Vec<Vec<f64>> = (0..3)
        .map(|i| (0..3).map(|j| m[(i, j)]).collect())
        .collect();
    PyArray2::from_vec2(py, &rows).expect("3x3")
}

/// An `R x C` matrix as an `(R, C)` float64 array (cv2's `P1`, `P2`, `Q`).
pub fn matrix_out<'py, const R: usize, const C: usize>(
    py: Python<'py>,
    m: &nalgebra::SMatrix<f64, R, C>,
) -> Bound<'py, PyArray2<f64>> {
    let rows: Vec<Vec<f64>> = (0..R)
        .map(|i| (0..C).map(|j| m[(i, j)]).collect())
        .collect();
    PyArray2::from_vec2(py, &rows).expect("rows of equal length")
}

/// A column vector as an `(N, 1)` float64 array (cv2's `rvec`, `tvec`, `T`).
pub fn column_out<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray2<f64>> {
    let rows: Vec<Vec<f64>> = v.iter().map(|&x| vec![x]).collect();
    PyArray2::from_vec2(py, &rows).expect("column")
}

/// A row vector as a `(1, N)` float64 array (cv2's distortion coefficients).
pub fn row_out<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray2<f64>> {
    PyArray2::from_vec2(py, &[v.to_vec()]).expect("row")
}

/// A flat `(N,)` float64 array.
pub fn flat_out<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

/// The Rodrigues rotation vectors of `poses`, one `(3, 1)` array each (cv2's `rvecs`).
pub fn rvecs_out<'a, 'py>(
    py: Python<'py>,
    poses: impl IntoIterator<Item = &'a Pose>,
) -> PyResult<Bound<'py, PyList>> {
    list_out(
        py,
        poses.into_iter().map(|pose| {
            let w = AxisAngle::from_matrix(&pose.rotation);
            column_out(py, &[w.x, w.y, w.z])
        }),
    )
}

/// The translations of `poses`, one `(3, 1)` array each (cv2's `tvecs`).
pub fn tvecs_out<'a, 'py>(
    py: Python<'py>,
    poses: impl IntoIterator<Item = &'a Pose>,
) -> PyResult<Bound<'py, PyList>> {
    list_out(
        py,
        poses.into_iter().map(|pose| {
            let t = pose.translation;
            column_out(py, &[t.x, t.y, t.z])
        }),
    )
}

/// A list of arrays.
pub fn list_out<'py, T: IntoPyObject<'py>>(
    py: Python<'py>,
    items: impl IntoIterator<Item = T>,
) -> PyResult<Bound<'py, PyList>> {
    PyList::new(py, items)
}

/// A JSON value as Python objects (dicts, lists, floats, ints, strings, None).
pub fn json_to_py<'py>(py: Python<'py>, value: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    use serde_json::Value;
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any()
            }
        }
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(json_to_py(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (k, v) in map {
                dict.set_item(k, json_to_py(py, v)?)?;
            }
            dict.into_any()
        }
    })
}
