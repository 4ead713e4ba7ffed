//! `stereo_calibrate`: `calib_stereo::calibrate_stereo` with cv2.stereoCalibrate's results.

use crate::calibration_error;
use crate::convert::{self, column_out, flat_out, mat3_out, row_out};
use crate::options::{self, Common};
use crate::single::view_names;
use calib_core::result::CameraEstimate;
use calib_single::View;
use calib_stereo::{
    RigInit, StereoCalibration, StereoObservations, StereoOptions, StereoPair, calibrate_stereo,
};
use camera_model::{CameraModel, RotationKind};
use numpy::{PyArray1, PyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};

/// The positional arguments of `stereo_calibrate`, for the message about cv2's order.
const STEREO_SIGNATURE: &str = "stereo_calibrate(object_points, image_points1, image_points2, image_size, K1=None, D1=None, K2=None, D2=None, *, ...)";

/// Calibrates a stereo pair from simultaneous views of a planar board, like
/// ``cv2.stereoCalibrate`` but estimating everything by default (both cameras, every pair's
/// board pose and the rig ``X2 = R X1 + T``).
///
/// ``object_points``: one (N, 3) array per pair; ``image_points1`` / ``image_points2``: the
/// first (left) and second (right) camera's pixels of those points, (N, 2) or (N, 1, 2) per
/// pair. ``image_size``: (width, height) of both cameras (``image_size2`` if the second differs).
///
/// ``K1``, ``D1``, ``K2``, ``D2``: starting camera matrices and coefficients (``None``: each
/// camera is first calibrated alone). ``fix_intrinsics`` holds both cameras' intrinsics and
/// coefficients (cv2's ``CALIB_FIX_INTRINSIC``): at ``K``/``D`` when given, else at the camera's
/// own calibration; ``fix_intrinsics1`` / ``fix_intrinsics2`` hold one. ``model`` / ``model2``,
/// ``fix`` / ``fix2`` as in :func:`calibrate_camera` (the second camera defaults to the
/// first's; without ``fix2``, ``fix`` holds each coefficient in the camera(s) whose model has
/// it, as ``calib stereo --fix`` does). ``same_focal_length``: both cameras share fx, fy. ``R``, ``T``: a starting rig
/// (rotation matrix or vector). ``rotation`` defaults to ``"so3"`` here (as for
/// :func:`calibrate_rig`; ``"euler"`` for :func:`calibrate_camera`): Euler angles are singular
/// where the second camera turns 90 degrees about y from the first.
///
/// ``bootstrap``: also estimate the standard deviations by a pair bootstrap of that many
/// resamples (10 to 10000; about as many stereo calibrations): ``bootstrap_std1``,
/// ``bootstrap_std2``, ``bootstrap_rig_std``, ``bootstrap_baseline_std``, and a
/// ``bootstrap-spread`` warning where they exceed the linearized ones three times. Worth it for
/// ``rational8`` and ``thin-prism12``, whose linearized principal-point and rig-rotation sigmas
/// are several times too small (``calib stereo --bootstrap N``, docs/calib-stereo.md).
///
/// Returns a :class:`StereoCalibration`, which unpacks as
/// ``rms, K1, D1, K2, D2, R, T, E, F``. Raises :class:`CalibrationError` naming the pair and
/// camera. The GIL is released while it runs.
#[pyfunction]
// The text signature spells rig_init's default out (pyo3 shows `...` for a String default).
#[pyo3(signature = (
    object_points, image_points1, image_points2, image_size, K1=None, D1=None, K2=None, D2=None,
    *, model=None, model2=None, fix=None, fix2=None, image_size2=None, fix_intrinsics=false,
    fix_intrinsics1=false, fix_intrinsics2=false, same_focal_length=false, R=None, T=None,
    rig_init="least-squares".to_string(), reject_outliers=false, outlier_threshold=5.0, loss=None,
    loss_scale=1.0, rotation=None, skip_bad_pairs=false, max_iterations=500, threads=0, names=None,
    bootstrap=None
),
    text_signature = "(object_points, image_points1, image_points2, image_size, K1=None, D1=None, K2=None, D2=None, *, model=None, model2=None, fix=None, fix2=None, image_size2=None, fix_intrinsics=False, fix_intrinsics1=False, fix_intrinsics2=False, same_focal_length=False, R=None, T=None, rig_init='least-squares', reject_outliers=False, outlier_threshold=5.0, loss=None, loss_scale=1.0, rotation=None, skip_bad_pairs=False, max_iterations=500, threads=0, names=None, bootstrap=None)"
)]
#[allow(non_snake_case, clippy::too_many_arguments)]
fn stereo_calibrate(
    py: Python<'_>,
    object_points: &Bound<'_, PyAny>,
    image_points1: &Bound<'_, PyAny>,
    image_points2: &Bound<'_, PyAny>,
    image_size: &Bound<'_, PyAny>,
    K1: Option<&Bound<'_, PyAny>>,
    D1: Option<&Bound<'_, PyAny>>,
    K2: Option<&Bound<'_, PyAny>>,
    D2: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::model)] model: Option<String>,
    #[pyo3(from_py_with = crate::args::model2)] model2: Option<String>,
    fix: Option<&Bound<'_, PyAny>>,
    fix2: Option<&Bound<'_, PyAny>>,
    image_size2: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::fix_intrinsics)] fix_intrinsics: bool,
    #[pyo3(from_py_with = crate::args::fix_intrinsics1)] fix_intrinsics1: bool,
    #[pyo3(from_py_with = crate::args::fix_intrinsics2)] fix_intrinsics2: bool,
    #[pyo3(from_py_with = crate::args::same_focal_length)] same_focal_length: bool,
    R: Option<&Bound<'_, PyAny>>,
    T: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::rig_init)] rig_init: String,
    #[pyo3(from_py_with = crate::args::reject_outliers)] reject_outliers: bool,
    #[pyo3(from_py_with = crate::args::outlier_threshold)] outlier_threshold: f64,
    #[pyo3(from_py_with = crate::args::loss)] loss: Option<String>,
    #[pyo3(from_py_with = crate::args::loss_scale)] loss_scale: f64,
    #[pyo3(from_py_with = crate::args::rotation)] rotation: Option<String>,
    #[pyo3(from_py_with = crate::args::skip_bad_pairs)] skip_bad_pairs: bool,
    #[pyo3(from_py_with = crate::args::max_iterations)] max_iterations: i64,
    #[pyo3(from_py_with = crate::args::threads)] threads: i64,
    names: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::bootstrap)] bootstrap: Option<i64>,
) -> PyResult<StereoCalibrationResult> {
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
    // First, so that cv2's positional order (a camera matrix where the image size belongs) is
    // named before the camera matrices are read in the wrong places.
    let size = convert::image_size(image_size, "image_size").map_err(|e| {
        let matrix_like = convert::as_array(image_size, "image_size")
            .is_ok_and(|a| a.ndim() == 2 || a.len() > 2);
        if matrix_like {
            PyValueError::new_err(format!(
                "{}; was this called in cv2.stereoCalibrate's order (K1, D1, K2, D2 before the image size)? calib's order differs: {STEREO_SIGNATURE}",
                e.value(image_size.py())
            ))
        } else {
            e
        }
    })?;
    // Without `model` / `model2` the number of coefficients in D1 / D2 decides (cv2's 5 are
    // brown-conrady5); the second camera otherwise follows the first.
    let model1 = options::model_for_dist(
        model.as_deref(),
        "model",
        options::coefficients(D1, "D1")?.as_deref(),
        "D1",
        CameraModel::default(),
    )?;
    let model2 = options::model_for_dist(
        model2.as_deref(),
        "model2",
        options::coefficients(D2, "D2")?.as_deref(),
        "D2",
        model1,
    )?;
    let fix1 = options::fix_names(fix, "fix")?;
    let (fix1, fix2) = match fix2.filter(|f| !f.is_none()) {
        Some(f) => (fix1, options::fix_names(Some(f), "fix2")?),
        // One list for both, as `calib stereo --fix`: flags for both cameras, each coefficient
        // in the camera(s) whose model has it.
        None => {
            let is_flag = options::is_fix_flag;
            let has = |m: CameraModel, n: &str| m.distortion_names().contains(&n);
            if let Some(unknown) = fix1
                .iter()
                .find(|n| !is_flag(n) && !has(model1, n) && !has(model2, n))
            {
                return Err(PyValueError::new_err(format!(
                    "fix: neither model ({model1}, {model2}) has a coefficient '{unknown}', and it is not one of {}",
                    options::FIX_FLAGS.join(", ")
                )));
            }
            let keep = |m: CameraModel| -> Vec<String> {
                fix1.iter()
                    .filter(|n| is_flag(n) || has(m, n))
                    .cloned()
                    .collect()
            };
            (keep(model1), keep(model2))
        }
    };
    options::check_tangential(&[fix1.clone(), fix2.clone()].concat(), &[model1, model2])?;
    let mut left = options::camera_options(model1, &fix1, K1, D1, &common, "1")?;
    let mut right = options::camera_options(model2, &fix2, K2, D2, &common, "2")?;
    // cv2's CALIB_FIX_INTRINSIC with a given camera matrix holds exactly that camera (and the
    // given coefficients, zero if none): hold them in the single-camera stage too. Without a
    // camera matrix the camera is held at its single-camera estimate.
    let hold_given =
        |o: &mut calib_core::CalibrationOptions, fixed: bool, k: Option<&Bound<'_, PyAny>>| {
            if fixed && k.is_some_and(|k| !k.is_none()) {
                o.fix_focal_length = true;
                o.fix_principal_point = true;
                o.fixed_distortion = (0..o.model.num_distortion_params()).collect();
            }
        };
    hold_given(&mut left, fix_intrinsics || fix_intrinsics1, K1);
    hold_given(&mut right, fix_intrinsics || fix_intrinsics2, K2);
    let mut opts = StereoOptions::default();
    opts.solver = left.solver.clone();
    opts.rotation = common.rotation(RotationKind::So3)?;
    opts.outliers = common.outliers()?;
    opts.loss = common.loss()?;
    opts.skip_bad_pairs = skip_bad_pairs;
    opts.left = left;
    opts.right = right;
    opts.fix_left_intrinsics = fix_intrinsics || fix_intrinsics1;
    opts.fix_right_intrinsics = fix_intrinsics || fix_intrinsics2;
    opts.same_focal_length = same_focal_length;
    opts.rig_init = match rig_init.as_str() {
        "least-squares" => RigInit::LeastSquares,
        "median" => RigInit::Median,
        other => {
            return Err(PyValueError::new_err(format!(
                "rig_init: expected 'least-squares' or 'median', got '{other}'"
            )));
        }
    };
    opts.rig_guess = match (R.filter(|r| !r.is_none()), T.filter(|t| !t.is_none())) {
        (Some(r), Some(t)) => Some(convert::pose(r, t, "R", "T")?),
        (None, None) => None,
        _ => {
            return Err(PyValueError::new_err(
                "R, T: give both (a starting rig) or neither",
            ));
        }
    };

    let given_names = names.is_some_and(|n| !n.is_none());
    let objects = convert::view_list(object_points, "object_points")?;
    let left_images = convert::view_list(image_points1, "image_points1")?;
    let right_images = convert::view_list(image_points2, "image_points2")?;
    convert::check_same_length(
        objects.len(),
        "object_points",
        left_images.len(),
        "image_points1",
    )?;
    convert::check_same_length(
        objects.len(),
        "object_points",
        right_images.len(),
        "image_points2",
    )?;
    let names = view_names(names, objects.len(), "pair")?;
    let given_names = given_names.then(|| names.clone());
    let mut pairs = Vec::with_capacity(objects.len());
    for (i, name) in names.into_iter().enumerate() {
        let object = convert::points3(&objects[i], &format!("object_points[{i}]"))?;
        pairs.push(StereoPair {
            left: View {
                name: format!("{name} left"),
                object_points: object.clone(),
                image_points: convert::points2(&left_images[i], &format!("image_points1[{i}]"))?,
            },
            right: View {
                name: format!("{name} right"),
                object_points: object,
                image_points: convert::points2(&right_images[i], &format!("image_points2[{i}]"))?,
            },
        });
    }
    let size2 = match image_size2.filter(|s| !s.is_none()) {
        Some(s) => Some(convert::image_size(s, "image_size2")?),
        None => None,
    };
    let observations = StereoObservations {
        image_size: Some(size),
        right_image_size: size2,
        pairs,
    };
    let result = py
        .detach(|| {
            let mut result = calibrate_stereo(&observations, &opts)?;
            if let Some(resamples) = resamples {
                let settings = calib_stereo::BootstrapOptions {
                    resamples,
                    ..Default::default()
                };
                calib_stereo::add_bootstrap(&mut result, &observations, &opts, &settings)?;
            }
            Ok::<_, calib_stereo::StereoError>(result)
        })
        .map_err(|e| {
            calibration_error(crate::single::with_view_name(
                e.to_string(),
                "pair",
                given_names.as_deref(),
            ))
        })?;
    crate::emit_warnings(py, &result.warnings)?;
    Ok(StereoCalibrationResult { inner: result })
}

