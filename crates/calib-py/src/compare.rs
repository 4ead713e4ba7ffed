//! `compare_models`: `calib_single::compare_models` (the command's `calib single
//! --compare-models`) with `calibrate_camera`'s arguments.

use crate::calibration_error;
use crate::convert;
use crate::options::{self, Common};
use crate::single::{views, with_view_name};
use calib_single::compare::MODELS;
use calib_single::{Observations, compare_models as compare};
use camera_model::CameraModel;
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyString};

/// The lens models of `models`: `None` (the command's set, [`MODELS`]), a name or comma-separated
/// names, or an iterable of names; at least one, none twice.
fn model_list(models: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<CameraModel>> {
    let Some(models) = models.filter(|m| !m.is_none()) else {
        return Ok(MODELS.to_vec());
    };
    let names: Vec<String> = if let Ok(s) = models.cast::<PyString>() {
        s.to_cow()?
            .split(',')
            .map(|n| n.trim().to_string())
            .collect()
    } else {
        let items = models.try_iter().map_err(|_| {
            PyTypeError::new_err(format!(
                "models: expected a list of model names (str) or None, got {}",
                convert::type_name(models)
            ))
        })?;
        let mut names = Vec::new();
        for (i, item) in items.enumerate() {
            let item = item?;
            let s = item.cast::<PyString>().map_err(|_| {
                PyTypeError::new_err(format!(
                    "models[{i}]: expected a model name (str), got {}",
                    convert::type_name(&item)
                ))
            })?;
            names.push(s.to_cow()?.into_owned());
        }
        names
    };
    if names.is_empty() {
        return Err(PyValueError::new_err(
            "models: no model to compare (give None for the default set)",
        ));
    }
    let mut list: Vec<CameraModel> = Vec::new();
    for (i, name) in names.iter().enumerate() {
        let model = options::model(Some(name), &format!("models[{i}]"))?;
        if list.contains(&model) {
            return Err(PyValueError::new_err(format!(
                "models[{i}]: {model} is compared already"
            )));
        }
        list.push(model);
    }
    Ok(list)
}

/// Compares lens models on one camera's views, like ``calib single --compare-models``: each
/// model is calibrated on all views (``rms``), checked for being one-to-one over the image
/// (``valid_over_image``), and cross-validated: fitted on the even-numbered views and evaluated
/// on the odd-numbered ones (camera held, only their poses estimated), then the other way round
/// (``cross_validated_rms``, over both halves' held-out points; 4 views or more). The
/// recommendation is the model with the fewest parameters among the valid ones as good as the
/// best valid one: cross-validated RMS within 2% of it and not systematically worse on the
/// held-out views (the paired test of each view's held-out error, ``excess_over_reference`` and
/// ``excess_std_error`` of the rows); or, when the best valid one is not as good as the best
/// fit, one whose fold lies within the 5% margin beyond the image border and which is;
/// ``best_fit`` and ``gap_to_best_fit``
/// say when a model that folds inside the image fits clearly better.
///
/// ``object_points``, ``image_points``, ``image_size`` and ``names`` as in
/// :func:`calibrate_camera`. ``models``: model names to compare, in the table's order (default:
/// brown-conrady4, brown-conrady5, kannala-brandt4, rational8, thin-prism12, the command's set).
/// ``fix``: as in :func:`calibrate_camera`, except that each coefficient name is held at zero in
/// every compared model that has it (``fix=['k3']`` holds brown-conrady5's, rational8's and
/// kannala-brandt4's ``k3``), as the command's ``--fix`` with ``--compare-models``; a name no
/// compared model has is refused. ``K``: start every model from this camera matrix. The solver
/// settings ``reject_outliers``, ``outlier_threshold``, ``loss``, ``loss_scale``, ``rotation``,
/// ``skip_bad_views``, ``drop_duplicate_views``, ``max_iterations`` and ``threads`` as in
/// :func:`calibrate_camera` (outlier rejection off unless asked; the command rejects outliers
/// unless given ``--no-outlier-rejection``). There is no ``dist`` or ``model``: every model
/// starts from its own guess.
///
/// Returns a :class:`ModelComparison` (``rows``, ``recommended``, ``best_fit``,
/// ``gap_to_best_fit``, ``held_fixed``, ``uncovered_disagreement``; ``str()`` is the command's table). The rows' warnings are
/// not emitted with ``warnings.warn``: a richer model's ``poorly-determined`` is what the
/// comparison is for. Raises ``ValueError`` for fewer than 4 views (no cross-validation: the RMS
/// alone always favours the model with the most terms), an unknown model or ``fix`` name, and
/// :class:`CalibrationError` when no model could be fitted, with the reason. The GIL is released
/// while it runs.
#[pyfunction]
#[pyo3(signature = (
    object_points, image_points, image_size, models=None, fix=None, *, K=None,
    reject_outliers=false, outlier_threshold=5.0, loss=None, loss_scale=1.0, rotation=None,
    skip_bad_views=false, drop_duplicate_views=false, max_iterations=500, threads=0, names=None
))]
#[allow(non_snake_case, clippy::too_many_arguments)]
fn compare_models(
    py: Python<'_>,
    object_points: &Bound<'_, PyAny>,
    image_points: &Bound<'_, PyAny>,
    image_size: &Bound<'_, PyAny>,
    models: Option<&Bound<'_, PyAny>>,
    fix: Option<&Bound<'_, PyAny>>,
    K: Option<&Bound<'_, PyAny>>,
    #[pyo3(from_py_with = crate::args::reject_outliers)] reject_outliers: bool,
    #[pyo3(from_py_with = crate::args::outlier_threshold)] outlier_threshold: f64,
    #[pyo3(from_py_with = crate::args::loss)] loss: Option<String>,
    #[pyo3(from_py_with = crate::args::loss_scale)] loss_scale: f64,
    #[pyo3(from_py_with = crate::args::rotation)] rotation: Option<String>,
    #[pyo3(from_py_with = crate::args::skip_bad_views)] skip_bad_views: bool,
    #[pyo3(from_py_with = crate::args::drop_duplicate_views)] drop_duplicate_views: bool,
    #[pyo3(from_py_with = crate::args::max_iterations)] max_iterations: i64,
    #[pyo3(from_py_with = crate::args::threads)] threads: i64,
    names: Option<&Bound<'_, PyAny>>,
) -> PyResult<ModelComparison> {
    let common = Common {
        reject_outliers,
        outlier_threshold,
        loss,
        loss_scale,
        rotation,
        max_iterations,
        threads,
    };
    let models = model_list(models)?;
    let fix = options::fix_names(fix, "fix")?;
    options::check_tangential(&fix, &models)?;
    // The flags go into the options; coefficient names are held per model by the comparison.
    let (flags, hold): (Vec<String>, Vec<String>) =
        fix.into_iter().partition(|n| options::is_fix_flag(n));
    if let Some(unknown) = hold.iter().find(|n| {
        !models
            .iter()
            .any(|m| m.distortion_names().contains(&n.as_str()))
    }) {
        return Err(PyValueError::new_err(format!(
            "fix: no compared model has a coefficient '{unknown}', and it is not one of {}",
            options::FIX_FLAGS.join(", ")
        )));
    }
    let mut opts = options::camera_options(CameraModel::default(), &flags, K, None, &common, "")?;
    opts.skip_bad_views = skip_bad_views;
    opts.drop_duplicate_views = drop_duplicate_views;
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
    // Without cross-validation the rows could only be ranked by their RMS on the views they were
    // fitted to, which always favours the model with the most terms.
    let n = observations.views.len();
    if n < 4 {
        return Err(PyValueError::new_err(format!(
            "object_points: {n} view{}; comparing models needs at least 4 (each model is fitted on half of the views and evaluated on the other half)",
            if n == 1 { "" } else { "s" }
        )));
    }
    let given_names: Option<Vec<String>> = names
        .is_some_and(|n| !n.is_none())
        .then(|| observations.views.iter().map(|v| v.name.clone()).collect());
    let hold: Vec<&str> = hold.iter().map(String::as_str).collect();
    let mut comparison = py.detach(|| compare(&observations, &opts, &models, &hold));
    for row in &mut comparison.rows {
        row.error = row
            .error
            .take()
            .map(|e| with_view_name(e, "view", given_names.as_deref()));
    }
    if comparison.rows.iter().all(|r| r.rms.is_none()) {
        let errors: Vec<&str> = comparison
            .rows
            .iter()
            .filter_map(|r| r.error.as_deref())
            .collect();
        let reason = if errors.windows(2).all(|w| w[0] == w[1]) {
            errors
                .first()
                .copied()
                .unwrap_or("no model given")
                .to_string()
        } else {
            comparison
                .rows
                .iter()
                .map(|r| format!("{}: {}", r.model, r.error.as_deref().unwrap_or("-")))
                .collect::<Vec<_>>()
                .join("; ")
        };
        return Err(calibration_error(format!(
            "no model could be fitted: {reason}"
        )));
    }
    Ok(ModelComparison { inner: comparison })
}

