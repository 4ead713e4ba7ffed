//! The keyword arguments shared by `calibrate_camera`, `stereo_calibrate` and `calibrate_rig`,
//! turned into the crates' `CalibrationOptions` the way the `calib` command does
//! (`crates/calib-cli/src/single.rs`), except that outlier rejection is off unless asked (cv2
//! fits every point) and repeated views are kept unless asked.

use crate::convert;
use calib_core::{CalibrationOptions, OutlierRejection};
use camera_model::{CameraModel, RotationKind};
use lm_solver::Loss;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyString;

/// Names accepted by `fix` besides the model's distortion coefficients.
pub const FIX_FLAGS: [&str; 4] = [
    "principal_point",
    "focal_length",
    "aspect_ratio",
    "tangential",
];

/// A lens model by name (`None`: the default, brown-conrady4).
pub fn model(name: Option<&str>, what: &str) -> PyResult<CameraModel> {
    match name {
        None => Ok(CameraModel::default()),
        // The parse error already lists the known names.
        Some(name) => name
            .parse()
            .map_err(|e| PyValueError::new_err(format!("{what}: {e}"))),
    }
}

/// The pinhole model a coefficient vector of `n` values means in cv2's convention (4
/// brown-conrady4, 5 brown-conrady5, 8 rational8, 12 thin-prism12), if any.
pub fn model_of_count(n: usize) -> Option<CameraModel> {
    CameraModel::ALL
        .into_iter()
        .find(|m| !m.is_fisheye() && m.num_distortion_params() == n)
}

/// The lens model of a camera whose coefficients may be given (`coefficients`, from the argument
/// `dist_what`; `None` or empty when not given). A named `model` (argument `model_what`) must have
/// as many coefficients as given. Without a name, `fallback` when the count fits it (or nothing
/// was given), else the model the count means in cv2's convention ([`model_of_count`]), so that
/// OpenCV's five coefficients (which cv2 returns even with `CALIB_FIX_K3`) need no `model=`.
pub fn model_for_dist(
    model: Option<&str>,
    model_what: &str,
    coefficients: Option<&[f64]>,
    dist_what: &str,
    fallback: CameraModel,
) -> PyResult<CameraModel> {
    let n = coefficients.map(|c| c.len()).filter(|&n| n > 0);
    let Some(name) = model else {
        return match n {
            None => Ok(fallback),
            Some(n) if n == fallback.num_distortion_params() => Ok(fallback),
            Some(n) => model_of_count(n).ok_or_else(|| {
                PyValueError::new_err(format!(
                    "{dist_what}: {n} coefficients match no pinhole model (4 brown-conrady4, 5 brown-conrady5, 8 rational8 or 12 thin-prism12); give {model_what}= (a fisheye: {model_what}='kannala-brandt4')"
                ))
            }),
        };
    };
    let model = self::model(Some(name), model_what)?;
    if let Some(n) = n {
        check_count(model, n, model_what, dist_what)?;
    }
    Ok(model)
}

