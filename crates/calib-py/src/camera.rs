//! `undistort_points` (`camera_model::AnyCamera`'s inverse projection), `project_points` (its
//! projection) and the model table.

use crate::convert;
use crate::options;
use camera_model::{AnyCamera, CameraModel, UndistortOptions};
use nalgebra::{Matrix3, Point3, Vector2, Vector3};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A camera from a camera matrix `k`, coefficients `dist` (OpenCV's order; `None` or empty: no
/// distortion, as cv2) and a model name (`None`: `fallback` if given and the count fits it, else
/// inferred from the number of coefficients, [`options::model_for_dist`]). `k_what`, `d_what` and
/// `model_what` are the arguments' names for messages.
pub(crate) fn camera(
    k: &Bound<'_, PyAny>,
    dist: Option<&Bound<'_, PyAny>>,
    model: Option<&str>,
    fallback: Option<CameraModel>,
    k_what: &str,
    d_what: &str,
    model_what: &str,
) -> PyResult<AnyCamera> {
    let coefficients = options::coefficients(dist, d_what)?.unwrap_or_default();
    // The first camera of a pair follows the count of its coefficients; with none, brown-conrady4.
    let model = options::model_for_dist(
        model,
        model_what,
        Some(&coefficients),
        d_what,
        fallback.unwrap_or_default(),
    )?;
    // cv2 accepts an empty (or None) distortion vector for "no distortion".
    let coefficients = if coefficients.is_empty() {
        vec![0.0; model.num_distortion_params()]
    } else {
        coefficients
    };
    let intrinsics = convert::intrinsics_from_k(k, k_what)?;
    AnyCamera::new(model, intrinsics, coefficients)
        .map_err(|e| PyValueError::new_err(format!("{d_what}: {e}")))
}

/// Undistorts pixels, like ``cv2.undistortPoints``: the ideal normalized image coordinates
/// ``(x / z, y / z)`` of the rays through the pixels; with ``R`` (a 3x3 rotation matrix or a
/// rotation vector, e.g. from rectification) the rays are rotated first, and with ``P`` (3x3 or
/// 3x4; its left 3x3 part is used) they are projected again to pixels.
///
/// ``points``: (N, 2), (N, 1, 2) or (1, N, 2), float32 or float64 (float16 is a ``TypeError``);
/// the result has the same shape, float64. ``K``, ``dist``: the camera matrix and coefficients (OpenCV's order; ``dist=None`` or
/// empty: no distortion, as in cv2). ``model``: the lens model; ``None`` infers it from the
/// number of coefficients (4 brown-conrady4, 5 brown-conrady5, 8 rational8, 12 thin-prism12); a
/// fisheye camera needs ``model="kannala-brandt4"``. Pixels where the model cannot be inverted
/// (far outside the calibrated area, or behind a fisheye camera) give NaN. An ``R`` that is not
/// a rotation, a ``K`` with non-positive focal lengths or a coefficient count that does not fit
/// ``model`` raise ``ValueError`` naming the argument.
#[pyfunction]
#[pyo3(signature = (points, K, dist=None, *, model=None, R=None, P=None))]
#[allow(non_snake_case)]
fn undistort_points<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    K: &Bound<'py, PyAny>,
    dist: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = crate::args::model)] model: Option<String>,
    R: Option<&Bound<'py, PyAny>>,
    P: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let camera = camera(K, dist, model.as_deref(), None, "K", "dist", "model")?;
    let model = camera.model;
    let mut map = Matrix3::identity();
    if let Some(r) = R.filter(|r| !r.is_none()) {
        map = convert::rotation(r, "R")?;
    }
    if let Some(p) = P.filter(|p| !p.is_none()) {
        let array = convert::as_f64(p, "P")?;
        let shape = array.shape().to_vec();
        if shape != [3, 3] && shape != [3, 4] {
            return Err(PyValueError::new_err(format!(
                "P: expected a 3x3 or 3x4 matrix, got shape {shape:?}"
            )));
        }
        let readonly = array.readonly();
        let v = readonly.as_array();
        map = Matrix3::from_fn(|i, j| v[[i, j]]) * map;
    }
    let shape = convert::as_array(points, "points")?.shape().to_vec();
    let pixels = convert::point_rows::<2>(points, "points")?;
    let out: Vec<f64> = py.detach(|| {
        let options = UndistortOptions::default();
        pixels
            .iter()
            .flat_map(|p| {
                let pixel = Vector2::new(p[0], p[1]);
                let n = if model.is_fisheye() {
                    camera
                        .pixel_to_ray(&pixel, &options)
                        .ok()
                        .filter(|r| r.z > 0.0)
                        .map(|r| Vector2::new(r.x / r.z, r.y / r.z))
                } else {
                    camera.undistort_pixel(&pixel, &options).ok()
                };
                let q = match n {
                    None => Vector2::new(f64::NAN, f64::NAN),
                    Some(n) if map == Matrix3::identity() => n,
                    Some(n) => {
                        let v = map * Vector3::new(n.x, n.y, 1.0);
                        Vector2::new(v.x / v.z, v.y / v.z)
                    }
                };
                [q.x, q.y]
            })
            .collect()
    });
    Ok(PyArray1::from_vec(py, out).reshape(shape)?.into_any())
}

