//! Writing a calibration in another tool's format, and reading any supported file back.

use crate::calibration::{CameraCalibration, CameraRig, StereoRig};
use crate::error::ExportError;
use crate::yaml::{self, Doc};
use crate::{Calibrated, kalibr, opencv, ros};
use std::path::{Path, PathBuf};

/// A file format of another tool.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Format {
    /// OpenCV FileStorage YAML ([`crate::opencv`]).
    OpenCv,
    /// ROS camera_info YAML, one file per camera ([`crate::ros`]).
    Ros,
    /// Kalibr camchain YAML ([`crate::kalibr`]).
    Kalibr,
}

impl Format {
    /// Every format.
    pub const ALL: [Format; 3] = [Format::OpenCv, Format::Ros, Format::Kalibr];

    /// The name on the command line: `opencv`, `ros`, `kalibr`.
    pub fn name(self) -> &'static str {
        match self {
            Format::OpenCv => "opencv",
            Format::Ros => "ros",
            Format::Kalibr => "kalibr",
        }
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Format {
    type Err = ExportError;
    fn from_str(s: &str) -> Result<Self, ExportError> {
        Format::ALL
            .into_iter()
            .find(|f| f.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| {
                ExportError::invalid(
                    "export format",
                    format!("unknown format '{s}' (known: opencv, ros, kalibr)"),
                )
            })
    }
}

/// Settings of an export.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct ExportOptions {
    /// Free scaling of the rectification (stereo, OpenCV and ROS) and of a single camera's ROS
    /// projection matrix: `0..=1`; `None` is OpenCV's default scaling for stereo and 0 for a
    /// single camera. Default `Some(0.0)` (only valid pixels, ROS's default).
    pub alpha: Option<f64>,
    /// Factor applied to translations on export (the rig's `T`, `P2`'s translation, `Q`):
    /// board units to the other tool's unit, e.g. 0.001 for a board in millimetres when ROS or
    /// Kalibr expect metres. Default 1.
    pub translation_scale: f64,
}

impl Default for ExportOptions {
    fn default() -> Self {
        Self {
            alpha: Some(0.0),
            translation_scale: 1.0,
        }
    }
}

impl ExportOptions {
    /// Options with this alpha and translation scale (checked).
    pub fn new(alpha: Option<f64>, translation_scale: f64) -> Result<Self, ExportError> {
        if let Some(a) = alpha {
            crate::undistort::check_alpha(a)?;
        }
        if !(translation_scale.is_finite() && translation_scale > 0.0) {
            return Err(ExportError::invalid(
                "translation scale",
                format!("expected a positive number, got {translation_scale}"),
            ));
        }
        Ok(Self {
            alpha,
            translation_scale,
        })
    }
}

/// The files of an export to `path`: `path` itself, except ROS stereo and rigs, which write
/// one file per camera: `STEM-left.EXT` and `STEM-right.EXT` for stereo (`out.yaml` gives
/// `out-left.yaml` and `out-right.yaml`), `STEM-NAME.EXT` for each camera of a rig (characters
/// other than letters, digits, `_`, `-` and `.` in a name become `_`; a camera whose name is
/// empty, starts with `.` or gives the same file as an earlier camera's is `STEM-cam{i}.EXT`,
/// with `_` appended while that is taken).
pub fn export_paths(calibration: &Calibrated, format: Format, path: &Path) -> Vec<PathBuf> {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    let named = |suffixes: Vec<String>| {
        suffixes
            .iter()
            .map(|s| path.with_file_name(format!("{stem}-{s}{ext}")))
            .collect()
    };
    match (format, calibration) {
        (Format::Ros, Calibrated::Stereo(_)) => named(vec!["left".into(), "right".into()]),
        (Format::Ros, Calibrated::Rig(r)) => {
            let safe: Vec<String> = r
                .cameras
                .iter()
                .map(|c| {
                    c.name
                        .chars()
                        .map(|ch| {
                            if ch.is_ascii_alphanumeric() || matches!(ch, '_' | '-' | '.') {
                                ch
                            } else {
                                '_'
                            }
                        })
                        .collect()
                })
                .collect();
            // Each camera keeps its own name where it can: only a name that is empty, hidden
            // (leading '.') or already taken by an earlier camera falls back to `cam{i}`, made
            // unique against every name in use (a camera may itself be called "cam0").
            let usable = |i: usize| {
                let s = &safe[i];
                !s.is_empty() && !s.starts_with('.') && !safe[..i].contains(s)
            };
            let mut taken: Vec<String> = (0..safe.len())
                .filter(|&i| usable(i))
                .map(|i| safe[i].clone())
                .collect();
            let names = (0..safe.len())
                .map(|i| {
                    if usable(i) {
                        return safe[i].clone();
                    }
                    let mut name = format!("cam{i}");
                    while taken.contains(&name) {
                        name.push('_');
                    }
                    taken.push(name.clone());
                    name
                })
                .collect();
            named(names)
        }
        _ => vec![path.to_path_buf()],
    }
}

/// Refuses a lens model that `format` cannot hold whatever the coefficients (Kalibr: the
/// rational models; ROS: thin-prism12), so a command can say so before calibrating.
pub fn check_format_takes_model(
    format: Format,
    model: camera_model::CameraModel,
) -> Result<(), ExportError> {
    match format {
        Format::OpenCv => Ok(()),
        Format::Ros => ros::check_model(model),
        Format::Kalibr => kalibr::check_model(model),
    }
}

