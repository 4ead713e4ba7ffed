//! `calibrate_camera`: `calib_single::calibrate` with cv2.calibrateCamera's arguments and results.

use crate::calibration_error;
use crate::convert::{self, flat_out, mat3_out, row_out};
use crate::options::{self, Common};
use calib_single::{BootstrapOptions, Calibration, Observations, View, add_bootstrap, calibrate};
use camera_model::CameraModel;
use numpy::{PyArray1, PyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};

/// The views of one camera from per-view lists of board points and pixels.
pub fn views(
    object_points: &Bound<'_, PyAny>,
    image_points: &Bound<'_, PyAny>,
    names: Option<&Bound<'_, PyAny>>,
    obj_what: &str,
    img_what: &str,
) -> PyResult<Vec<View>> {
    let objects = convert::view_list(object_points, obj_what)?;
    let images = convert::view_list(image_points, img_what)?;
    convert::check_same_length(objects.len(), obj_what, images.len(), img_what)?;
    let names = view_names(names, objects.len(), "view")?;
    objects
        .iter()
        .zip(&images)
        .zip(names)
        .enumerate()
        .map(|(i, ((o, p), name))| {
            Ok(View {
                name,
                object_points: convert::points3(o, &format!("{obj_what}[{i}]"))?,
                image_points: convert::points2(p, &format!("{img_what}[{i}]"))?,
            })
        })
        .collect()
}

/// A crate's error message that starts with `"{what} {i}"` (e.g. "view 3, point 5: ...") with the
/// name the caller gave that view added: "view 3 ('left4.jpg'), point 5: ...". Other messages
/// are unchanged.
pub fn with_view_name(message: String, what: &str, names: Option<&[String]>) -> String {
    let Some(names) = names else {
        return message;
    };
    let Some(rest) = message.strip_prefix(what).and_then(|r| r.strip_prefix(' ')) else {
        return message;
    };
    let digits = rest.chars().take_while(|c| c.is_ascii_digit()).count();
    if rest[digits..].starts_with(" (") {
        // Named already (the engine's `view 3 (img03.png)`).
        return message;
    }
    match rest[..digits]
        .parse::<usize>()
        .ok()
        .and_then(|i| names.get(i))
    {
        Some(name) => format!("{what} {} ('{name}'){}", &rest[..digits], &rest[digits..]),
        None => message,
    }
}

/// `names` (a list of `n` strings) or "view 0", "view 1", ...
pub fn view_names(names: Option<&Bound<'_, PyAny>>, n: usize, what: &str) -> PyResult<Vec<String>> {
    match names.filter(|x| !x.is_none()) {
        None => Ok((0..n).map(|i| format!("{what} {i}")).collect()),
        Some(names) => {
            let names: Vec<String> = names.extract().map_err(|_| {
                pyo3::exceptions::PyTypeError::new_err("names: expected a list of strings")
            })?;
            if names.len() != n {
                return Err(PyValueError::new_err(format!(
                    "names: {} names for {n} views",
                    names.len()
                )));
            }
            Ok(names)
        }
    }
}

