//! `calibrate_rig`: `calib_rig::calibrate_rig` for N cameras from NumPy arrays.

use crate::calibration_error;
use crate::convert::{self, column_out, flat_out, mat3_out, row_out};
use crate::options::{self, Common};
use crate::stereo::camera_std;
use calib_core::View;
use calib_rig::{
    RigCalibration, RigCameraInput, RigFrame, RigObservation, RigObservations, RigOptions,
    calibrate_rig,
};
use camera_model::{AnyCamera, CameraModel, RotationKind};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString, PyTuple};

/// The camera index named by `key` (an index or one of `names`).
fn camera_key(key: &Bound<'_, PyAny>, names: &[String], what: &str) -> PyResult<usize> {
    if let Ok(s) = key.cast::<PyString>() {
        let s = s.to_cow()?;
        return names.iter().position(|n| *n == s).ok_or_else(|| {
            PyValueError::new_err(format!(
                "{what}: no camera named '{s}' (the cameras are {})",
                names.join(", ")
            ))
        });
    }
    let i: i64 = key
        .call_method0("__index__")
        .and_then(|i| i.extract())
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "{what}: a camera is an index or a name, got {}",
                convert::type_name(key)
            ))
        })?;
    usize::try_from(i)
        .ok()
        .filter(|&i| i < names.len())
        .ok_or_else(|| {
            PyValueError::new_err(format!(
                "{what}: camera {i} does not exist ({} cameras)",
                names.len()
            ))
        })
}

/// One observation: pixels (board points from the frame), or `(object_points, image_points)`.
fn observation(
    entry: &Bound<'_, PyAny>,
    frame_points: Option<&[nalgebra::Point3<f64>]>,
    camera: usize,
    frame: usize,
    name: &str,
) -> PyResult<RigObservation> {
    let what = format!("image_points[{frame}][{camera}]");
    let (object_points, pixels) = match entry.cast::<PyTuple>() {
        Ok(t) if t.len() == 2 => (
            convert::points3(&t.get_item(0)?, &format!("{what}[0] (board points)"))?,
            convert::points2(&t.get_item(1)?, &format!("{what}[1] (pixels)"))?,
        ),
        _ => {
            let object_points = frame_points.ok_or_else(|| {
                PyValueError::new_err(format!(
                    "{what}: frame {frame} has no object_points: give them, or give this observation as (object_points, image_points)"
                ))
            })?;
            (object_points.to_vec(), convert::points2(entry, &what)?)
        }
    };
    Ok(RigObservation {
        camera,
        view: View {
            name: format!("frame {frame}, camera {name}"),
            object_points,
            image_points: pixels,
        },
    })
}