/// An export rendered but not yet written ([`render_export`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct RenderedExport {
    /// The texts, one per file of [`export_paths`].
    pub texts: Vec<String>,
    /// What the files leave out and why, for the caller to warn about: an OpenCV stereo file
    /// without its rectification (`R1 ... Q`), which cannot be computed for this rig (the
    /// files say so in a comment too). Empty for a complete export.
    pub omissions: Vec<String>,
}

/// The texts of an export and what they leave out ([`RenderedExport`]).
pub fn render_export(
    calibration: &Calibrated,
    format: Format,
    options: &ExportOptions,
) -> Result<RenderedExport, ExportError> {
    let (texts, omissions) = match format {
        Format::OpenCv => {
            let (text, note) = opencv::write_noting(calibration, options)?;
            (vec![text], note.into_iter().collect())
        }
        Format::Ros => (ros::write(calibration, options)?, Vec::new()),
        Format::Kalibr => (vec![kalibr::write(calibration, options)?], Vec::new()),
    };
    Ok(RenderedExport { texts, omissions })
}

/// The texts of an export, one per file of [`export_paths`] ([`render_export`] without what
/// they leave out).
pub fn export_texts(
    calibration: &Calibrated,
    format: Format,
    options: &ExportOptions,
) -> Result<Vec<String>, ExportError> {
    render_export(calibration, format, options).map(|r| r.texts)
}

/// Writes `calibration` in `format` to `path` (see [`export_paths`]; [`write_export`]): a
/// failure leaves every previous file in place. Returns the files written. What a file leaves
/// out ([`RenderedExport::omissions`]) is not reported here: callers that warn use
/// [`render_export`] and [`write_export`].
pub fn export(
    calibration: &Calibrated,
    format: Format,
    path: &Path,
    options: &ExportOptions,
) -> Result<Vec<PathBuf>, ExportError> {
    let rendered = render_export(calibration, format, options)?;
    let paths = export_paths(calibration, format, path);
    write_export(&rendered, &paths)?;
    Ok(paths)
}

/// Writes a rendered export to `paths` (its [`export_paths`]) as a group
/// ([`calib_core::io::write_group_atomically`]): a ROS stereo pair's or rig's files are replaced
/// together, or a failure leaves every previous file as it was.
pub fn write_export(rendered: &RenderedExport, paths: &[PathBuf]) -> Result<(), ExportError> {
    let group: Vec<(PathBuf, &[u8])> = paths
        .iter()
        .cloned()
        .zip(rendered.texts.iter().map(String::as_bytes))
        .collect();
    calib_core::io::write_group_atomically(&group).map_err(|(path, source)| ExportError::Write {
        path: path.display().to_string(),
        source,
    })
}

/// Parses a calibration from text: a `calib single`, `calib stereo` or `calib rig` result (JSON), an OpenCV
/// FileStorage YAML, a ROS camera_info YAML or a Kalibr camchain. `path` names the source in
/// errors.
pub fn parse_calibration(text: &str, path: &str) -> Result<Calibrated, ExportError> {
    if text.trim_start().starts_with('{') {
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| ExportError::Syntax {
                path: path.to_string(),
                reason: e.to_string(),
            })?;
        let format = value
            .get("format")
            .and_then(|f| f.as_str())
            .unwrap_or("")
            .to_string();
        let content = |reason: &dyn std::fmt::Display| ExportError::Syntax {
            path: path.to_string(),
            reason: reason.to_string(),
        };
        let calibrated = if format.starts_with("calib-single-result/") {
            let c = calib_single::Calibration::from_json(value).map_err(|e| content(&e))?;
            Calibrated::Single(CameraCalibration::from(&c))
        } else if format.starts_with("calib-stereo-result/") {
            let s = calib_stereo::StereoCalibration::from_json(value).map_err(|e| content(&e))?;
            Calibrated::Stereo(StereoRig::from(&s))
        } else if format.starts_with("calib-rig-result/") {
            let r = calib_rig::RigCalibration::from_json(value).map_err(|e| content(&e))?;
            Calibrated::Rig(CameraRig::from(&r))
        } else {
            return Err(ExportError::UnknownFormat {
                path: path.to_string(),
            });
        };
        calibrated.check().map_err(|e| content(&e))?;
        return Ok(calibrated);
    }
    let value = yaml::parse(text, path)?;
    let doc = Doc { path };
    if kalibr::recognizes(&value) {
        kalibr::read(&doc, &value)
    } else if ros::recognizes(&value) {
        ros::read(&doc, &value).map(Calibrated::Single)
    } else if opencv::recognizes(text, &value) {
        opencv::read(&doc, &value)
    } else {
        Err(ExportError::UnknownFormat {
            path: path.to_string(),
        })
    }
}

/// Reads a calibration file of any supported kind ([`parse_calibration`]), at most
/// [`calib_core::io::DEFAULT_MAX_INPUT_BYTES`].
pub fn read_calibration(path: &Path) -> Result<Calibrated, ExportError> {
    let (text, name) = calib_core::read_text(path, calib_core::io::DEFAULT_MAX_INPUT_BYTES)?;
    parse_calibration(&text, &name)
}