/// Calibrates one camera from views of a planar board, like ``cv2.calibrateCamera``.
///
/// ``object_points``: one array per view of board points, shape (N, 3) or (N, 1, 3), Z = 0, in
/// any length unit (the translations come out in it). ``image_points``: one array per view of
/// pixels, shape (N, 2) or (N, 1, 2), same order, in OpenCV's pixel convention (the centre of the
/// first pixel is (0, 0), x to the right, y down). float32 or float64 (integers are converted,
/// longdouble rounded to float64; float16, whose 11 significant bits round pixels above 2048 to
/// whole pixels, is a ``TypeError``, as in cv2).
/// ``image_size``: (width, height) in pixels.
///
/// ``model``: "brown-conrady4" (k1 k2 p1 p2, the default), "brown-conrady5" (+k3, OpenCV's
/// default model), "rational8", "thin-prism12" or "kannala-brandt4" (fisheye).
/// ``fix``: names to hold: "principal_point", "focal_length", "aspect_ratio", "tangential"
/// (p1 = p2 = 0) and the model's coefficient names ("k3", ...), held at their guess (zero).
/// ``model`` and ``fix`` accept ``None``, so cv2's ``calibrateCamera(obj, img, size, None, None)``
/// works unchanged.
///
/// ``K`` and ``dist``: start from this camera matrix and these coefficients instead of the
/// closed-form guess; without ``model`` the number of coefficients picks the model (4
/// brown-conrady4, 5 brown-conrady5, 8 rational8, 12 thin-prism12), so cv2's (1, 5) array works
/// as it is. ``reject_outliers``: drop points far beyond the noise (``outlier_threshold`` robust
/// sigmas, at least 2) and solve again; off by default, so that every point is fitted as cv2
/// does. ``loss``: ``None`` (least squares), ``"huber"`` or ``"cauchy"``, robust beyond
/// ``loss_scale`` pixels. ``rotation``: the pose parameterization during the optimization,
/// ``"euler"`` (default), ``"axis-angle"`` or ``"so3"`` (``pose_std`` is given in it). ``max_iterations``: Levenberg-Marquardt iterations at most
/// (default 500). ``skip_bad_views``: leave out views that cannot be used (too few points,
/// degenerate) and list them in ``skipped_views`` instead of raising. ``drop_duplicate_views``:
/// leave out repeated views (with a warning). ``compute_std``: compute the standard deviations
/// (``std``, ``pose_std``; all zero with ``False``, which is slightly faster). ``names``: one
/// string per view (file names, say), used in messages, warnings and ``to_json()``.
/// ``threads``: 0 uses every core; the result does not depend on it. ``bootstrap``: also
/// estimate the standard deviations by a view bootstrap of that many resamples (10 to 10000;
/// about as many calibrations): ``bootstrap_std``, and a ``bootstrap-spread`` warning where they
/// exceed the linearized ``std`` three times. Worth it for "rational8" and "thin-prism12", whose
/// linearized principal-point sigmas are several times too small (``calib single --bootstrap N``,
/// docs/camera-model.md).
///
/// Returns a :class:`CameraCalibration`, which unpacks as ``rms, K, dist, rvecs, tvecs``:
/// ``rvecs`` / ``tvecs`` are the board-to-camera poses as cv2's (``X_cam = R(rvec) X_board +
/// tvec``, Rodrigues vectors, translations in the board's unit), RMS in pixels. Each warning of
/// the result is also emitted with ``warnings.warn`` as a :class:`CalibrationWarning`.
/// Raises :class:`CalibrationError` with the crate's message (naming the view and point) when the
/// data cannot be calibrated. The GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (
    object_points, image_points, image_size, model=None, fix=None, *, K=None, dist=None,
    reject_outliers=false, outlier_threshold=5.0, loss=None, loss_scale=1.0, rotation=None,
    skip_bad_views=false, drop_duplicate_views=false, compute_std=true, max_iterations=500,
    threads=0, names=None, bootstrap=None
))]
#[allow(non_snake_case, clippy::too_many_arguments)]
fn calibrate_camera(
    py: Python<'_>,
    object_points: &Bound<'_, PyAny>,
    image_points: &Bound<'_, PyAny>,
    image_size: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = crate::args::model)] model: Option<String>,
    fix: Option<&Bound<'_, PyAny>>,
    K: Option<&Bound<'_, PyAny>>,
    dist: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::reject_outliers)] reject_outliers: bool,
    #[pyo3(from_py_with = crate::args::outlier_threshold)] outlier_threshold: f64,
    #[pyo3(from_py_with = crate::args::loss)] loss: Option<String>,
    #[pyo3(from_py_with = crate::args::loss_scale)] loss_scale: f64,
    #[pyo3(from_py_with = crate::args::rotation)] rotation: Option<String>,
    #[pyo3(from_py_with = crate::args::skip_bad_views)] skip_bad_views: bool,
    #[pyo3(from_py_with = crate::args::drop_duplicate_views)] drop_duplicate_views: bool,
    #[pyo3(from_py_with = crate::args::compute_std)] compute_std: bool,
    #[pyo3(from_py_with = crate::args::max_iterations)] max_iterations: i64,
    #[pyo3(from_py_with = crate::args::threads)] threads: i64,
    names: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::bootstrap)] bootstrap: Option<i64>,
) -> PyResult<CameraCalibration> {
    let resamples = bootstrap
        .map(|n| options::count(n, "bootstrap", 10, 10_000))
        .transpose()?;
    let common = Common {
        reject_outliers,
        outlier_threshold,
        loss,
        loss_scale,
        rotation,
        max_iterations,
        threads,
    };
    let model = options::model_for_dist(
        model.as_deref(),
        "model",
        options::coefficients(dist, "dist")?.as_deref(),
        "dist",
        CameraModel::default(),
    )?;
    let fix = options::fix_names(fix, "fix")?;
    options::check_tangential(&fix, &[model])?;
    let mut opts = options::camera_options(model, &fix, K, dist, &common, "")?;
    opts.skip_bad_views = skip_bad_views;
    opts.drop_duplicate_views = drop_duplicate_views;
    opts.compute_uncertainty = compute_std;
    let size = convert::image_size(image_size, "image_size")?;
    let observations = Observations {
        image_size: Some(size),
        views: views(
            object_points,
            image_points,
            names,
            "object_points",
            "image_points",
        )?,
    };
    let given_names: Option<Vec<String>> = names
        .is_some_and(|n| !n.is_none())
        .then(|| observations.views.iter().map(|v| v.name.clone()).collect());
    let result = py
        .detach(|| {
            let mut result = calibrate(&observations, &opts)?;
            if let Some(resamples) = resamples {
                let settings = BootstrapOptions {
                    resamples,
                    ..BootstrapOptions::default()
                };
                add_bootstrap(&mut result, &observations, &opts, &settings)?;
            }
            Ok::<_, calib_core::CalibrationError>(result)
        })
        .map_err(|e| {
            calibration_error(with_view_name(
                e.to_string(),
                "view",
                given_names.as_deref(),
            ))
        })?;
    crate::emit_warnings(py, &result.warnings)?;
    Ok(CameraCalibration { inner: result })
}

