//! After calibration (crate `calib-export`): `stereo_rectify` (Bouguet's rectification, shaped
//! like cv2.stereoRectify) and `write_calibration` / `read_calibration` (OpenCV FileStorage, ROS
//! camera_info and Kalibr camchain YAML, and `calib` result JSON).

use crate::calibration_error;
use crate::camera::camera;
use crate::convert::{self, column_out, mat3_out, matrix_out, row_out};
use crate::rig::RigCalibrationResult;
use crate::single::CameraCalibration as CameraResult;
use crate::stereo::StereoCalibrationResult;
use calib_core::ImageSize;
use calib_core::ReadError;
use calib_export::{
    Calibrated, CameraCalibration, CameraRig, ExportError, ExportOptions, Format, StereoRig,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::path::PathBuf;

/// `alpha` as the crate's option: `None` or -1 is OpenCV's default scaling, else 0 to 1.
fn alpha_option(alpha: Option<f64>) -> PyResult<Option<f64>> {
    match alpha {
        None => Ok(None),
        Some(-1.0) => Ok(None),
        Some(a) if (0.0..=1.0).contains(&a) => Ok(Some(a)),
        Some(a) => Err(PyValueError::new_err(format!(
            "alpha: expected 0 to 1, or -1 / None for OpenCV's default scaling, got {a}"
        ))),
    }
}

/// A stereo rig from cv2-style arguments.
#[allow(clippy::too_many_arguments)]
fn rig(
    k1: &Bound<'_, PyAny>,
    d1: &Bound<'_, PyAny>,
    k2: &Bound<'_, PyAny>,
    d2: &Bound<'_, PyAny>,
    image_size: ImageSize,
    image_size2: ImageSize,
    r: &Bound<'_, PyAny>,
    t: &Bound<'_, PyAny>,
    model: Option<&str>,
    model2: Option<&str>,
    names: (String, String),
    dict: bool,
) -> PyResult<StereoRig> {
    // The arguments' names in messages: `K1` for stereo_rectify, `calibration['K1']` for a dict.
    let arg = |key: &str| {
        if dict {
            format!("calibration['{key}']")
        } else {
            key.to_string()
        }
    };
    let (model_what, model2_what) = if dict {
        (
            "calibration['models'][0]".to_string(),
            "calibration['models'][1]".to_string(),
        )
    } else {
        ("model".to_string(), "model2".to_string())
    };
    let left = camera(
        k1,
        Some(d1),
        model,
        None,
        &arg("K1"),
        &arg("D1"),
        &model_what,
    )?;
    let right = camera(
        k2,
        Some(d2),
        model2,
        Some(left.model),
        &arg("K2"),
        &arg("D2"),
        &model2_what,
    )?;
    let pose = convert::pose(r, t, &arg("R"), &arg("T"))?;
    Ok(StereoRig {
        left: CameraCalibration {
            name: names.0,
            camera: left,
            image_size,
        },
        right: CameraCalibration {
            name: names.1,
            camera: right,
            image_size: image_size2,
        },
        rotation: pose.rotation,
        translation: pose.translation,
    })
}

/// Bouguet's stereo rectification, like ``cv2.stereoRectify`` with ``CALIB_ZERO_DISPARITY`` (the
/// default), for every lens model: the same computation as ``calib rectify``.
///
/// ``K1``, ``D1``, ``K2``, ``D2``: the cameras' 3x3 matrices and distortion coefficients (OpenCV's
/// order; ``None`` or empty for none). ``image_size``: (width, height) of both images. ``R``,
/// ``T``: the rig, ``X2 = R X1 + T`` (a 3x3 rotation matrix or a rotation vector; ``T`` of 3
/// values), as :func:`stereo_calibrate` returns it. ``alpha``: free scaling, 0 (only valid pixels
/// in both rectified images) to 1 (every source pixel kept); -1 or ``None`` is OpenCV's default
/// (no extra scaling), cv2's default too. ``model`` / ``model2``: the lens models (``None``:
/// inferred from the number of coefficients, 4 brown-conrady4, 5 brown-conrady5, 8 rational8, 12
/// thin-prism12; a fisheye camera needs ``model="kannala-brandt4"``; the second camera defaults
/// to the first's model).
///
/// Returns ``R1, R2, P1, P2, Q, roi1, roi2`` as cv2.stereoRectify does: rotations (3, 3) into the
/// rectified frames, projection matrices (3, 4) in the rectified left frame (``P2[0, 3] = f *
/// baseline``), the disparity-to-depth matrix (4, 4), and the valid pixel regions ``(x, y, width,
/// height)``. Raises ``ValueError`` / ``TypeError`` for bad arguments and
/// :class:`CalibrationError` when the rig cannot be rectified (e.g. an image corner that cannot
/// be undistorted).
#[pyfunction]
// The text signature spells alpha's default out (pyo3 shows `...` for an `Option` default).
#[pyo3(
    signature = (K1, D1, K2, D2, image_size, R, T, alpha=-1.0, *, model=None, model2=None),
    text_signature = "(K1, D1, K2, D2, image_size, R, T, alpha=-1.0, *, model=None, model2=None)"
)]
#[allow(non_snake_case, clippy::too_many_arguments)]
fn stereo_rectify<'py>(
    py: Python<'py>,
    K1: &Bound<'py, PyAny>,
    D1: &Bound<'py, PyAny>,
    K2: &Bound<'py, PyAny>,
    D2: &Bound<'py, PyAny>,
    image_size: &Bound<'py, PyAny>,
    R: &Bound<'py, PyAny>,
    T: &Bound<'py, PyAny>,
    #[pyo3(from_py_with = crate::args::alpha)] alpha: Option<f64>,
    #[pyo3(from_py_with = crate::args::model)] model: Option<String>,
    #[pyo3(from_py_with = crate::args::model2)] model2: Option<String>,
) -> PyResult<Bound<'py, PyTuple>> {
    let alpha = alpha_option(alpha)?;
    let size = convert::image_size(image_size, "image_size")?;
    let rig = rig(
        K1,
        D1,
        K2,
        D2,
        size,
        size,
        R,
        T,
        model.as_deref(),
        model2.as_deref(),
        ("left".into(), "right".into()),
        false,
    )?;
    let rect = py
        .detach(|| calib_export::stereo_rectify(&rig, alpha))
        .map_err(calibration_error)?;
    let roi = |r: [u32; 4]| PyTuple::new(py, r);
    PyTuple::new(
        py,
        [
            mat3_out(py, &rect.r1).into_any(),
            mat3_out(py, &rect.r2).into_any(),
            matrix_out(py, &rect.p1).into_any(),
            matrix_out(py, &rect.p2).into_any(),
            matrix_out(py, &rect.q).into_any(),
            roi(rect.roi1)?.into_any(),
            roi(rect.roi2)?.into_any(),
        ],
    )
}