/// `[fx, fy, cx, cy, k...]` standard deviations of a camera.
pub fn camera_std(c: &CameraEstimate) -> Vec<f64> {
    let mut v = c.intrinsics_std.to_vec();
    v.extend_from_slice(&c.distortion_std);
    v
}

/// The result of :func:`stereo_calibrate`. Unpacks like cv2's result:
/// ``rms, K1, D1, K2, D2, R, T, E, F = calib.stereo_calibrate(...)``.
#[pyclass(module = "calib", frozen, name = "StereoCalibration")]
pub struct StereoCalibrationResult {
    pub inner: StereoCalibration,
}

impl StereoCalibrationResult {
    fn tuple<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(
            py,
            [
                self.inner.rms.into_pyobject(py)?.into_any(),
                self.k1(py).into_any(),
                self.d1(py).into_any(),
                self.k2(py).into_any(),
                self.d2(py).into_any(),
                self.r(py).into_any(),
                self.t(py).into_any(),
                self.e(py).into_any(),
                self.f(py).into_any(),
            ],
        )
    }
}

result_object_methods!(
    StereoCalibrationResult,
    StereoCalibration,
    9,
    "The result as JSON text, the ``calib-stereo-result`` format of docs/formats.md (what ``calib stereo -o`` writes)."
);

