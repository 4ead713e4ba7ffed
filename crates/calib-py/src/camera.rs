//! `undistort_points` (`camera_model::AnyCamera`'s inverse projection) and the model table.

use crate::convert;
use crate::options;
use camera_model::{AnyCamera, CameraModel, UndistortOptions};
use nalgebra::{Matrix3, Vector2, Vector3};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// The model a coefficient vector of `n` values implies (cv2's convention; 4 is Brown-Conrady,
/// so a fisheye camera must name its model).
pub(crate) fn model_for(n: usize) -> PyResult<CameraModel> {
    CameraModel::ALL
        .into_iter()
        .find(|m| !m.is_fisheye() && m.num_distortion_params() == n)
        .ok_or_else(|| {
            PyValueError::new_err(format!(
                "dist: {n} coefficients match no pinhole model (4, 5, 8 or 12); give model="
            ))
        })
}

/// Undistorts pixels, like ``cv2.undistortPoints``: the ideal normalized image coordinates
/// ``(x / z, y / z)`` of the rays through the pixels; with ``R`` (3x3 rotation, e.g. from
/// rectification) the rays are rotated first, and with ``P`` (3x3 or 3x4; its left 3x3 part is
/// used) they are projected again to pixels.
///
/// ``points``: (N, 2), (N, 1, 2) or (1, N, 2), float32 or float64; the result has the same shape,
/// float64. ``K``, ``dist``: the camera matrix and coefficients (OpenCV's order). ``model``: the
/// lens model; ``None`` infers it from the number of coefficients (4 brown-conrady4, 5
/// brown-conrady5, 8 rational8, 12 thin-prism12); a fisheye camera needs
/// ``model="kannala-brandt4"``. Pixels where the model cannot be inverted (far outside the
/// calibrated area, or behind a fisheye camera) give NaN.
#[pyfunction]
#[pyo3(signature = (points, K, dist, *, model=None, R=None, P=None))]
#[allow(non_snake_case)]
fn undistort_points<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    K: &Bound<'py, PyAny>,
    dist: &Bound<'py, PyAny>,
    model: Option<&str>,
    R: Option<&Bound<'py, PyAny>>,
    P: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let coefficients = convert::vector(dist, "dist")?;
    let model = match model {
        Some(name) => options::model(Some(name), "model")?,
        None => model_for(coefficients.len())?,
    };
    let intrinsics = convert::intrinsics_from_k(K, "K")?;
    let camera = AnyCamera::new(model, intrinsics, coefficients)
        .map_err(|e| PyValueError::new_err(format!("dist: {e}")))?;
    let mut map = Matrix3::identity();
    if let Some(r) = R.filter(|r| !r.is_none()) {
        map = convert::matrix3(r, "R")?;
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

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(undistort_points, m)?)?;
    let models = PyDict::new(m.py());
    for model in CameraModel::ALL {
        models.set_item(model.name(), model.distortion_names().to_vec())?;
    }
    m.add("MODELS", models)?;
    Ok(())
}