/// The format named `name`.
fn format(name: &str) -> PyResult<Format> {
    name.parse()
        .map_err(|e| PyValueError::new_err(format!("format: {e}")))
}

/// An item of a calibration dict, or a `ValueError` naming the missing key.
fn item<'py>(d: &Bound<'py, PyDict>, key: &str) -> PyResult<Bound<'py, PyAny>> {
    d.get_item(key)?.ok_or_else(|| {
        PyValueError::new_err(format!(
            "calibration: the dict has no key '{key}' (see read_calibration for its keys)"
        ))
    })
}

/// An optional string item.
fn str_item(d: &Bound<'_, PyDict>, key: &str) -> PyResult<Option<String>> {
    match d.get_item(key)? {
        Some(v) if !v.is_none() => v.extract().map(Some).map_err(|_| {
            PyTypeError::new_err(format!(
                "calibration['{key}']: expected a string, got {}",
                convert::type_name(&v)
            ))
        }),
        _ => Ok(None),
    }
}

/// An optional pair of strings (`names`, `models`).
fn pair_item(d: &Bound<'_, PyDict>, key: &str) -> PyResult<(Option<String>, Option<String>)> {
    match d.get_item(key)? {
        Some(v) if !v.is_none() => {
            let (a, b): (String, String) = v.extract().map_err(|_| {
                PyTypeError::new_err(format!(
                    "calibration['{key}']: expected two strings, got {}",
                    convert::short_repr(&v)
                ))
            })?;
            Ok((Some(a), Some(b)))
        }
        _ => Ok((None, None)),
    }
}