#[pymethods]
impl StereoCalibrationResult {
    /// RMS reprojection error over the used points of both cameras, pixels.
    #[getter]
    fn rms(&self) -> f64 {
        self.inner.rms
    }

    /// First (left) camera matrix, (3, 3).
    #[getter(K1)]
    fn k1<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat3_out(py, &self.inner.left.camera.matrix())
    }

    /// First camera's distortion coefficients, (1, N).
    #[getter(D1)]
    fn d1<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        row_out(py, &self.inner.left.camera.distortion)
    }

    /// Second (right) camera matrix, (3, 3).
    #[getter(K2)]
    fn k2<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat3_out(py, &self.inner.right.camera.matrix())
    }

    /// Second camera's distortion coefficients, (1, N).
    #[getter(D2)]
    fn d2<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        row_out(py, &self.inner.right.camera.distortion)
    }

    /// Where each camera's lens model is one-to-one: (left, right) dicts as
    /// ``CameraCalibration.validity``.
    #[getter]
    fn validity<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(
        Bound<'py, pyo3::types::PyDict>,
        Bound<'py, pyo3::types::PyDict>,
    )> {
        let (l, r) = (&self.inner.left, &self.inner.right);
        Ok((
            crate::validity_out(py, &l.camera, l.image_size)?,
            crate::validity_out(py, &r.camera, r.image_size)?,
        ))
    }

    /// Rotation from the first camera to the second: ``X2 = R X1 + T``, (3, 3).
    #[getter(R)]
    fn r<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat3_out(py, &self.inner.rig.rotation)
    }

    /// Translation from the first camera to the second, (3, 1), board units.
    #[getter(T)]
    fn t<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        column_out(py, self.inner.rig.translation.as_slice())
    }

    /// Essential matrix ``[T]x R``, (3, 3).
    #[getter(E)]
    fn e<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat3_out(py, &self.inner.essential)
    }

    /// Fundamental matrix, (3, 3), scaled so that F[2, 2] = 1 when possible.
    #[getter(F)]
    fn f<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        mat3_out(py, &self.inner.fundamental)
    }

    /// Standard deviations of the first camera's fx, fy, cx, cy and coefficients, (4 + N,).
    #[getter]
    fn std1<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        flat_out(py, &camera_std(&self.inner.left))
    }

    /// Standard deviations of the second camera's parameters, (4 + N,).
    #[getter]
    fn std2<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        flat_out(py, &camera_std(&self.inner.right))
    }

    /// The rig's parameters ``[rotation (3), T (3)]`` in the ``rotation`` parameterization, (6,).
    #[getter]
    fn rig_params<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        flat_out(py, &self.inner.rig_params)
    }

    /// Standard deviations of ``rig_params`` (radians, board units), (6,).
    #[getter]
    fn rig_std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        flat_out(py, &self.inner.rig_std)
    }

    /// The pair bootstrap's standard deviations of the first camera in ``std1``'s order, or
    /// ``None`` without ``bootstrap=N``: each parameter's spread over N stereo calibrations of
    /// resampled pairs, about the estimate (docs/calib-stereo.md).
    #[getter]
    fn bootstrap_std1<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner.bootstrap.as_ref().map(|b| {
            let mut v = b.left.intrinsics_std.to_vec();
            v.extend_from_slice(&b.left.distortion_std);
            flat_out(py, &v)
        })
    }

    /// The pair bootstrap's standard deviations of the second camera in ``std2``'s order, or
    /// ``None`` without ``bootstrap=N``.
    #[getter]
    fn bootstrap_std2<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner.bootstrap.as_ref().map(|b| {
            let mut v = b.right.intrinsics_std.to_vec();
            v.extend_from_slice(&b.right.distortion_std);
            flat_out(py, &v)
        })
    }

    /// The pair bootstrap's standard deviations of the rig's six parameters in ``rig_std``'s
    /// order and units (radians, board units), or ``None`` without ``bootstrap=N``.
    #[getter]
    fn bootstrap_rig_std<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner
            .bootstrap
            .as_ref()
            .map(|b| flat_out(py, &b.rig_std))
    }

    /// The pair bootstrap's standard deviation of the baseline ``|T|`` (board units), or
    /// ``None`` without ``bootstrap=N``.
    #[getter]
    fn bootstrap_baseline_std(&self) -> Option<f64> {
        self.inner.bootstrap.as_ref().map(|b| b.baseline_std)
    }

    /// ``|T|``, board units.
    #[getter]
    fn baseline(&self) -> f64 {
        self.inner.baseline
    }

    /// Rotation parameterization of ``rig_params``.
    #[getter]
    fn rotation(&self) -> &'static str {
        self.inner.rotation.name()
    }

    /// Board-to-first-camera rotations (Rodrigues), one (3, 1) array per used pair.
    #[getter]
    fn rvecs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::rvecs_out(py, self.inner.pairs.iter().map(|p| &p.left_pose))
    }

    /// Board-to-first-camera translations, one (3, 1) array per used pair.
    #[getter]
    fn tvecs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::tvecs_out(py, self.inner.pairs.iter().map(|p| &p.left_pose))
    }

    /// RMS of each used pair's first and second view, pixels, (pairs, 2) (cv2's
    /// ``perViewErrors``).
    #[getter]
    fn per_view_rms<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let rows: Vec<Vec<f64>> = self
            .inner
            .pairs
            .iter()
            .map(|p| vec![p.rms_left, p.rms_right])
            .collect();
        Ok(PyArray2::from_vec2(py, &rows).unwrap_or_else(|_| PyArray2::zeros(py, [0, 2], false)))
    }

    /// Input index of each used pair.
    #[getter]
    fn pair_indices(&self) -> Vec<usize> {
        self.inner.pairs.iter().map(|p| p.index).collect()
    }

    /// Pairs left out, as (input index, reason).
    #[getter]
    fn skipped_pairs(&self) -> Vec<(usize, String)> {
        self.inner
            .skipped_pairs
            .iter()
            .map(|s| (s.index, s.reason.clone()))
            .collect()
    }

    /// Lens models of the two cameras.
    #[getter]
    fn models(&self) -> (&'static str, &'static str) {
        (
            self.inner.left.camera.model.name(),
            self.inner.right.camera.model.name(),
        )
    }

    /// Number of points rejected as outliers.
    #[getter]
    fn num_rejected(&self) -> usize {
        self.inner.num_rejected
    }

    fn __repr__(&self) -> String {
        format!(
            "StereoCalibration(models=({:?}, {:?}), rms={:.5}, baseline={:.4}, pairs={}, warnings={})",
            self.inner.left.camera.model.name(),
            self.inner.right.camera.model.name(),
            self.inner.rms,
            self.inner.baseline,
            self.inner.pairs.len(),
            self.inner.warnings.len()
        )
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(stereo_calibrate, m)?)?;
    m.add_class::<StereoCalibrationResult>()?;
    Ok(())
}