/// Projects world points to pixels, like ``cv2.projectPoints`` (pinhole models) and
/// ``cv2.fisheye.projectPoints`` (kannala-brandt4): ``pixel = K distort(project(R X + t))`` with
/// ``R`` the rotation of ``rvec``, the pixel origin at the centre of the first pixel (OpenCV's
/// convention).
///
/// ``object_points``: (N, 3), (N, 1, 3) or (1, N, 3), float32 or float64 (float16 is a
/// ``TypeError``). ``rvec``, ``tvec``: the
/// pose world -> camera, a Rodrigues rotation vector of 3 values (a 3x3 rotation matrix is
/// accepted too) and a translation, as ``cv2.solvePnP`` and ``calibrate_camera`` return them.
/// ``K``, ``dist``: the camera matrix and coefficients (OpenCV's order; ``dist=None`` or empty: no
/// distortion). ``model``: the lens model; ``None`` infers it from the number of coefficients (4
/// brown-conrady4, 5 brown-conrady5, 8 rational8, 12 thin-prism12); a fisheye camera needs
/// ``model="kannala-brandt4"``. Returns the pixels, (N, 2) float64. A point the model cannot
/// project (behind a pinhole camera, on the optical axis behind a fisheye camera, at a pole of a
/// rational model) raises ``ValueError`` naming its index; bad shapes or values of the arguments
/// (non-finite values, a ``K`` with non-positive focal lengths, a coefficient count that does not
/// fit ``model``) raise ``ValueError`` naming the argument.
#[pyfunction]
#[pyo3(signature = (object_points, rvec, tvec, K, dist=None, model=None))]
#[allow(non_snake_case)]
fn project_points<'py>(
    py: Python<'py>,
    object_points: &Bound<'py, PyAny>,
    rvec: &Bound<'py, PyAny>,
    tvec: &Bound<'py, PyAny>,
    K: &Bound<'py, PyAny>,
    dist: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = crate::args::model)] model: Option<String>,
) -> PyResult<Bound<'py, PyAny>> {
    let rows = convert::point_rows::<3>(object_points, "object_points")?;
    if let Some(i) = rows.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(PyValueError::new_err(format!(
            "object_points[{i}]: the values must be finite, got [{}]",
            rows[i].map(convert::py_float).join(", ")
        )));
    }
    let pose = convert::pose(rvec, tvec, "rvec", "tvec")?;
    let camera = camera(K, dist, model.as_deref(), None, "K", "dist", "model")?;
    let n = rows.len();
    let pixels = py.detach(
        || -> Result<Vec<f64>, (usize, camera_model::CameraModelError)> {
            let mut out = Vec::with_capacity(2 * n);
            for (i, p) in rows.iter().enumerate() {
                let pixel = camera
                    .project(&pose, &Point3::new(p[0], p[1], p[2]))
                    .map_err(|e| (i, e))?;
                out.extend([pixel.x, pixel.y]);
            }
            Ok(out)
        },
    );
    let pixels = pixels.map_err(|(i, e)| {
        PyValueError::new_err(format!(
            "object_points[{i}]: cannot be projected by {}: {e}",
            camera.model
        ))
    })?;
    Ok(PyArray1::from_vec(py, pixels).reshape([n, 2])?.into_any())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(undistort_points, m)?)?;
    m.add_function(wrap_pyfunction!(project_points, m)?)?;
    let models = PyDict::new(m.py());
    for model in CameraModel::ALL {
        models.set_item(model.name(), model.distortion_names().to_vec())?;
    }
    m.add("MODELS", models)?;
    Ok(())
}