/// The list under `key` of a rig dict, with `n` items.
fn list_item<'py>(
    d: &Bound<'py, PyDict>,
    key: &str,
    n: Option<usize>,
) -> PyResult<Vec<Bound<'py, PyAny>>> {
    let v = item(d, key)?;
    let items: Vec<Bound<'py, PyAny>> = v
        .try_iter()
        .and_then(|it| it.collect::<PyResult<Vec<_>>>())
        .map_err(|_| {
            PyTypeError::new_err(format!(
                "calibration['{key}']: expected a list, got {}",
                convert::type_name(&v)
            ))
        })?;
    if let Some(n) = n
        && items.len() != n
    {
        return Err(PyValueError::new_err(format!(
            "calibration['{key}']: expected {n} items (one per camera), got {}",
            items.len()
        )));
    }
    Ok(items)
}

/// A rig dict (`kind="rig"`, the form `read_calibration` returns) as the crate's type.
fn rig_from_dict(d: &Bound<'_, PyDict>) -> PyResult<Calibrated> {
    let names: Vec<String> = list_item(d, "names", None)?
        .iter()
        .map(|v| v.extract())
        .collect::<PyResult<_>>()
        .map_err(|_| PyTypeError::new_err("calibration['names']: expected a list of strings"))?;
    let n = names.len();
    let ks = list_item(d, "Ks", Some(n))?;
    let dists = list_item(d, "dists", Some(n))?;
    let sizes = list_item(d, "image_sizes", Some(n))?;
    let rs = list_item(d, "Rs", Some(n))?;
    let ts = list_item(d, "Ts", Some(n))?;
    let models: Vec<Option<String>> = match d.get_item("models")? {
        Some(v) if !v.is_none() => list_item(d, "models", Some(n))?
            .iter()
            .map(|m| m.extract::<Option<String>>())
            .collect::<PyResult<_>>()
            .map_err(|_| {
                PyTypeError::new_err("calibration['models']: expected a list of strings")
            })?,
        _ => vec![None; n],
    };
    let mut cameras = Vec::with_capacity(n);
    let mut transforms = Vec::with_capacity(n);
    for (i, name) in names.into_iter().enumerate() {
        let camera = camera(
            &ks[i],
            Some(&dists[i]),
            models[i].as_deref(),
            None,
            &format!("calibration['Ks'][{i}]"),
            &format!("calibration['dists'][{i}]"),
            &format!("calibration['models'][{i}]"),
        )?;
        let image_size =
            convert::image_size(&sizes[i], &format!("calibration['image_sizes'][{i}]"))?;
        cameras.push(CameraCalibration {
            name,
            camera,
            image_size,
        });
        transforms.push(convert::pose(
            &rs[i],
            &ts[i],
            &format!("calibration['Rs'][{i}]"),
            &format!("calibration['Ts'][{i}]"),
        )?);
    }
    let reference = match d.get_item("reference")? {
        Some(v) if !v.is_none() => v.extract::<usize>().map_err(|_| {
            PyTypeError::new_err("calibration['reference']: expected a camera index")
        })?,
        _ => 0,
    };
    CameraRig::new(cameras, transforms, reference)
        .map(Calibrated::Rig)
        .map_err(|e| PyValueError::new_err(format!("calibration: {e}")))
}