/// The result of :func:`calibrate_camera`. Unpacks like cv2's result:
/// ``rms, K, dist, rvecs, tvecs = calib.calibrate_camera(...)``.
///
/// ``rvecs``, ``tvecs`` and ``per_view_rms`` follow ``view_indices`` (every input view unless
/// views were skipped or dropped as duplicates, which the warnings say).
#[pyclass(module = "calib", frozen)]
pub struct CameraCalibration {
    pub inner: Calibration,
}

impl CameraCalibration {
    fn tuple<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(
            py,
            [
                self.rms().into_pyobject(py)?.into_any(),
                self.k(py).into_any(),
                self.dist(py).into_any(),
                self.rvecs(py)?.into_any(),
                self.tvecs(py)?.into_any(),
            ],
        )
    }
}

result_object_methods!(
    CameraCalibration,
    Calibration,
    5,
    "The result as JSON text, the ``calib-single-result`` format of docs/formats.md (what ``calib single -o`` writes)."
);

#[pymethods]
impl CameraCalibration {
    /// RMS reprojection error over the used points, pixels (cv2's ``retval``).
    #[getter]
    fn rms(&self) -> f64 {
        self.inner.rms
    }

    /// Camera matrix [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], shape (3, 3).
    #[getter(K)]
    fn k<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat3_out(py, &self.inner.camera.matrix())
    }

    /// Distortion coefficients in OpenCV's order for the model, shape (1, N).
    #[getter]
    fn dist<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        row_out(py, &self.inner.camera.distortion)
    }

    /// Board-to-camera rotations as Rodrigues vectors, one (3, 1) array per used view.
    #[getter]
    fn rvecs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::rvecs_out(py, self.inner.views.iter().map(|v| &v.pose))
    }

    /// Board-to-camera translations, one (3, 1) array per used view (board units).
    #[getter]
    fn tvecs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::tvecs_out(py, self.inner.views.iter().map(|v| &v.pose))
    }

    /// Standard deviations of ``param_names`` (fx, fy, cx, cy, then the coefficients), shape
    /// (4 + N,); zero for fixed parameters (cv2's ``stdDeviationsIntrinsics``).
    #[getter]
    fn std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let mut v = self.inner.intrinsics_std.to_vec();
        v.extend_from_slice(&self.inner.distortion_std);
        flat_out(py, &v)
    }

    /// The view bootstrap's standard deviations in ``std``'s order (``param_names``), or
    /// ``None`` without ``bootstrap=N``: each parameter's spread over N calibrations of resampled
    /// views, about the estimate (docs/camera-model.md).
    #[getter]
    fn bootstrap_std<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner.bootstrap.as_ref().map(|b| {
            let mut v = b.intrinsics_std.to_vec();
            v.extend_from_slice(&b.distortion_std);
            flat_out(py, &v)
        })
    }

    /// Names of the intrinsic parameters: fx, fy, cx, cy and the model's coefficients.
    #[getter]
    fn param_names(&self) -> Vec<String> {
        let mut names: Vec<String> = ["fx", "fy", "cx", "cy"].map(String::from).to_vec();
        names.extend(
            self.inner
                .camera
                .model
                .distortion_names()
                .iter()
                .map(|s| s.to_string()),
        );
        names
    }

    /// Names of the parameters held fixed.
    #[getter]
    fn fixed_parameters(&self) -> Vec<String> {
        self.inner.fixed_parameters.clone()
    }

    /// Standard deviations of each used view's pose parameters ``[rotation (3), translation (3)]``
    /// in the ``rotation`` parameterization, shape (views, 6).
    #[getter]
    fn pose_std<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows: Vec<Vec<f64>> = self
            .inner
            .views
            .iter()
            .map(|v| v.pose_std.to_vec())
            .collect();
        Ok(PyArray2::from_vec2(py, &rows).unwrap_or_else(|_| PyArray2::zeros(py, [0, 6], false)))
    }

    /// RMS reprojection error of each used view, pixels, shape (views,).
    #[getter]
    fn per_view_rms<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let v: Vec<f64> = self.inner.views.iter().map(|v| v.rms).collect();
        flat_out(py, &v)
    }

    /// Input index of each used view.
    #[getter]
    fn view_indices(&self) -> Vec<usize> {
        self.inner.views.iter().map(|v| v.index).collect()
    }

    /// Views left out, as (input index, reason).
    #[getter]
    fn skipped_views(&self) -> Vec<(usize, String)> {
        self.inner
            .skipped_views
            .iter()
            .map(|s| (s.index, s.reason.clone()))
            .collect()
    }

    /// Indices (in each used view's input arrays) of the points rejected as outliers.
    #[getter]
    fn rejected_points(&self) -> Vec<Vec<usize>> {
        self.inner
            .views
            .iter()
            .map(|v| v.rejected_points.clone())
            .collect()
    }

    /// RMS over every point, rejected outliers included, pixels.
    #[getter]
    fn rms_all_points(&self) -> f64 {
        self.inner.rms_all_points
    }

    /// Number of points used.
    #[getter]
    fn num_points(&self) -> usize {
        self.inner.num_points
    }

    /// The lens model's name.
    #[getter]
    fn model(&self) -> &'static str {
        self.inner.camera.model.name()
    }

    /// (width, height).
    #[getter]
    fn image_size(&self) -> (u32, u32) {
        (self.inner.image_size.width, self.inner.image_size.height)
    }

    /// Where the lens model is one-to-one: a dict with ``valid_radius_px`` (pixels from the
    /// principal point to the nearest fold, ``None`` if none was found), ``image_radius_px``,
    /// ``coverage`` and ``covers_image`` (docs/python.md; the ``model-invalid`` warning).
    #[getter]
    fn validity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        crate::validity_out(py, &self.inner.camera, self.inner.image_size)
    }

    /// Rotation parameterization of the poses during the optimization (of ``pose_std``).
    #[getter]
    fn rotation(&self) -> &'static str {
        self.inner.rotation.name()
    }

    fn __repr__(&self) -> String {
        let c = &self.inner.camera;
        let k = &c.intrinsics;
        format!(
            "CameraCalibration(model={:?}, rms={:.5}, fx={:.3}, fy={:.3}, cx={:.3}, cy={:.3}, views={}, warnings={})",
            c.model.name(),
            self.inner.rms,
            k.fx,
            k.fy,
            k.cx,
            k.cy,
            self.inner.views.len(),
            self.inner.warnings.len()
        )
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(calibrate_camera, m)?)?;
    m.add_class::<CameraCalibration>()?;
    Ok(())
}