/// One model's row of a :class:`ModelComparison`.
#[pyclass(module = "calib", frozen)]
pub struct ModelRow {
    inner: calib_single::ModelRow,
}

#[pymethods]
impl ModelRow {
    /// The lens model's name.
    #[getter]
    fn model(&self) -> &'static str {
        self.inner.model.name()
    }

    /// Number of camera parameters the calibration estimates: fx, fy, cx, cy and the distortion
    /// coefficients, less those held (coefficients in ``fix``, a held principal point, focal
    /// length or aspect ratio, tangential terms held at zero), as in the command's table.
    #[getter]
    fn parameters(&self) -> usize {
        self.inner.parameters
    }

    /// RMS reprojection error on all views, pixels (``None`` if the calibration failed).
    #[getter]
    fn rms(&self) -> Option<f64> {
        self.inner.rms
    }

    /// Cross-validated RMS, pixels: fitted on the even-numbered views and evaluated on the
    /// odd-numbered ones, then the other way round, over both halves' held-out points (``None``
    /// with fewer than 4 views or when a half could not be fitted).
    #[getter]
    fn cross_validated_rms(&self) -> Option<f64> {
        self.inner.cross_validated_rms
    }

    /// The fitted model is one-to-one over the whole image (with the 5% margin of the
    /// ``model-invalid`` warning).
    #[getter]
    fn valid_over_image(&self) -> bool {
        self.inner.valid_over_image
    }

    /// The warnings of the calibration on all views (list of :class:`CalibrationWarning`).
    #[getter]
    fn warnings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        crate::warnings_out(py, &self.inner.warnings)
    }

    /// Why the calibration on all views failed (``None`` if it did not).
    #[getter]
    fn error(&self) -> Option<String> {
        self.inner.error.clone()
    }

    /// Each view's held-out error (the camera fitted on the other half of the views): a list of
    /// ``(view, squared_error, points)``, the view's index in the input, the sum of its points'
    /// squared reprojection errors (pixels squared) and their number; empty without
    /// cross-validation.
    #[getter]
    fn held_out(&self) -> Vec<(usize, f64, usize)> {
        self.inner
            .held_out
            .iter()
            .map(|v| (v.view, v.squared_error, v.points))
            .collect()
    }

    /// How far this model's held-out errors lie above the reference model's
    /// (:attr:`ModelComparison.reference`): the mean over the views of the log ratio of the
    /// views' held-out squared errors (0.036: 3.7% larger; negative: smaller); ``None`` without
    /// a reference.
    #[getter]
    fn excess_over_reference(&self) -> Option<f64> {
        self.inner.excess_over_reference
    }

    /// The standard error of ``excess_over_reference``, from the spread of the per-view log
    /// ratios. The row is as good as the reference when its cross-validated RMS is within 2%
    /// and the excess at most Student's t (97.5%, views - 1 degrees of freedom) times this.
    #[getter]
    fn excess_std_error(&self) -> Option<f64> {
        self.inner.excess_std_error
    }

    /// A row from the JSON form of one row (what ``__reduce__`` gives ``pickle``).
    #[staticmethod]
    fn _from_json(text: &str) -> PyResult<Self> {
        let inner = serde_json::from_str(text)
            .map_err(|e| PyValueError::new_err(format!("text: not a model row: {e}")))?;
        Ok(Self { inner })
    }

    /// Pickling (and ``copy``) through the JSON form, as :class:`ModelComparison`'s.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let from_json = py.get_type::<Self>().getattr("_from_json")?;
        let text = serde_json::to_string(&self.inner).map_err(calibration_error)?;
        Ok((from_json, (text,)))
    }

    fn __repr__(&self) -> String {
        let px = |v: Option<f64>| v.map_or("None".to_string(), |v| format!("{v:.5}"));
        format!(
            "ModelRow(model={:?}, parameters={}, rms={}, cross_validated_rms={}, valid_over_image={}, warnings={}{})",
            self.inner.model.name(),
            self.inner.parameters,
            px(self.inner.rms),
            px(self.inner.cross_validated_rms),
            if self.inner.valid_over_image {
                "True"
            } else {
                "False"
            },
            self.inner.warnings.len(),
            self.inner
                .error
                .as_ref()
                .map_or(String::new(), |e| format!(", error={e:?}"))
        )
    }
}