/// A calibration dict (the form `read_calibration` returns) as the crate's type.
fn from_dict(d: &Bound<'_, PyDict>) -> PyResult<Calibrated> {
    if str_item(d, "kind")?.as_deref() == Some("rig") {
        return rig_from_dict(d);
    }
    let size = convert::image_size(&item(d, "image_size")?, "calibration['image_size']")?;
    let stereo =
        d.contains("R")? || d.contains("K1")? || str_item(d, "kind")?.as_deref() == Some("stereo");
    if stereo {
        let size2 = match d.get_item("image_size2")? {
            Some(v) if !v.is_none() => convert::image_size(&v, "calibration['image_size2']")?,
            _ => size,
        };
        let (name1, name2) = pair_item(d, "names")?;
        let (model1, model2) = pair_item(d, "models")?;
        let rig = rig(
            &item(d, "K1")?,
            &item(d, "D1")?,
            &item(d, "K2")?,
            &item(d, "D2")?,
            size,
            size2,
            &item(d, "R")?,
            &item(d, "T")?,
            model1.as_deref(),
            model2.as_deref(),
            (
                name1.unwrap_or_else(|| "left".into()),
                name2.unwrap_or_else(|| "right".into()),
            ),
            true,
        )?;
        Ok(Calibrated::Stereo(rig))
    } else {
        let model = str_item(d, "model")?;
        let camera = camera(
            &item(d, "K")?,
            Some(&item(d, "dist")?),
            model.as_deref(),
            None,
            "calibration['K']",
            "calibration['dist']",
            "calibration['model']",
        )?;
        Ok(Calibrated::Single(CameraCalibration {
            name: str_item(d, "name")?.unwrap_or_else(|| "camera".into()),
            camera,
            image_size: size,
        }))
    }
}

/// What `write_calibration` can write: a result of `calibrate_camera`, `stereo_calibrate` or
/// `calibrate_rig`, or a dict of `read_calibration`'s form.
fn calibrated(obj: &Bound<'_, PyAny>) -> PyResult<Calibrated> {
    if let Ok(c) = obj.cast::<CameraResult>() {
        return Ok(Calibrated::Single(CameraCalibration::from(&c.get().inner)));
    }
    if let Ok(s) = obj.cast::<StereoCalibrationResult>() {
        return Ok(Calibrated::Stereo(StereoRig::from(&s.get().inner)));
    }
    if let Ok(r) = obj.cast::<RigCalibrationResult>() {
        return Ok(Calibrated::Rig(CameraRig::from(&r.get().inner)));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        return from_dict(d);
    }
    Err(PyTypeError::new_err(format!(
        "calibration: expected a CameraCalibration, a StereoCalibration, a RigCalibration or a dict of read_calibration's form, got {}",
        convert::type_name(obj)
    )))
}