/// The coefficients of an optional argument (`None` when absent or `None`), finite.
pub fn coefficients(dist: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Option<Vec<f64>>> {
    let Some(d) = dist.filter(|d| !d.is_none()) else {
        return Ok(None);
    };
    let v = convert::vector(d, what)?;
    convert::check_finite(&v, what)?;
    Ok(Some(v))
}

/// Refuses `n` coefficients for `model` unless it has that many, naming the model the count
/// would mean.
pub fn check_count(
    model: CameraModel,
    n: usize,
    model_what: &str,
    dist_what: &str,
) -> PyResult<()> {
    let names = model.distortion_names();
    if n == names.len() {
        return Ok(());
    }
    let hint = match model_of_count(n) {
        Some(other) => format!(
            "; {n} coefficients are {other}'s ({}): give {model_what}='{other}', or leave {model_what} out to have it inferred from the count",
            other.distortion_names().join(", ")
        ),
        None => format!("; {n} coefficients match no lens model"),
    };
    Err(PyValueError::new_err(format!(
        "{dist_what}: {model_what} {model} has {} coefficients ({}), got {n}{hint}",
        names.len(),
        names.join(", "),
    )))
}

/// The names in `fix`: a string ("k3", or "k2,k3") or an iterable of strings.
pub fn fix_names(fix: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Vec<String>> {
    let Some(fix) = fix else {
        return Ok(Vec::new());
    };
    if fix.is_none() {
        return Ok(Vec::new());
    }
    let split = |s: &str| -> Vec<String> {
        s.split(',')
            .map(|n| n.trim().to_ascii_lowercase().replace('-', "_"))
            .filter(|n| !n.is_empty())
            .collect()
    };
    if let Ok(s) = fix.cast::<PyString>() {
        return Ok(split(&s.to_cow()?));
    }
    let mut names = Vec::new();
    for item in fix.try_iter().map_err(|_| {
        PyTypeError::new_err(format!(
            "{what}: expected a string or a list of strings, got {}",
            convert::type_name(fix)
        ))
    })? {
        let item = item?;
        let s = item.cast::<PyString>().map_err(|_| {
            PyTypeError::new_err(format!(
                "{what}: expected strings, got {}",
                convert::type_name(&item)
            ))
        })?;
        names.extend(split(&s.to_cow()?));
    }
    Ok(names)
}

/// Refuses the `tangential` flag when none of `models` has tangential terms (it would do
/// nothing), as the command line's `--zero-tangential` does.
pub fn check_tangential(fix: &[String], models: &[CameraModel]) -> PyResult<()> {
    let asked = fix.iter().any(|n| n == "tangential" || n == "tangent_dist");
    if asked && models.iter().all(|m| m.tangential_params().is_empty()) {
        return Err(PyValueError::new_err(format!(
            "fix: 'tangential' holds p1, p2, which {} {} not have",
            models
                .iter()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(" and "),
            if models.len() > 1 { "do" } else { "does" }
        )));
    }
    Ok(())
}

/// True for the `fix` names that are flags rather than distortion coefficients.
pub fn is_fix_flag(name: &str) -> bool {
    FIX_FLAGS.contains(&name) || name == "tangent_dist"
}

/// Applies `fix` to `options` (whose model is already set).
pub fn apply_fix(options: &mut CalibrationOptions, names: &[String], what: &str) -> PyResult<()> {
    let mut distortion: Vec<&str> = Vec::new();
    for name in names {
        match name.as_str() {
            "principal_point" => options.fix_principal_point = true,
            "focal_length" => options.fix_focal_length = true,
            "aspect_ratio" => options.fix_aspect_ratio = true,
            "tangential" | "tangent_dist" => options.zero_tangential_distortion = true,
            other => distortion.push(other),
        }
    }
    options.fixed_distortion.clear();
    options.fix_distortion_by_name(&distortion).map_err(|e| {
        PyValueError::new_err(format!("{what}: {e}, or one of {}", FIX_FLAGS.join(", ")))
    })
}

/// A count given as a Python int, within `least..=most`.
pub fn count(value: i64, what: &str, least: usize, most: usize) -> PyResult<usize> {
    usize::try_from(value)
        .ok()
        .filter(|v| (least..=most).contains(v))
        .ok_or_else(|| {
            PyValueError::new_err(format!("{what}: expected {least} to {most}, got {value}"))
        })
}

/// The solver settings common to every calibration function.
pub struct Common {
    pub reject_outliers: bool,
    pub outlier_threshold: f64,
    pub loss: Option<String>,
    pub loss_scale: f64,
    pub rotation: Option<String>,
    /// As given (a Python int; checked in [`Common::apply`], so a negative value is a
    /// `ValueError` naming the argument rather than pyo3's `OverflowError`).
    pub max_iterations: i64,
    pub threads: i64,
}

impl Common {
    /// The outlier rejection these settings ask for.
    pub fn outliers(&self) -> PyResult<Option<OutlierRejection>> {
        if !(self.outlier_threshold.is_finite() && self.outlier_threshold >= 2.0) {
            return Err(PyValueError::new_err(format!(
                "outlier_threshold: expected a number of sigmas of at least 2, got {}",
                self.outlier_threshold
            )));
        }
        Ok(self
            .reject_outliers
            .then(|| OutlierRejection::with_threshold(self.outlier_threshold)))
    }

    /// The robust loss.
    pub fn loss(&self) -> PyResult<Loss> {
        if !(self.loss_scale.is_finite() && self.loss_scale > 0.0) {
            return Err(PyValueError::new_err(format!(
                "loss_scale: expected a positive number of pixels, got {}",
                self.loss_scale
            )));
        }
        match self.loss.as_deref() {
            None | Some("none") | Some("linear") => Ok(Loss::Trivial),
            Some("huber") => Ok(Loss::Huber(self.loss_scale)),
            Some("cauchy") => Ok(Loss::Cauchy(self.loss_scale)),
            Some(other) => Err(PyValueError::new_err(format!(
                "loss: unknown loss '{other}' (expected None, 'huber' or 'cauchy')"
            ))),
        }
    }

    /// The rotation parameterization (`default` when not given).
    pub fn rotation(&self, default: RotationKind) -> PyResult<RotationKind> {
        match self.rotation.as_deref() {
            None => Ok(default),
            Some("euler") | Some("euler-xyz") => Ok(RotationKind::EulerXyz),
            Some("axis-angle") | Some("rodrigues") => Ok(RotationKind::AxisAngle),
            Some("so3") => Ok(RotationKind::So3),
            Some(other) => Err(PyValueError::new_err(format!(
                "rotation: unknown parameterization '{other}' (expected 'euler', 'axis-angle' or 'so3')"
            ))),
        }
    }

    /// `options` with these settings (model, fixes and guesses are set by the caller).
    pub fn apply(&self, options: &mut CalibrationOptions) -> PyResult<()> {
        options.outliers = self.outliers()?;
        options.loss = self.loss()?;
        options.rotation = self.rotation(RotationKind::EulerXyz)?;
        options.solver.max_iterations = count(self.max_iterations, "max_iterations", 1, 1_000_000)?;
        options.solver.num_threads = count(self.threads, "threads (0: every core)", 0, 4096)?;
        Ok(())
    }
}

/// One camera's options: model, `fix`, and the guesses `K` and `dist` (either may be `None`).
pub fn camera_options(
    model: CameraModel,
    fix: &[String],
    k: Option<&Bound<'_, PyAny>>,
    dist: Option<&Bound<'_, PyAny>>,
    common: &Common,
    what: &str,
) -> PyResult<CalibrationOptions> {
    let mut options = CalibrationOptions::default();
    options.model = model;
    // The arguments' own names: `fix`/`K`/`dist` for one camera, `fix`/`K1`/`D1` and
    // `fix2`/`K2`/`D2` for a stereo pair.
    let (fix_arg, dist_arg, model_arg) = match what {
        "" => ("fix".to_string(), "dist".to_string(), "model".to_string()),
        "1" => ("fix".to_string(), "D1".to_string(), "model".to_string()),
        other => (
            format!("fix{other}"),
            format!("D{other}"),
            format!("model{other}"),
        ),
    };
    apply_fix(&mut options, fix, &fix_arg)?;
    common.apply(&mut options)?;
    // cv2 semantics: a camera matrix passed as `None` means "no guess".
    if let Some(k) = k.filter(|k| !k.is_none()) {
        options.intrinsic_guess = Some(convert::intrinsics_from_k(k, &format!("K{what}"))?);
    }
    if let Some(d) = dist.filter(|d| !d.is_none()) {
        let v = convert::vector(d, &dist_arg)?;
        convert::check_finite(&v, &dist_arg)?;
        check_count(model, v.len(), &model_arg, &dist_arg)?;
        options.distortion_guess = Some(v);
    }
    Ok(options)
}