/// Calibrates a rig of N cameras, each seeing the board in some of the frames.
///
/// ``image_sizes``: (width, height) of each camera; their number is the number of cameras.
/// ``object_points``: one (N, 3) array of board points per frame (``None`` where every
/// observation of the frame brings its own). ``image_points``: per frame, the cameras that saw the
/// board: a dict ``{camera: pixels}`` (camera by index or name) or a list with one entry per
/// camera (``None`` for cameras that did not see it). ``pixels`` is an (N, 2) or (N, 1, 2) array
/// matching the frame's board points, or a tuple ``(object_points, image_points)`` for a partial
/// view.
///
/// ``models``: one model name for every camera, or a list with one per camera (``None``: the
/// default). ``names``: camera names (default cam0, cam1, ...). ``reference``: the camera whose
/// frame is the rig's (index or name). ``known``: ``{camera: (K, dist)}`` for cameras whose
/// intrinsics are known and held. ``fix`` and the solver settings as in
/// :func:`calibrate_camera` (a coefficient name holds it in every camera whose model has it);
/// ``fix={camera: names}`` holds coefficients of one camera each (``fix={'fish': ['k4']}``, as
/// ``calib rig --fix fish=k4``). The rotation parameterization defaults to "so3".
///
/// Returns a :class:`RigCalibration` (unpacks as ``rms, Ks, dists, Rs, Ts``, with
/// ``X_cam = R X_ref + T``). Raises :class:`CalibrationError` naming the camera and frame. The
/// GIL is released while it runs.
#[pyfunction]
#[pyo3(name = "calibrate_rig", signature = (
    image_sizes, object_points, image_points, models=None, *, names=None, reference=None,
    known=None, fix=None, min_views=3, reject_outliers=false, outlier_threshold=5.0, loss=None,
    loss_scale=1.0, rotation=None, skip_bad_views=false, max_iterations=500, threads=0
))]
#[allow(clippy::too_many_arguments)]
fn calibrate_rig_py(
    py: Python<'_>,
    image_sizes: &Bound<'_, PyAny>,
    object_points: &Bound<'_, PyAny>,
    image_points: &Bound<'_, PyAny>,
    models: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::names)] names: Option<Vec<String>>,
    reference: Option<&Bound<'_, PyAny>>,
    known: Option<&Bound<'_, PyDict>>,
    fix: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::min_views)] min_views: i64,
    #[pyo3(from_py_with = crate::args::reject_outliers)] reject_outliers: bool,
    #[pyo3(from_py_with = crate::args::outlier_threshold)] outlier_threshold: f64,
    #[pyo3(from_py_with = crate::args::loss)] loss: Option<String>,
    #[pyo3(from_py_with = crate::args::loss_scale)] loss_scale: f64,
    #[pyo3(from_py_with = crate::args::rotation)] rotation: Option<String>,
    #[pyo3(from_py_with = crate::args::skip_bad_views)] skip_bad_views: bool,
    #[pyo3(from_py_with = crate::args::max_iterations)] max_iterations: i64,
    #[pyo3(from_py_with = crate::args::threads)] threads: i64,
) -> PyResult<RigCalibrationResult> {
    let common = Common {
        reject_outliers,
        outlier_threshold,
        loss,
        loss_scale,
        rotation,
        max_iterations,
        threads,
    };
    let sizes: Vec<_> = convert::size_list(image_sizes, "image_sizes")?
        .iter()
        .enumerate()
        .map(|(i, s)| convert::image_size(s, &format!("image_sizes[{i}]")))
        .collect::<PyResult<_>>()?;
    let n = sizes.len();
    if n == 0 {
        return Err(PyValueError::new_err("image_sizes: no cameras"));
    }
    let names = match names {
        Some(names) if names.len() != n => {
            return Err(PyValueError::new_err(format!(
                "names: {} names for {n} cameras",
                names.len()
            )));
        }
        Some(names) => names,
        None => (0..n).map(|i| format!("cam{i}")).collect(),
    };
    if let Some((c, name)) = names
        .iter()
        .enumerate()
        .find(|(c, name)| names[..*c].contains(name))
    {
        return Err(PyValueError::new_err(format!(
            "names: cameras {} and {c} are both named '{name}'",
            names.iter().position(|n| n == name).unwrap_or(0)
        )));
    }
    let mut per_camera_models: Vec<Option<CameraModel>> = match models.filter(|m| !m.is_none()) {
        None => vec![None; n],
        Some(m) if m.is_instance_of::<PyString>() => {
            vec![Some(options::model(Some(&m.extract::<String>()?), "models")?); n]
        }
        Some(m) => {
            let list: Vec<Option<String>> = m.extract().map_err(|_| {
                PyTypeError::new_err("models: expected a model name or a list of names (or None)")
            })?;
            if list.len() != n {
                return Err(PyValueError::new_err(format!(
                    "models: {} models for {n} cameras",
                    list.len()
                )));
            }
            list.iter()
                .enumerate()
                .map(|(i, m)| {
                    m.as_deref()
                        .map(|m| options::model(Some(m), &format!("models[{i}]")))
                        .transpose()
                })
                .collect::<PyResult<_>>()?
        }
    };
    // The model of the cameras without one (taken before a known camera's coefficients name its
    // model, so that they name no other camera's).
    let first = per_camera_models[0].unwrap_or_default();
    // Known cameras: a camera without a model takes the one its coefficients' count means
    // (cv2's 5 are brown-conrady5), as in `calibrate_camera`.
    let mut given: Option<Vec<Option<AnyCamera>>> = None;
    if let Some(known) = known {
        let given = given.insert(vec![None; n]);
        for (key, value) in known.iter() {
            let c = camera_key(&key, &names, "known")?;
            let what = format!("known[{}]", names[c]);
            let (k, d): (Bound<'_, PyAny>, Bound<'_, PyAny>) = value
                .extract()
                .map_err(|_| PyTypeError::new_err(format!("{what}: expected a tuple (K, dist)")))?;
            let model_what = match models.filter(|m| !m.is_none()) {
                Some(m) if !m.is_instance_of::<PyString>() => format!("models[{c}]"),
                _ => "models".to_string(),
            };
            let model = per_camera_models[c].map(|m| m.name());
            let camera = crate::camera::camera(
                &k,
                Some(&d),
                model,
                None,
                &format!("{what} K"),
                &format!("{what} dist"),
                &model_what,
            )?;
            per_camera_models[c] = Some(camera.model);
            given[c] = Some(camera);
        }
    }
    let cameras: Vec<RigCameraInput> = (0..n)
        .map(|c| RigCameraInput {
            name: names[c].clone(),
            image_size: sizes[c],
            model: per_camera_models[c],
        })
        .collect();

    let objects = convert::view_list(object_points, "object_points")?;
    let frames_in = convert::view_list(image_points, "image_points")?;
    convert::check_same_length(
        objects.len(),
        "object_points",
        frames_in.len(),
        "image_points",
    )?;
    let mut frames = Vec::with_capacity(objects.len());
    for (f, (object, entries)) in objects.iter().zip(&frames_in).enumerate() {
        let frame_points = if object.is_none() {
            None
        } else {
            Some(convert::points3(object, &format!("object_points[{f}]"))?)
        };
        let mut observations = Vec::new();
        if let Ok(dict) = entries.cast::<PyDict>() {
            for (key, value) in dict.iter() {
                let c = camera_key(&key, &names, &format!("image_points[{f}]"))?;
                if !value.is_none() {
                    observations.push(observation(
                        &value,
                        frame_points.as_deref(),
                        c,
                        f,
                        &names[c],
                    )?);
                }
            }
            observations.sort_by_key(|o| o.camera);
        } else {
            let list = convert::view_list(entries, &format!("image_points[{f}]"))
                .map_err(|_| {
                    PyTypeError::new_err(format!(
                        "image_points[{f}]: expected a dict {{camera: pixels}} or a list with one entry per camera, got {}",
                        convert::type_name(entries)
                    ))
                })?;
            if list.len() != n {
                return Err(PyValueError::new_err(format!(
                    "image_points[{f}]: {} entries for {n} cameras (use None for a camera that did not see the board, or a dict)",
                    list.len()
                )));
            }
            for (c, value) in list.iter().enumerate() {
                if !value.is_none() {
                    observations.push(observation(
                        value,
                        frame_points.as_deref(),
                        c,
                        f,
                        &names[c],
                    )?);
                }
            }
        }
        frames.push(RigFrame { observations });
    }

    // Flags ("principal_point", ...) apply to every camera, coefficient names to every camera
    // whose model has them, as `calib rig --fix`; a dict holds coefficients of one camera each,
    // as `calib rig --fix NAME=k3,k4`.
    let mut camera = options::camera_options(first, &[], None, None, &common, "")?;
    let mut hold_by_camera: Vec<Vec<String>> = vec![Vec::new(); names.len()];
    let fix = match fix.filter(|f| !f.is_none()).map(|f| f.cast::<PyDict>()) {
        Some(Ok(per_camera)) => {
            for (key, value) in per_camera.iter() {
                let c = camera_key(&key, &names, "fix")?;
                let what = format!("fix['{}']", names[c]);
                let held = options::fix_names(Some(&value), &what)?;
                if let Some(flag) = held.iter().find(|n| options::is_fix_flag(n)) {
                    return Err(PyValueError::new_err(format!(
                        "{what}: '{flag}' holds it in every camera; per camera, fix holds distortion coefficients (give flags as a list: fix=['{flag}'])"
                    )));
                }
                let model = per_camera_models[c].unwrap_or_default();
                if let Some(unknown) = held
                    .iter()
                    .find(|n| !model.distortion_names().contains(&n.as_str()))
                {
                    return Err(PyValueError::new_err(format!(
                        "{what}: the {model} model has no coefficient '{unknown}' (it has {})",
                        model.distortion_names().join(", ")
                    )));
                }
                hold_by_camera[c].extend(held);
            }
            Vec::new()
        }
        _ => options::fix_names(fix, "fix")?,
    };
    let models: Vec<CameraModel> = per_camera_models
        .iter()
        .map(|m| m.unwrap_or_default())
        .collect();
    options::check_tangential(&fix, &models)?;
    let (flags, coefficients): (Vec<String>, Vec<String>) =
        fix.into_iter().partition(|n| options::is_fix_flag(n));
    options::apply_fix(&mut camera, &flags, "fix")?;
    if let Some(unknown) = coefficients.iter().find(|n| {
        !models
            .iter()
            .any(|m| m.distortion_names().contains(&n.as_str()))
    }) {
        return Err(PyValueError::new_err(format!(
            "fix: no camera's model has a coefficient '{unknown}', and it is not one of {}",
            options::FIX_FLAGS.join(", ")
        )));
    }
    let mut opts = RigOptions::default();
    if let Some(given) = given {
        opts.given = given;
    }
    opts.hold_fixed = coefficients;
    opts.hold_fixed_by_camera = hold_by_camera;
    opts.models = per_camera_models.clone();
    camera.skip_bad_views = skip_bad_views;
    opts.solver = camera.solver.clone();
    opts.rotation = common.rotation(RotationKind::So3)?;
    opts.outliers = camera.outliers;
    opts.loss = camera.loss;
    opts.min_views = crate::options::count(min_views, "min_views", 1, 1_000_000)?;
    opts.camera = camera;
    if let Some(r) = reference.filter(|r| !r.is_none()) {
        opts.reference = camera_key(r, &names, "reference")?;
    }
    let observations = RigObservations { cameras, frames };
    let result = py
        .detach(|| calibrate_rig(&observations, &opts))
        .map_err(calibration_error)?;
    crate::emit_warnings(py, &result.warnings)?;
    Ok(RigCalibrationResult { inner: result })
}