/// Writes a calibration in another tool's format, like ``calib export`` (and ``--export`` of
/// ``calib single`` / ``calib stereo``).
///
/// ``path``: the file (a ``str`` or ``os.PathLike``). ``calibration``: a result of
/// :func:`calibrate_camera`, :func:`stereo_calibrate` or :func:`calibrate_rig`, or a dict of the
/// form :func:`read_calibration` returns (single: ``K``, ``dist``, ``image_size``, optional
/// ``model`` and ``name``; stereo: ``K1``, ``D1``, ``K2``, ``D2``, ``R``, ``T``, ``image_size``,
/// optional ``image_size2``, ``models``, ``names``; rig: ``kind="rig"``, lists ``names``, ``Ks``,
/// ``dists``, ``image_sizes``, ``Rs``, ``Ts``, optional ``models`` and ``reference``).
/// ``format``: ``"opencv"`` (FileStorage YAML, what cv2.FileStorage reads; a rig as maps
/// ``camera_0 ...``), ``"ros"`` (camera_info YAML; a stereo rig writes ``STEM-left.EXT`` and
/// ``STEM-right.EXT``, a rig ``STEM-NAME.EXT`` per camera) or ``"kalibr"`` (camchain YAML). ``alpha``: free scaling of the
/// rectification written with a stereo rig (OpenCV, ROS) and of a single camera's ROS
/// projection matrix, 0 to 1, or -1 / ``None`` for OpenCV's default; default 0 as in
/// ``calib export``. ``translation_scale``: multiplies translations (0.001 for a board in
/// millimetres when ROS or Kalibr expect metres).
///
/// The files are written atomically, as a group (a ROS stereo pair's two files together). An
/// OpenCV stereo file whose rectification cannot be computed (a lens model that folds inside the
/// image) holds ``M1 ... F`` without ``R1 ... Q`` and a comment why, with a ``UserWarning``.
/// Returns the paths written (``str``). Raises
/// :class:`CalibrationError` when the format cannot hold the calibration (e.g. a lens model
/// Kalibr has no equivalent of), and the ``OSError`` subclass ``open(path, "w")`` raises when a
/// file cannot be written (``FileNotFoundError`` for a missing folder, ``PermissionError``,
/// ``IsADirectoryError`` for a folder at ``path``, ...), with ``filename`` the file.
#[pyfunction]
#[pyo3(
    signature = (path, calibration, format="opencv".to_string(), *, alpha=0.0, translation_scale=1.0),
    text_signature = "(path, calibration, format='opencv', *, alpha=0.0, translation_scale=1.0)"
)]
fn write_calibration(
    py: Python<'_>,
    #[pyo3(from_py_with = crate::args::path)] path: PathBuf,
    calibration: &Bound<'_, PyAny>,
    #[pyo3(from_py_with = crate::args::format)] format: String,
    #[pyo3(from_py_with = crate::args::alpha)] alpha: Option<f64>,
    #[pyo3(from_py_with = crate::args::translation_scale)] translation_scale: f64,
) -> PyResult<Vec<String>> {
    let format = self::format(&format)?;
    let calibrated = calibrated(calibration)?;
    let options = ExportOptions::new(alpha_option(alpha)?, translation_scale)
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let rendered = py
        .detach(|| calib_export::render_export(&calibrated, format, &options))
        .map_err(calibration_error)?;
    // What a file leaves out (an OpenCV stereo file without R1..Q, said in its comment too):
    // a UserWarning, as calib export prints a warning.
    for omission in &rendered.omissions {
        PyErr::warn(
            py,
            &py.get_type::<pyo3::exceptions::PyUserWarning>(),
            &std::ffi::CString::new(format!("{}: {omission}", path.display())).unwrap_or_default(),
            1,
        )?;
    }
    let written = calib_export::export_paths(&calibrated, format, &path);
    py.detach(|| calib_export::write_export(&rendered, &written))
        .map_err(|e| match &e {
            // A file that cannot be written is the OSError open(path, "w") would raise.
            ExportError::Write { path, source } => {
                crate::os_error(py, source, path).unwrap_or_else(|| calibration_error(&e))
            }
            _ => calibration_error(e),
        })?;
    Ok(written
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect())
}

/// One camera's entries of a calibration dict.
fn camera_items(d: &Bound<'_, PyDict>, c: &CameraCalibration, k: &str, dist: &str) -> PyResult<()> {
    let py = d.py();
    d.set_item(k, mat3_out(py, &c.matrix()))?;
    d.set_item(dist, row_out(py, &c.camera.distortion))?;
    Ok(())
}