/// The result of :func:`compare_models`: one :class:`ModelRow` per model and the
/// recommendation. ``str()`` (or ``table()``) is the table ``calib single --compare-models``
/// prints; ``to_json()`` the file it writes with ``-o``.
#[pyclass(module = "calib", frozen)]
pub struct ModelComparison {
    inner: calib_single::ModelComparison,
}

#[pymethods]
impl ModelComparison {
    /// One :class:`ModelRow` per model, in the order of ``models``.
    #[getter]
    fn rows(&self) -> Vec<ModelRow> {
        self.inner
            .rows
            .iter()
            .map(|r| ModelRow { inner: r.clone() })
            .collect()
    }

    /// The recommended model's name: the fewest parameters among the models valid over the
    /// image as good as the best valid one (cross-validated RMS within 2% and not
    /// systematically worse by the paired test); when the best valid one is not as good as
    /// ``best_fit`` but a model whose fold lies within the 5% margin beyond the image border
    /// is, the same rule among those and the valid ones (``None`` if no model valid over the
    /// image could be cross-validated).
    #[getter]
    fn recommended(&self) -> Option<&'static str> {
        self.inner.recommended.map(|m| m.name())
    }

    /// The model with the lowest cross-validated RMS of all fitted ones, valid or not.
    #[getter]
    fn best_fit(&self) -> Option<&'static str> {
        self.inner.best_fit.map(|m| m.name())
    }

    /// How far the recommended model's cross-validated RMS lies above ``best_fit``'s, as a
    /// fraction (0.57: 57% higher); when ``reference`` is not as good as ``best_fit`` (above
    /// 0.02, or systematically worse), no model valid over the image fits the lens as well as
    /// one that folds inside it, and the table says so.
    #[getter]
    fn gap_to_best_fit(&self) -> Option<f64> {
        self.inner.gap_to_best_fit
    }

    /// The model the recommendation was measured against (the lowest cross-validated RMS among
    /// the models it was chosen from); the rows' ``excess_over_reference`` are against it.
    #[getter]
    fn reference(&self) -> Option<&'static str> {
        self.inner.reference.map(|m| m.name())
    }

    /// Names of the distortion coefficients held at zero in every model that has them.
    #[getter]
    fn held_fixed(&self) -> Vec<String> {
        self.inner.held_fixed.clone()
    }

    /// Where no board corner was seen (the image corners and edge midpoints the
    /// ``poor-coverage`` warning names), the largest distance between the pixel where the
    /// recommended model sees a ray and where another model that fits as well (one-to-one over
    /// the image, as good as ``reference`` by the same rule) sees it: a dict with ``pixels``,
    /// ``model`` and ``place`` (``"top-left corner"``, ``"left edge"``, ...), or None when the
    /// corners reached every image corner and edge or no other model fits as well.
    #[getter]
    fn uncovered_disagreement<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        self.inner
            .uncovered_disagreement
            .as_ref()
            .map(|d| {
                let dict = PyDict::new(py);
                dict.set_item("pixels", d.pixels)?;
                dict.set_item("model", d.model.name())?;
                dict.set_item("place", &d.place)?;
                Ok(dict)
            })
            .transpose()
    }

    /// The ``to_json()`` text (or a ``calib single --compare-models -o FILE`` file) as a
    /// comparison again. Raises ``ValueError`` when the text is not such a comparison.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let inner = serde_json::from_str(text)
            .map_err(|e| PyValueError::new_err(format!("text: not a model comparison: {e}")))?;
        Ok(Self { inner })
    }

    /// Pickling (and ``copy``) through the JSON form, which holds every number exactly.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let from_json = py.get_type::<Self>().getattr("from_json")?;
        Ok((from_json, (self.to_json()?,)))
    }

    /// The table ``calib single --compare-models`` prints, with the recommendation.
    fn table(&self) -> String {
        self.inner.table()
    }

    /// The comparison as JSON text, what ``calib single --compare-models -o FILE`` writes
    /// (docs/formats.md, "Model comparison").
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.inner).map_err(calibration_error)
    }

    fn __str__(&self) -> String {
        self.inner.table()
    }

    fn __repr__(&self) -> String {
        format!(
            "ModelComparison(models=[{}], recommended={})",
            self.inner
                .rows
                .iter()
                .map(|r| format!("{:?}", r.model.name()))
                .collect::<Vec<_>>()
                .join(", "),
            self.inner
                .recommended
                .map_or("None".to_string(), |m| format!("{:?}", m.name()))
        )
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(compare_models, m)?)?;
    m.add_class::<ModelRow>()?;
    m.add_class::<ModelComparison>()?;
    Ok(())
}