/// The result of :func:`calibrate_rig`: every camera's intrinsics and its transform from the
/// reference camera (``X_cam = R X_ref + T``), and the board pose of every used frame in the
/// reference camera. Unpacks as ``rms, Ks, dists, Rs, Ts``.
#[pyclass(module = "calib", frozen, name = "RigCalibration")]
pub struct RigCalibrationResult {
    pub inner: RigCalibration,
}

impl RigCalibrationResult {
    fn tuple<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        PyTuple::new(
            py,
            [
                self.inner.rms.into_pyobject(py)?.into_any(),
                self.ks(py)?.into_any(),
                self.dists(py)?.into_any(),
                self.rs(py)?.into_any(),
                self.ts(py)?.into_any(),
            ],
        )
    }
}

result_object_methods!(
    RigCalibrationResult,
    RigCalibration,
    5,
    "The result as JSON text, the ``calib-rig-result`` format of docs/formats.md (what ``calib rig -o`` writes)."
);

#[pymethods]
impl RigCalibrationResult {
    /// RMS reprojection error over the used points of every camera, pixels.
    #[getter]
    fn rms(&self) -> f64 {
        self.inner.rms
    }

    /// Camera names.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inner
            .cameras
            .iter()
            .map(|c| c.estimate.name.clone())
            .collect()
    }

    /// Lens model of each camera.
    #[getter]
    fn models(&self) -> Vec<&'static str> {
        self.inner
            .cameras
            .iter()
            .map(|c| c.estimate.camera.model.name())
            .collect()
    }

    /// Where each camera's lens model is one-to-one: one dict per camera, as
    /// ``CameraCalibration.validity``.
    #[getter]
    fn validity<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, pyo3::types::PyDict>>> {
        self.inner
            .cameras
            .iter()
            .map(|c| crate::validity_out(py, &c.estimate.camera, c.estimate.image_size))
            .collect()
    }

    /// The reference camera's index.
    #[getter]
    fn reference(&self) -> usize {
        self.inner.reference
    }

    /// Camera matrices, one (3, 3) array per camera.
    #[getter(Ks)]
    fn ks<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::list_out(
            py,
            self.inner
                .cameras
                .iter()
                .map(|c| mat3_out(py, &c.estimate.camera.matrix())),
        )
    }

    /// Distortion coefficients, one (1, N) array per camera.
    #[getter]
    fn dists<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::list_out(
            py,
            self.inner
                .cameras
                .iter()
                .map(|c| row_out(py, &c.estimate.camera.distortion)),
        )
    }

    /// Rotations from the reference camera, one (3, 3) array per camera (identity for the
    /// reference).
    #[getter(Rs)]
    fn rs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::list_out(
            py,
            self.inner
                .cameras
                .iter()
                .map(|c| mat3_out(py, &c.transform.rotation)),
        )
    }

    /// Translations from the reference camera, one (3, 1) array per camera.
    #[getter(Ts)]
    fn ts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::list_out(
            py,
            self.inner
                .cameras
                .iter()
                .map(|c| column_out(py, c.transform.translation.as_slice())),
        )
    }

    /// Standard deviations of each camera's fx, fy, cx, cy and coefficients, one (4 + N,) array
    /// per camera.
    #[getter]
    fn std<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::list_out(
            py,
            self.inner
                .cameras
                .iter()
                .map(|c| flat_out(py, &camera_std(&c.estimate))),
        )
    }

    /// Standard deviations of each camera's transform parameters ``[rotation (3), T (3)]`` in
    /// the ``rotation`` parameterization, one (6,) array per camera (zero for the reference).
    #[getter]
    fn transform_std<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::list_out(
            py,
            self.inner
                .cameras
                .iter()
                .map(|c| flat_out(py, &c.transform_std)),
        )
    }

    /// RMS of each camera over its used points, pixels.
    #[getter]
    fn camera_rms(&self) -> Vec<f64> {
        self.inner.cameras.iter().map(|c| c.estimate.rms).collect()
    }

    /// Board-to-reference-camera rotations (Rodrigues), one (3, 1) array per used frame.
    #[getter]
    fn rvecs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::rvecs_out(py, self.inner.frames.iter().map(|f| &f.pose))
    }

    /// Board-to-reference-camera translations, one (3, 1) array per used frame.
    #[getter]
    fn tvecs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        convert::tvecs_out(py, self.inner.frames.iter().map(|f| &f.pose))
    }

    /// Input index of each used frame.
    #[getter]
    fn frame_indices(&self) -> Vec<usize> {
        self.inner.frames.iter().map(|f| f.index).collect()
    }

    /// Per used frame, ``{camera index: RMS in pixels}`` of the cameras that saw the board.
    #[getter]
    fn per_view_rms<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for f in &self.inner.frames {
            let d = PyDict::new(py);
            for v in &f.views {
                d.set_item(v.camera, v.rms)?;
            }
            list.append(d)?;
        }
        Ok(list)
    }

    /// Parent of each camera in the start's spanning tree (``None`` for the reference).
    #[getter]
    fn tree_parent(&self) -> Vec<Option<usize>> {
        self.inner.tree_parent.clone()
    }

    /// Rotation parameterization of ``transform_std``.
    #[getter]
    fn rotation(&self) -> &'static str {
        self.inner.rotation.name()
    }

    /// Number of points rejected as outliers.
    #[getter]
    fn num_rejected(&self) -> usize {
        self.inner.num_rejected
    }

    fn __repr__(&self) -> String {
        format!(
            "RigCalibration(cameras={}, rms={:.5}, frames={}, warnings={})",
            self.inner.cameras.len(),
            self.inner.rms,
            self.inner.frames.len(),
            self.inner.warnings.len()
        )
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(calibrate_rig_py, m)?)?;
    m.add_class::<RigCalibrationResult>()?;
    Ok(())
}