/// Reads a calibration file of any kind ``calib`` reads: an OpenCV FileStorage YAML, a ROS
/// camera_info YAML, a Kalibr camchain, or a result JSON of ``calib single`` / ``calib stereo`` /
/// ``calib rig``. The kind is recognized from the content. ``path`` may also be the text itself:
/// a ``str`` that starts with ``{`` (such as ``result.to_json()``) or spans several lines.
///
/// Returns a dict. One camera: ``kind="single"``, ``name``, ``model`` (e.g.
/// ``"brown-conrady5"``), ``image_size`` (width, height), ``K`` (3, 3), ``dist`` (1, N) in
/// OpenCV's order. A stereo rig: ``kind="stereo"``, ``names`` and ``models`` (pairs),
/// ``image_size`` and ``image_size2``, ``K1``, ``D1``, ``K2``, ``D2``, ``R`` (3, 3) and ``T`` (3, 1)
/// with ``X2 = R X1 + T``. A rig of N cameras: ``kind="rig"``, lists ``names``, ``models``,
/// ``image_sizes``, ``Ks``, ``dists``, ``Rs`` and ``Ts`` (each camera's transform from the
/// reference camera, ``X_cam = R X_ref + T``), and ``reference`` (index).
/// :func:`write_calibration` takes the dict back. A file that cannot be read raises the
/// ``OSError`` subclass ``open()`` raises (``FileNotFoundError``, ``PermissionError``,
/// ``IsADirectoryError``, ...; ``filename`` is the path); a file whose content is wrong (not a
/// calibration, bad YAML or JSON, a missing key, not UTF-8) raises :class:`CalibrationError`
/// naming the file and key at fault.
#[pyfunction]
fn read_calibration<'py>(
    py: Python<'py>,
    path: &Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyDict>> {
    let text = match path.cast::<pyo3::types::PyString>() {
        Ok(s) => {
            let s = s.to_cow()?;
            (s.trim_start().starts_with('{') || s.contains('\n')).then(|| s.into_owned())
        }
        Err(_) => None,
    };
    let calibrated = match text {
        Some(text) => py
            .detach(|| calib_export::parse_calibration(&text, "<text>"))
            .map_err(calibration_error)?,
        None => {
            let path = crate::args::path(path)?;
            py.detach(|| calib_export::read_calibration(&path))
                .map_err(|e| {
                    // A file that cannot be read is the OSError open() would raise.
                    if let ExportError::Read(ReadError::Io { path, source }) = &e
                        && let Some(error) = crate::os_error(py, source, path)
                    {
                        return error;
                    }
                    // A long path is not echoed whole.
                    let shown = path.to_string_lossy();
                    calibration_error(
                        e.to_string()
                            .replace(shown.as_ref(), &crate::shown_path(&shown)),
                    )
                })?
        }
    };
    let d = PyDict::new(py);
    let size = |s: ImageSize| (s.width, s.height);
    match &calibrated {
        Calibrated::Single(c) => {
            d.set_item("kind", "single")?;
            d.set_item("name", &c.name)?;
            d.set_item("model", c.camera.model.name())?;
            d.set_item("image_size", size(c.image_size))?;
            camera_items(&d, c, "K", "dist")?;
        }
        Calibrated::Stereo(s) => {
            d.set_item("kind", "stereo")?;
            d.set_item("names", (&s.left.name, &s.right.name))?;
            d.set_item(
                "models",
                (s.left.camera.model.name(), s.right.camera.model.name()),
            )?;
            d.set_item("image_size", size(s.left.image_size))?;
            d.set_item("image_size2", size(s.right.image_size))?;
            camera_items(&d, &s.left, "K1", "D1")?;
            camera_items(&d, &s.right, "K2", "D2")?;
            d.set_item("R", mat3_out(py, &s.rotation))?;
            d.set_item("T", column_out(py, s.translation.as_slice()))?;
        }
        Calibrated::Rig(r) => {
            d.set_item("kind", "rig")?;
            let names: Vec<&str> = r.cameras.iter().map(|c| c.name.as_str()).collect();
            d.set_item("names", names)?;
            let models: Vec<&str> = r.cameras.iter().map(|c| c.camera.model.name()).collect();
            d.set_item("models", models)?;
            let sizes: Vec<(u32, u32)> = r.cameras.iter().map(|c| size(c.image_size)).collect();
            d.set_item("image_sizes", sizes)?;
            let ks: Vec<_> = r
                .cameras
                .iter()
                .map(|c| mat3_out(py, &c.matrix()))
                .collect();
            d.set_item("Ks", ks)?;
            let dists: Vec<_> = r
                .cameras
                .iter()
                .map(|c| row_out(py, &c.camera.distortion))
                .collect();
            d.set_item("dists", dists)?;
            let rs: Vec<_> = r
                .transforms
                .iter()
                .map(|t| mat3_out(py, &t.rotation))
                .collect();
            d.set_item("Rs", rs)?;
            let ts: Vec<_> = r
                .transforms
                .iter()
                .map(|t| column_out(py, t.translation.as_slice()))
                .collect();
            d.set_item("Ts", ts)?;
            d.set_item("reference", r.reference)?;
        }
    }
    Ok(d)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(stereo_rectify, m)?)?;
    m.add_function(wrap_pyfunction!(write_calibration, m)?)?;
    m.add_function(wrap_pyfunction!(read_calibration, m)?)?;
    Ok(())
}
