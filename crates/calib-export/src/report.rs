//! An HTML report of a calibration: `index.html` and one SVG per plot, drawn with `plotters`
//! (no browser needed to produce it). How to read each plot: `docs/after-calibration.md`.
//!
//! Per camera:
//!
//! * `residuals-CAM.svg`: each observed corner's reprojection error as an arrow (scaled),
//!   outliers (rejected points) in red; above 20000 used corners every k-th (said in the caption);
//! * `mean-residuals-CAM.svg`: the mean error of the used corners per cell of the image, as
//!   arrows (systematic patterns the per-corner arrows hide in their noise);
//! * `scatter-CAM.svg`: the errors `(dx, dy)` as a scatter, outliers in red;
//! * `coverage-CAM.svg`: how many corners were observed in each cell of the image;
//! * `rms-CAM.svg`: RMS per view, worst first;
//! * `poses-CAM.svg`: the camera's frustum and the board in every view, in 3-D;
//! * `distortion-CAM.svg`: the distortion field, `|distorted - undistorted|` in pixels, with arrows;
//! * `uncertainty-CAM.svg`: the standard deviation (worst direction, pixels) of where a point
//!   projects, from the intrinsics' covariance ([`crate::covariance`]).
//!
//! The residual, coverage and uncertainty plots need the observations (the board points and
//! pixels); without them the report has the other plots and says what is missing.

use crate::covariance::{CovarianceView, Uncertainty, worst_std};
use crate::error::ExportError;
use calib_core::ImageSize;
use camera_model::{AnyCamera, Pose, UndistortOptions};
use nalgebra::{Point3, Vector2, Vector3};
use plotters::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Board points and the pixels where they were measured, in the same order.
pub type ViewPoints = (Vec<Point3<f64>>, Vec<Vector2<f64>>);

/// A measured pixel, its error (projected minus measured, pixels) and whether it was rejected.
type Residual = (Vector2<f64>, Vector2<f64>, bool);

/// The plots of a camera (with their SVG text) and notes about what is missing.
type CameraPlots = (Vec<(Plot, String)>, Vec<String>);

/// One view of one camera in a report.
#[derive(Debug, Clone)]
pub struct ReportView {
    /// The view's name (image file).
    pub name: String,
    /// Board-to-camera pose.
    pub pose: Pose,
    /// RMS of the used points, pixels.
    pub rms: f64,
    /// Board points and measured pixels, when the observations are known.
    pub points: Option<ViewPoints>,
    /// Indices of the points rejected as outliers.
    pub rejected: Vec<usize>,
}

/// One camera in a report.
#[derive(Debug, Clone)]
pub struct ReportCamera {
    /// Its name ("camera", "left", "right"): also the SVG files' suffix.
    pub name: String,
    /// The calibrated camera.
    pub camera: AnyCamera,
    /// Image size.
    pub image_size: ImageSize,
    /// Indices (in `[fx, fy, cx, cy, distortion...]`) of the parameters held fixed.
    pub fixed: Vec<usize>,
    /// The views.
    pub views: Vec<ReportView>,
}

/// What a report shows.
#[derive(Debug, Clone)]
pub struct ReportInput {
    /// Title of the page.
    pub title: String,
    /// The calibration's summary text (shown as is).
    pub summary: String,
    /// The result's warnings (`code: message`), shown in a box at the top of the page.
    pub warnings: Vec<String>,
    /// The cameras.
    pub cameras: Vec<ReportCamera>,
    /// The layout of a rig (stereo or N cameras), drawn once for the whole page; `None` for a
    /// single camera.
    pub layout: Option<RigLayout>,
}

/// Where a rig's cameras and boards are, in the reference camera's frame.
#[derive(Debug, Clone)]
pub struct RigLayout {
    /// Each camera's transform from the reference camera, `X_cam = R X_ref + T`, in the order
    /// of [`ReportInput::cameras`].
    pub transforms: Vec<Pose>,
    /// The board's pose in each frame, board to reference camera.
    pub boards: Vec<Pose>,
}

fn fixed_indices(camera: &AnyCamera, names: &[String]) -> Vec<usize> {
    let mut all: Vec<&str> = vec!["fx", "fy", "cx", "cy"];
    all.extend(camera.model.distortion_names());
    names
        .iter()
        .filter_map(|n| all.iter().position(|a| a == n))
        .collect()
}

fn observation_mismatch(what: &str) -> ExportError {
    ExportError::invalid(
        "report",
        format!(
            "the observation file does not match the result ({what}); give the file the result was calibrated from"
        ),
    )
}

/// Refuses observations that do not give (within 5%: duplicate points the calibration dropped
/// count here) the view's stored RMS at its pose: the file is not the one the result was
/// calibrated from (a different camera, another set's views, reordered corners).
fn check_view_rms(
    camera: &AnyCamera,
    pose: &Pose,
    points: &ViewPoints,
    rejected: &[usize],
    stored: f64,
    what: &str,
) -> Result<(), ExportError> {
    let (object, pixels) = points;
    let (mut sum, mut n) = (0.0, 0usize);
    for (i, (x, m)) in object.iter().zip(pixels).enumerate() {
        if rejected.contains(&i) {
            continue;
        }
        match camera.project(pose, x) {
            Ok(q) => {
                sum += (q - m).norm_squared();
                n += 1;
            }
            Err(_) => {
                return Err(observation_mismatch(&format!(
                    "{what}: a point does not project"
                )));
            }
        }
    }
    let rms = if n > 0 { (sum / n as f64).sqrt() } else { 0.0 };
    if (rms - stored).abs() > 0.05 * stored + 1e-6 {
        return Err(observation_mismatch(&format!(
            "{what}: RMS {rms:.4} px from the file, {stored:.4} px in the result"
        )));
    }
    Ok(())
}

/// One view of a report: the observed points (when the observation file is given, the view
/// `observed` of it; `None` inside `Some` when the file lacks the view) checked against the
/// stored RMS at `pose`. `what` names the view in messages.
fn report_view(
    camera: &AnyCamera,
    name: String,
    pose: Pose,
    rms: f64,
    rejected: &[usize],
    observed: Option<Option<&calib_core::View>>,
    what: &str,
) -> Result<ReportView, ExportError> {
    let points = match observed {
        None => None,
        Some(None) => return Err(observation_mismatch(&format!("no {what}"))),
        Some(Some(view)) => {
            if rejected.iter().any(|&i| i >= view.object_points.len()) {
                return Err(observation_mismatch(&format!("{what} has fewer points")));
            }
            let points: ViewPoints = (
                view.object_points.clone(),
                view.image_points.iter().map(|q| q.coords).collect(),
            );
            check_view_rms(camera, &pose, &points, rejected, rms, what)?;
            Some(points)
        }
    };
    Ok(ReportView {
        name,
        pose,
        rms,
        points,
        rejected: rejected.to_vec(),
    })
}

/// The name of a rig's camera in a report: its own, else `fallback`.
fn camera_name(estimate: &calib_core::CameraEstimate, fallback: String) -> String {
    if estimate.name.is_empty() {
        fallback
    } else {
        estimate.name.clone()
    }
}

impl ReportInput {
    /// The report of a single-camera result, with the observations it was calibrated from (if
    /// given: they must be the same file).
    pub fn single(
        result: &calib_single::Calibration,
        observations: Option<&calib_single::Observations>,
    ) -> Result<Self, ExportError> {
        let views = result
            .views
            .iter()
            .map(|v| {
                report_view(
                    &result.camera,
                    v.name.clone(),
                    v.pose,
                    v.rms,
                    &v.rejected_points,
                    observations.map(|o| o.views.get(v.index)),
                    &format!("view {} ({})", v.index, v.name),
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(ReportInput {
            title: "Single-camera calibration".into(),
            summary: result.summary(),
            warnings: result.warnings.iter().map(ToString::to_string).collect(),
            cameras: vec![ReportCamera {
                name: "camera".into(),
                camera: result.camera.clone(),
                image_size: result.image_size,
                fixed: fixed_indices(&result.camera, &result.fixed_parameters),
                views,
            }],
            layout: None,
        })
    }

    /// The report of a stereo result (one section per camera; the right camera's poses are the
    /// left ones composed with the rig).
    pub fn stereo(
        result: &calib_stereo::StereoCalibration,
        observations: Option<&calib_stereo::StereoObservations>,
    ) -> Result<Self, ExportError> {
        let mut cameras = Vec::new();
        for (side, estimate) in [(0, &result.left), (1, &result.right)] {
            let side_name = ["left", "right"][side];
            let views = result
                .pairs
                .iter()
                .map(|p| {
                    let (pose, rejected, name, rms) = if side == 0 {
                        (p.left_pose, &p.rejected_left, &p.names.0, p.rms_left)
                    } else {
                        (
                            result.rig.compose(&p.left_pose),
                            &p.rejected_right,
                            &p.names.1,
                            p.rms_right,
                        )
                    };
                    let observed = observations.map(|o| {
                        o.pairs
                            .get(p.index)
                            .map(|pair| if side == 0 { &pair.left } else { &pair.right })
                    });
                    report_view(
                        &estimate.camera,
                        name.clone(),
                        pose,
                        rms,
                        rejected,
                        observed,
                        &format!("pair {} ({side_name})", p.index),
                    )
                })
                .collect::<Result<Vec<_>, _>>()?;
            cameras.push(ReportCamera {
                name: camera_name(estimate, side_name.to_string()),
                camera: estimate.camera.clone(),
                image_size: estimate.image_size,
                fixed: fixed_indices(&estimate.camera, &estimate.fixed_parameters),
                views,
            });
        }
        Ok(ReportInput {
            title: "Stereo calibration".into(),
            summary: result.summary(),
            warnings: result.warnings.iter().map(ToString::to_string).collect(),
            cameras,
            layout: Some(RigLayout {
                transforms: vec![Pose::identity(), result.rig],
                boards: result.pairs.iter().map(|p| p.left_pose).collect(),
            }),
        })
    }

    /// The report of a rig result (one section per camera; a camera's pose in a frame is the
    /// frame's board pose in the reference camera composed with the camera's rig transform).
    /// The observations, if given, must be the file the rig was calibrated from.
    pub fn rig(
        result: &calib_rig::RigCalibration,
        observations: Option<&calib_rig::RigObservations>,
    ) -> Result<Self, ExportError> {
        if let Some(o) = observations
            && o.cameras.len() != result.cameras.len()
        {
            return Err(observation_mismatch(&format!(
                "{} cameras in the file, {} in the result",
                o.cameras.len(),
                result.cameras.len()
            )));
        }
        let mut cameras = Vec::with_capacity(result.cameras.len());
        for (c, rig_camera) in result.cameras.iter().enumerate() {
            let estimate = &rig_camera.estimate;
            let name = camera_name(estimate, format!("camera {c}"));
            let mut views = Vec::new();
            for frame in &result.frames {
                let Some(view) = frame.views.iter().find(|v| v.camera == c) else {
                    continue;
                };
                let observed = observations.map(|o| {
                    o.frames
                        .get(frame.index)
                        .and_then(|f| f.observations.iter().find(|x| x.camera == c))
                        .map(|x| &x.view)
                });
                let view_name = observed
                    .flatten()
                    .map(|v| v.name.clone())
                    .filter(|n| !n.is_empty())
                    .unwrap_or_else(|| format!("frame {}", frame.index));
                views.push(report_view(
                    &estimate.camera,
                    view_name,
                    rig_camera.transform.compose(&frame.pose),
                    view.rms,
                    &view.rejected_points,
                    observed,
                    &format!("frame {} (camera '{name}')", frame.index),
                )?);
            }
            cameras.push(ReportCamera {
                name,
                camera: estimate.camera.clone(),
                image_size: estimate.image_size,
                fixed: fixed_indices(&estimate.camera, &estimate.fixed_parameters),
                views,
            });
        }
        Ok(ReportInput {
            title: format!("Rig calibration ({} cameras)", result.cameras.len()),
            summary: result.summary(),
            warnings: result.warnings.iter().map(ToString::to_string).collect(),
            cameras,
            layout: Some(RigLayout {
                transforms: result.cameras.iter().map(|c| c.transform).collect(),
                boards: result.frames.iter().map(|f| f.pose).collect(),
            }),
        })
    }
}

type DrawResult<T> = Result<T, Box<dyn std::error::Error>>;

/// A colour of the viridis-like map for `t` in `0..=1`.
fn colour(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    } * 4.0;
    let i = (t.floor() as usize).min(3);
    let f = t - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let mix = |x: f64, y: f64| (x + (y - x) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

struct Plot {
    file: String,
    title: String,
    caption: String,
}

fn svg(
    draw: impl FnOnce(&DrawingArea<SVGBackend, plotters::coord::Shift>) -> DrawResult<()>,
    size: (u32, u32),
) -> DrawResult<String> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
    }
    Ok(text)
}

/// Chart size for an image of `size`, about 640 px wide.
fn chart_size(size: ImageSize) -> (u32, u32) {
    let w = 640u32;
    let h = ((size.height as f64 / size.width as f64) * 560.0 + 80.0)
        .round()
        .clamp(200.0, 900.0) as u32;
    (w, h)
}

/// Height of the colour bar under a heat map, pixels.
const BAR_HEIGHT: u32 = 44;

/// Size of a heat map's SVG: the image chart and its colour bar.
fn heat_size(size: ImageSize) -> (u32, u32) {
    let (w, h) = chart_size(size);
    (w, h + BAR_HEIGHT)
}

/// Draws a colour bar from 0 to `max` (`label` names the unit) along the bottom of `root` and
/// returns the area above it for the map.
fn colour_bar<'b>(
    root: &DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    max: f64,
    label: &str,
) -> DrawResult<DrawingArea<SVGBackend<'b>, plotters::coord::Shift>> {
    let (_, h) = root.dim_in_pixel();
    let (top, bottom) = root.split_vertically(h.saturating_sub(BAR_HEIGHT));
    let max = if max.is_finite() && max > 0.0 {
        max
    } else {
        1.0
    };
    let mut c = ChartBuilder::on(&bottom)
        .margin_left(55)
        .margin_right(20)
        .x_label_area_size(22)
        .build_cartesian_2d(0.0..max, 0.0..1.0)?;
    c.configure_mesh()
        .disable_mesh()
        .disable_y_axis()
        .x_labels(6)
        .x_desc(label)
        .x_label_style(("sans-serif", 10))
        .draw()?;
    let steps = 60;
    c.draw_series((0..steps).map(|i| {
        let (a, b) = (i as f64 / steps as f64, (i + 1) as f64 / steps as f64);
        Rectangle::new(
            [(a * max, 0.0), (b * max, 1.0)],
            colour((a + b) / 2.0).filled(),
        )
    }))?;
    Ok(top)
}

/// The polyline of an arrow from `tail` to `tip` (chart coordinates) with a head of two strokes
/// a third of its length, 25 degrees off the shaft: barrel and pincushion fields, inward and
/// outward errors, look different.
fn arrow(tail: Vector2<f64>, tip: Vector2<f64>) -> Vec<(f64, f64)> {
    let back = (tail - tip) / 3.0;
    let (c, s) = (25f64.to_radians().cos(), 25f64.to_radians().sin());
    let turn = |v: Vector2<f64>, s: f64| Vector2::new(c * v.x - s * v.y, s * v.x + c * v.y);
    let (a, b) = (tip + turn(back, s), tip + turn(back, -s));
    vec![
        (tail.x, tail.y),
        (tip.x, tip.y),
        (a.x, a.y),
        (tip.x, tip.y),
        (b.x, b.y),
    ]
}

/// At most this many views in the RMS-per-view chart (the worst ones).
const MAX_RMS_BARS: usize = 60;

/// Band edges of the projection-uncertainty map, pixels: below the first, between each pair,
/// above the last.
const UNCERTAINTY_BANDS: [f64; 9] = [0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0, 10.0];

/// Draws a colour bar of `edges.len() + 1` bands of equal width labelled with their edges along
/// the bottom of `root` and returns the area above it for the map.
fn band_bar<'b>(
    root: &DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    edges: &[f64],
    label: &str,
) -> DrawResult<DrawingArea<SVGBackend<'b>, plotters::coord::Shift>> {
    let (_, h) = root.dim_in_pixel();
    let (top, bottom) = root.split_vertically(h.saturating_sub(BAR_HEIGHT));
    let n = edges.len() + 1;
    let mut c = ChartBuilder::on(&bottom)
        .margin_left(55)
        .margin_right(20)
        .x_label_area_size(22)
        .build_cartesian_2d(0.0..n as f64, 0.0..1.0)?;
    c.configure_mesh()
        .disable_mesh()
        .disable_y_axis()
        .x_labels(n + 1)
        .x_label_formatter(&|x| {
            let k = x.round() as usize;
            if (x - x.round()).abs() < 1e-6 && (1..n).contains(&k) {
                format!("{}", edges[k - 1])
            } else {
                String::new()
            }
        })
        .x_desc(label)
        .x_label_style(("sans-serif", 10))
        .draw()?;
    c.draw_series((0..n).map(|i| {
        Rectangle::new(
            [(i as f64, 0.0), (i as f64 + 1.0, 1.0)],
            colour((i as f64 + 0.5) / n as f64).filled(),
        )
    }))?;
    Ok(top)
}

/// Residuals `projected - measured` of each point of each view with points.
fn residuals(camera: &ReportCamera) -> Vec<Vec<Residual>> {
    camera
        .views
        .iter()
        .map(|v| match &v.points {
            Some((object, pixels)) => object
                .iter()
                .zip(pixels)
                .enumerate()
                .filter_map(|(i, (x, m))| {
                    let q = camera.camera.project(&v.pose, x).ok()?;
                    Some((*m, q - m, v.rejected.contains(&i)))
                })
                .collect(),
            None => Vec::new(),
        })
        .collect()
}

type ImageChart<'a, 'b> = ChartContext<
    'a,
    SVGBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn image_chart<'a, 'b>(
    root: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    size: ImageSize,
    caption: &str,
) -> DrawResult<ImageChart<'a, 'b>> {
    let (w, h) = (size.width as f64, size.height as f64);
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 16))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(45)
        .build_cartesian_2d(-0.5..w - 0.5, h - 0.5..-0.5)?;
    chart
        .configure_mesh()
        .x_desc("x (px)")
        .y_desc("y (px)")
        .disable_mesh()
        .draw()?;
    Ok(chart)
}

/// Writes the report into `dir` (created if needed): `index.html` and the SVG files. Every plot
/// is drawn before anything is written, and the files are written as a group
/// ([`calib_core::io::write_group_atomically`]): a failure leaves a previous report in `dir` as it
/// was. Plots of a previous report that this one does not have (another camera's, or those
/// needing observations) are removed, so the folder never mixes two reports. Returns the files
/// written.
pub fn write_report(input: &ReportInput, dir: &Path) -> Result<Vec<PathBuf>, ExportError> {
    let mut files: Vec<(String, String)> = Vec::new();
    let mut sections = String::new();
    if let Some(layout) = &input.layout {
        let text = layout_svg(input, layout)
            .map_err(|e| ExportError::invalid("report of the rig layout", e.to_string()))?;
        let file = "layout.svg".to_string();
        let _ = writeln!(
            sections,
            "<h2>Rig</h2>\n<figure><h3>Rig layout</h3><img src=\"{file}\" alt=\"Rig layout\"><figcaption>{}</figcaption></figure>",
            html(
                "Every camera (frustum, labelled) and the board in every frame (dots at the board origin, coloured by frame), in the reference camera's frame (board units), seen from above (from the reference camera's -y, its 'up'). Check that the cameras stand where they are mounted: a camera on the wrong side or facing away means mislabelled images or cameras."
            )
        );
        files.push((file, text));
    }
    let suffixes = file_suffixes(&input.cameras);
    for (camera, suffix) in input.cameras.iter().zip(&suffixes) {
        let (plots, notes) = camera_plots(camera, suffix).map_err(|e| {
            ExportError::invalid(format!("report of camera '{}'", camera.name), e.to_string())
        })?;
        let _ = writeln!(
            sections,
            "<h2>Camera '{}' ({}, {}x{})</h2>",
            html(&camera.name),
            camera.camera.model,
            camera.image_size.width,
            camera.image_size.height
        );
        for note in notes {
            let _ = writeln!(sections, "<p class=\"note\">{}</p>", html(&note));
        }
        for (plot, text) in plots {
            let _ = writeln!(
                sections,
                "<figure><h3>{}</h3><img src=\"{}\" alt=\"{}\"><figcaption>{}</figcaption></figure>",
                html(&plot.title),
                plot.file,
                html(&plot.title),
                html(&plot.caption)
            );
            files.push((plot.file, text));
        }
    }
    let warnings = if input.warnings.is_empty() {
        String::new()
    } else {
        let items: String = input
            .warnings
            .iter()
            .map(|w| format!("<li>{}</li>", html(w)))
            .collect();
        format!(
            "<div class=\"warnings\"><h2>{} warning{}: read before using this calibration</h2><ul>{items}</ul></div>\n",
            input.warnings.len(),
            if input.warnings.len() == 1 { "" } else { "s" }
        )
    };
    let page = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title>\n<style>body{{font-family:sans-serif;max-width:1400px;margin:1em auto;padding:0 1em}}figure{{display:inline-block;vertical-align:top;width:660px;margin:0.5em}}figure img{{width:640px;border:1px solid #ccc}}figcaption{{font-size:0.9em;color:#333}}pre{{background:#f4f4f4;padding:0.5em;white-space:pre-wrap}}.note{{color:#a40}}.warnings{{background:#fff4e0;border:2px solid #d80;padding:0.2em 1em;margin:1em 0}}.warnings h2{{font-size:1.1em;color:#a40}}.warnings li{{margin:0.4em 0}}</style></head>\n<body><h1>{title}</h1>\n{warnings}<pre>{summary}</pre>\n{sections}{REPORT_FOOTER}</body></html>\n",
        title = html(&input.title),
        summary = html(&input.summary),
    );
    files.push(("index.html".to_string(), page));

    std::fs::create_dir_all(dir).map_err(|source| ExportError::Write {
        path: dir.display().to_string(),
        source,
    })?;
    let stale = previous_plots(&dir.join("index.html"));
    let paths: Vec<(PathBuf, &[u8])> = files
        .iter()
        .map(|(file, text)| (dir.join(file), text.as_bytes()))
        .collect();
    calib_core::io::write_group_atomically(&paths).map_err(|(path, source)| {
        ExportError::Write {
            path: path.display().to_string(),
            source,
        }
    })?;
    for old in stale {
        if !files.iter().any(|(file, _)| *file == old) {
            let _ = std::fs::remove_file(dir.join(old));
        }
    }
    Ok(paths.into_iter().map(|(path, _)| path).collect())
}

/// The last line of every report's page: how [`previous_plots`] recognizes one.
const REPORT_FOOTER: &str = "<p>How to read these plots: docs/after-calibration.md.</p>";

/// The plot files a previous report's `index.html` shows, to be removed when the new report
/// does not write them: only if that page is a report (its footer) and only names of this
/// module's plots (`layout.svg`, `KIND-CAM.svg`, plain characters, in this folder), so a
/// folder's other files are never touched.
fn previous_plots(index: &Path) -> Vec<String> {
    const KINDS: [&str; 8] = [
        "residuals-",
        "mean-residuals-",
        "scatter-",
        "coverage-",
        "rms-",
        "poses-",
        "distortion-",
        "uncertainty-",
    ];
    let Ok(text) = std::fs::read_to_string(index) else {
        return Vec::new();
    };
    if !text.contains(REPORT_FOOTER) {
        return Vec::new();
    }
    text.split("<img src=\"")
        .skip(1)
        .filter_map(|rest| rest.split('"').next())
        .filter(|file| {
            (*file == "layout.svg"
                || (file.ends_with(".svg") && KINDS.iter().any(|k| file.starts_with(k))))
                && file
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
        })
        .map(str::to_string)
        .collect()
}

/// The file-name suffix of each camera's plots: its name with characters outside
/// `[A-Za-z0-9_-]` replaced by `_`, and the camera's index appended where two names would give
/// the same suffix or the name has no such characters at all (`左カメラ` and `右カメラ`, or
/// `cam 1` and `cam.1`), so one camera's plots never overwrite another's.
fn file_suffixes(cameras: &[ReportCamera]) -> Vec<String> {
    let plain: Vec<String> = cameras.iter().map(|c| safe_name(&c.name)).collect();
    let suffixes: Vec<String> = plain
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let shared = plain.iter().filter(|other| *other == name).count() > 1;
            let meaningless = name.chars().all(|c| c == '_');
            if shared || meaningless {
                format!("{name}-{i}")
            } else {
                name.clone()
            }
        })
        .collect();
    let unique = suffixes
        .iter()
        .enumerate()
        .all(|(i, a)| suffixes[..i].iter().all(|b| b != a));
    if unique {
        suffixes
    } else {
        // A name like `cam-1` beside two cameras named `cam`: number them all.
        (0..cameras.len()).map(|i| format!("camera-{i}")).collect()
    }
}

fn html(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn safe_name(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Most used corners the per-corner plots (arrows, scatter) draw; beyond, every k-th.
const MAX_DRAWN_POINTS: usize = 20_000;

/// "2nd", "3rd", "11th", ...
fn ordinal(n: usize) -> String {
    let suffix = match (n % 10, n % 100) {
        (_, 11..=13) => "th",
        (1, _) => "st",
        (2, _) => "nd",
        (3, _) => "rd",
        _ => "th",
    };
    format!("{n}{suffix}")
}

fn camera_plots(camera: &ReportCamera, name: &str) -> DrawResult<CameraPlots> {
    let size = camera.image_size;
    let chart = chart_size(size);
    let mut plots = Vec::new();
    let mut notes = Vec::new();
    let res = residuals(camera);
    let have_points = camera.views.iter().any(|v| v.points.is_some());
    if have_points {
        let all: Vec<&Residual> = res.iter().flatten().collect();
        let inlier_norms: Vec<f64> = all.iter().filter(|r| !r.2).map(|r| r.1.norm()).collect();
        // Arrows: the 95th percentile of the inlier errors drawn 3% of the image width long (not
        // the largest: one gross error would shrink every other arrow to a dot).
        let typical = percentile(&inlier_norms, 0.95).max(1e-6);
        let scale = 0.03 * size.width as f64 / typical;
        // Every `stride`-th used corner is drawn: a million arrows made a 75 MB file that no
        // browser shows; the statistics above and the mean-error plot use them all.
        let stride = inlier_norms.len().div_ceil(MAX_DRAWN_POINTS).max(1);
        let drawn: Vec<&&Residual> = all.iter().filter(|r| !r.2).step_by(stride).collect();
        let thinned = if stride > 1 {
            format!(
                " For a readable file every {} corner of the {} used ones is drawn ({}); the rejected ones all are.",
                ordinal(stride),
                inlier_norms.len(),
                drawn.len()
            )
        } else {
            String::new()
        };
        let text = svg(
            |root| {
                let mut c = image_chart(
                    root,
                    size,
                    &format!(
                        "reprojection errors x{scale:.0}, 95% under {typical:.2} px (red: rejected)"
                    ),
                )?;
                c.draw_series(drawn.iter().map(|(m, e, _)| {
                    PathElement::new(
                        vec![(m.x, m.y), (m.x + scale * e.x, m.y + scale * e.y)],
                        BLUE.stroke_width(1),
                    )
                }))?;
                c.draw_series(
                    drawn
                        .iter()
                        .map(|(m, _, _)| Circle::new((m.x, m.y), 1, BLUE.filled())),
                )?;
                c.draw_series(
                    all.iter()
                        .filter(|r| r.2)
                        .map(|(m, _, _)| Cross::new((m.x, m.y), 4, RED.stroke_width(2))),
                )?;
                Ok(())
            },
            chart,
        )?;
        plots.push((Plot { file: format!("residuals-{name}.svg"), title: "Reprojection errors over the image".into(), caption: format!("Each observed corner with its error (projected minus measured) as an arrow, magnified {scale:.0} times (an arrow {:.0} px long is {typical:.2} px, the error 95% of the used corners stay under); rejected outliers as red crosses. Errors should look random; arrows that line up (all outward at the edges, swirling) mean the lens model misses something: the mean-error plot below shows such patterns without the noise.{thinned}", 0.03 * size.width as f64) }, text));
        // Axes from the used corners: rejected ones far outside are drawn at the border.
        let lim = all
            .iter()
            .filter(|r| !r.2)
            .map(|r| r.1.x.abs().max(r.1.y.abs()))
            .fold(0.0, f64::max)
            .max(1e-3)
            * 1.1;
        let clamp = |e: &Vector2<f64>| (e.x.clamp(-lim, lim), e.y.clamp(-lim, lim));
        let beyond = all
            .iter()
            .filter(|r| r.1.x.abs() > lim || r.1.y.abs() > lim)
            .count();
        let text = svg(
            |root| {
                let mut c = ChartBuilder::on(root)
                    .caption(
                        "reprojection error scatter (red: rejected outliers)",
                        ("sans-serif", 16),
                    )
                    .margin(10)
                    .x_label_area_size(30)
                    .y_label_area_size(45)
                    .build_cartesian_2d(-lim..lim, lim..-lim)?;
                c.configure_mesh()
                    .x_desc("dx (px), right")
                    .y_desc("dy (px), down as in the image")
                    .draw()?;
                c.draw_series(
                    drawn
                        .iter()
                        .map(|(_, e, _)| Circle::new(clamp(e), 2, BLUE.mix(0.5).filled())),
                )?;
                c.draw_series(
                    all.iter()
                        .filter(|r| r.2)
                        .map(|(_, e, _)| Cross::new(clamp(e), 4, RED.stroke_width(2))),
                )?;
                Ok(())
            },
            (520, 520),
        )?;
        plots.push((Plot { file: format!("scatter-{name}.svg"), title: "Error scatter".into(), caption: format!("Every point's error (dx, dy; dy down, as in the image). A round cloud centred at zero is good; an elongated or offset cloud, or several clusters, point to a model or data problem. The axes span the used corners; {beyond} rejected corner{} beyond them {} drawn on the border.{thinned}", if beyond == 1 { "" } else { "s" }, if beyond == 1 { "is" } else { "are" }) }, text));
        plots.push(mean_residuals_plot(camera, &all, typical, name)?);
        // Coverage: counts per cell of about 1/16 of the width.
        let cell = (size.width.max(size.height) as f64 / 16.0).max(1.0);
        let (nx, ny) = (
            (size.width as f64 / cell).ceil() as usize,
            (size.height as f64 / cell).ceil() as usize,
        );
        let mut counts = vec![0usize; nx * ny];
        for (m, _, _) in all.iter().filter(|r| !r.2) {
            let (i, j) = ((m.x + 0.5) / cell, (m.y + 0.5) / cell);
            if i >= 0.0 && j >= 0.0 && (i as usize) < nx && (j as usize) < ny {
                counts[j as usize * nx + i as usize] += 1;
            }
        }
        let most = *counts.iter().max().unwrap_or(&1) as f64;
        let empty = counts.iter().filter(|&&c| c == 0).count();
        // The `poor-coverage` warning's places: an arc of its radius around each image corner
        // or edge midpoint that no used corner came that near.
        let uncovered = calib_core::diagnostics::uncovered_places(
            size,
            all.iter().filter(|r| !r.2).map(|r| &r.0),
        );
        let reach = calib_core::diagnostics::COVERAGE_GAP * size.half_diagonal();
        let text = svg(
            |root| {
                let map = colour_bar(root, most, "corners per cell (grey: none)")?;
                let mut c = image_chart(
                    &map,
                    size,
                    &format!(
                        "used corners per {cell:.0} px cell (max {most:.0}; {empty} of {} cells empty)",
                        nx * ny
                    ),
                )?;
                c.draw_series((0..nx * ny).map(|k| {
                    let (i, j) = ((k % nx) as f64, (k / nx) as f64);
                    let colour = if counts[k] == 0 {
                        RGBColor(235, 235, 235)
                    } else {
                        colour(counts[k] as f64 / most)
                    };
                    Rectangle::new(
                        [
                            (i * cell - 0.5, j * cell - 0.5),
                            ((i + 1.0) * cell - 0.5, (j + 1.0) * cell - 0.5),
                        ],
                        colour.filled(),
                    )
                }))?;
                // Clipped to the image by hand: the chart does not clip paths.
                let (w, h) = (size.width as f64 - 0.5, size.height as f64 - 0.5);
                for place in &uncovered {
                    let arc: Vec<(f64, f64)> = (0..=96)
                        .map(|k| {
                            let t = std::f64::consts::TAU * k as f64 / 96.0;
                            (
                                (place.pixel.x + reach * t.cos()).clamp(-0.5, w),
                                (place.pixel.y + reach * t.sin()).clamp(-0.5, h),
                            )
                        })
                        .collect();
                    c.draw_series(std::iter::once(PathElement::new(arc, RED.stroke_width(2))))?;
                }
                Ok(())
            },
            heat_size(size),
        )?;
        let marked = if uncovered.is_empty() {
            String::new()
        } else {
            format!(
                " Red: around each image corner or edge midpoint ({}) that no used corner came within {reach:.0} px of ({:.0}% of the half-diagonal), the reach of the poor-coverage warning (which leaves out a fisheye's places more than 90 degrees off-axis and places beyond the model's fold).",
                uncovered
                    .iter()
                    .map(|p| p.name)
                    .collect::<Vec<_>>()
                    .join(", "),
                100.0 * calib_core::diagnostics::COVERAGE_GAP
            )
        };
        plots.push((Plot { file: format!("coverage-{name}.svg"), title: "Coverage".into(), caption: format!("How many corners the calibration used in each cell (grey: none; rejected outliers are not counted). The model is only constrained where corners were seen: empty corners and edges of the image are where a calibration extrapolates, and where distortion errors hide. Add views with the board there.{marked}") }, text));
    } else {
        notes.push("No observations were given (calib report --observations OBS.json): the residual, scatter, coverage and uncertainty plots are left out.".to_string());
    }

    // Per-view RMS, worst first: one labelled horizontal bar per view (the worst
    // `MAX_RMS_BARS` when there are more).
    let mut order: Vec<&ReportView> = camera.views.iter().collect();
    order.sort_by(|a, b| b.rms.total_cmp(&a.rms));
    let total = order.len();
    order.truncate(MAX_RMS_BARS);
    let top = order.first().map_or(1.0, |v| v.rms).max(1e-6) * 1.15;
    let n = order.len().max(1);
    let rejected = |v: &ReportView| v.rejected.len();
    let label_width = order
        .iter()
        .map(|v| v.name.chars().count())
        .max()
        .unwrap_or(4)
        .clamp(4, 40) as u32
        * 6
        + 10;
    let text = svg(
        |root| {
            let mut c = ChartBuilder::on(root)
                .caption("RMS per view, worst first", ("sans-serif", 16))
                .margin(10)
                .x_label_area_size(30)
                .y_label_area_size(label_width)
                .build_cartesian_2d(0.0..top, n as f64..0.0)?;
            c.configure_mesh()
                .x_desc("RMS of the used corners (px)")
                .y_labels(n * 2 + 1)
                .y_label_formatter(&|y| {
                    // Labels at bar centres only (k + 0.5).
                    let k = (y - 0.5).round();
                    if (y - 0.5 - k).abs() > 1e-6 || k < 0.0 {
                        return String::new();
                    }
                    order.get(k as usize).map_or(String::new(), |v| {
                        let name: String = v.name.chars().take(40).collect();
                        name
                    })
                })
                .y_label_style(("sans-serif", 10))
                .disable_y_mesh()
                .draw()?;
            c.draw_series(order.iter().enumerate().map(|(i, v)| {
                Rectangle::new(
                    [(0.0, i as f64 + 0.15), (v.rms, i as f64 + 0.85)],
                    BLUE.mix(0.7).filled(),
                )
            }))?;
            c.draw_series(order.iter().enumerate().map(|(i, v)| {
                let note = match rejected(v) {
                    0 => format!("{:.3}", v.rms),
                    k => format!("{:.3} ({k} rejected)", v.rms),
                };
                Text::new(
                    note,
                    (v.rms + top * 0.01, i as f64 + 0.2),
                    ("sans-serif", 10).into_font(),
                )
            }))?;
            Ok(())
        },
        (640, (60 + 16 * n as u32).max(140)),
    )?;
    let shown = if total > order.len() {
        format!(" The {} worst of {total} views are shown.", order.len())
    } else {
        String::new()
    };
    plots.push((Plot { file: format!("rms-{name}.svg"), title: "RMS per view".into(), caption: format!("Each view's RMS reprojection error over the corners the calibration used, worst first, with the number of corners rejected as outliers in that view. A view far above the others (a blurred image, a mislabelled board), or with many rejected corners, is worth checking or removing.{shown}") }, text));

    let stride = pose_stride(camera);
    let which = if stride > 1 {
        format!(" (one view in {stride} of the {})", camera.views.len())
    } else {
        String::new()
    };
    let outline = if have_points {
        ""
    } else {
        " Without the observations each board is drawn as a square at its origin, a tenth of its distance wide."
    };
    plots.push((Plot { file: format!("poses-{name}.svg"), title: "Board poses".into(), caption: format!("The camera (frustum at the origin, looking along z) and the board in every view{which}, in the camera's frame (board units). Good data shows boards at several distances and tilted in different directions, not all parallel to the image.{outline}") }, poses_svg(camera)?));
    let validity = camera
        .camera
        .validity(camera.image_size.width, camera.image_size.height);
    let (text, max_shift) = distortion_svg(camera, &validity)?;
    let valid_text = if validity.covers_image(calib_core::diagnostics::VALIDITY_MARGIN) {
        if validity.valid_radius_px.is_finite() {
            let shown = if validity.valid_radius_px < validity.image_radius_px {
                "black dashes where the fold crosses the image: the fold is farther than the image border along every direction, nearer than the farthest corner along some"
            } else {
                "outside the image"
            };
            format!(
                "The model is one-to-one over the whole image: its nearest fold is {:.0} px from the principal point ({shown}), the farthest image corner {:.0} px away (validity coverage {:.2}: the fold's distance over the image border's, along the worst direction).",
                validity.valid_radius_px, validity.image_radius_px, validity.coverage
            )
        } else {
            format!(
                "The model is one-to-one over the whole image and beyond: no fold was found as far as it was checked (four image radii, or the projection's range), the farthest image corner being {:.0} px from the principal point.",
                validity.image_radius_px
            )
        }
    } else {
        format!(
            "The model stops being one-to-one {:.0} px from the principal point, inside the image or less than 5% beyond its border (red dashes where the fold crosses the image; the farthest image corner is {:.0} px away, coverage {:.2}): beyond the dashes the distortion folds over and pixels there cannot be trusted (see the model-invalid warning; a different --model may fit).",
            validity.valid_radius_px, validity.image_radius_px, validity.coverage
        )
    };
    plots.push((Plot { file: format!("distortion-{name}.svg"), title: "Distortion field".into(), caption: format!("How far the lens moves each pixel from where an ideal pinhole camera would put it (|distorted - undistorted|, colour, up to {max_shift:.1} px) and in which direction (arrows, towards the distorted position). Pixels where the model cannot be inverted are left white. {valid_text}") }, text));
    if have_points {
        match uncertainty_svg(camera) {
            Ok(u) => plots.push((Plot { file: format!("uncertainty-{name}.svg"), title: "Projection uncertainty".into(), caption: format!("Standard deviation (worst direction, pixels) of where a point seen at each pixel projects, {} board units from the camera (the boards' median distance), propagated from the covariance of the intrinsics and the board poses as mrcal does (the point is fixed relative to the boards). Median over the image {:.3} px; at infinity {:.3} px; at twice the distance {:.3} px; intrinsics alone (camera frame held) {:.3} px; pixel noise {:.3} px. It grows where few corners were observed (compare with the coverage plot) and away from the boards' distance.", significant(u.distance), u.median, u.median_infinity, u.median_double, u.median_intrinsics, u.sigma) }, u.text)),
            Err(e) => notes.push(format!("No uncertainty plot: {e}")),
        }
    }
    Ok((plots, notes))
}

/// The mean error of the used corners in each cell of the image (about 1/12 of its larger side),
/// as an arrow from the cell's centre: a pattern the per-corner arrows hide in their noise (a
/// radial trend when the lens model is too simple). `typical` is the 95th percentile of the
/// corners' errors; an arrow one cell long is that size. Cells with fewer than 3 corners are
/// left out.
fn mean_residuals_plot(
    camera: &ReportCamera,
    all: &[&Residual],
    typical: f64,
    name: &str,
) -> DrawResult<(Plot, String)> {
    let size = camera.image_size;
    let cell = (size.width.max(size.height) as f64 / 12.0).max(1.0);
    let (nx, ny) = (
        (size.width as f64 / cell).ceil() as usize,
        (size.height as f64 / cell).ceil() as usize,
    );
    let mut sums = vec![(Vector2::zeros(), 0usize); nx * ny];
    for (m, e, _) in all.iter().filter(|r| !r.2) {
        let (i, j) = ((m.x + 0.5) / cell, (m.y + 0.5) / cell);
        if i >= 0.0 && j >= 0.0 && (i as usize) < nx && (j as usize) < ny {
            let s = &mut sums[j as usize * nx + i as usize];
            s.0 += e;
            s.1 += 1;
        }
    }
    let means: Vec<(Vector2<f64>, Vector2<f64>)> = sums
        .iter()
        .enumerate()
        .filter(|(_, s)| s.1 >= 3)
        .map(|(k, s)| {
            let centre = Vector2::new(
                ((k % nx) as f64 + 0.5) * cell - 0.5,
                ((k / nx) as f64 + 0.5) * cell - 0.5,
            );
            (centre, s.0 / s.1 as f64)
        })
        .collect();
    let largest = means.iter().map(|(_, e)| e.norm()).fold(0.0, f64::max);
    let scale = cell / typical.max(1e-12);
    let text =
        svg(
            |root| {
                let mut c = image_chart(
                    root,
                    size,
                    &format!("mean error per {cell:.0} px cell (one cell = {typical:.2} px)"),
                )?;
                c.draw_series(means.iter().map(|(q, _)| {
                    Rectangle::new(
                        [
                            (q.x - 0.5 * cell, q.y - 0.5 * cell),
                            (q.x + 0.5 * cell, q.y + 0.5 * cell),
                        ],
                        RGBColor(240, 240, 240).filled(),
                    )
                }))?;
                c.draw_series(means.iter().map(|(q, e)| {
                    PathElement::new(arrow(*q, q + scale * e), BLUE.stroke_width(2))
                }))?;
                c.draw_series(
                    means
                        .iter()
                        .map(|(q, _)| Circle::new((q.x, q.y), 2, BLUE.filled())),
                )?;
                Ok(())
            },
            chart_size(size),
        )?;
    Ok((
        Plot {
            file: format!("mean-residuals-{name}.svg"),
            title: "Mean error over the image".into(),
            caption: format!(
                "The mean error (projected minus measured) of the used corners in each {cell:.0} px cell with 3 or more of them (grey), as an arrow from the cell's centre (dot); an arrow one cell long is {typical:.2} px, the error 95% of the corners stay under. The largest mean is {largest:.3} px. Noise averages out here: short arrows in random directions are good; arrows that line up (pointing outward or inward at the edges, turning around the centre) are a pattern the lens model does not fit: try a model with more terms (calib single --compare-models)."
            ),
        },
        text,
    ))
}

/// At most this many boards in the poses plot: more are an unreadable tangle.
const MAX_POSE_BOARDS: usize = 60;

/// Every how many views the poses plot draws a board ([`MAX_POSE_BOARDS`]).
fn pose_stride(camera: &ReportCamera) -> usize {
    camera.views.len().div_ceil(MAX_POSE_BOARDS).max(1)
}

fn poses_svg(camera: &ReportCamera) -> DrawResult<String> {
    // Board outlines from the observed points (or a unit square), in the camera frame.
    let mut boards: Vec<Vec<Vector3<f64>>> = Vec::new();
    for v in camera.views.iter().step_by(pose_stride(camera)) {
        let corners = match &v.points {
            Some((object, _)) if !object.is_empty() => {
                let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
                for p in object {
                    x0 = x0.min(p.x);
                    x1 = x1.max(p.x);
                    y0 = y0.min(p.y);
                    y1 = y1.max(p.y);
                }
                [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]
            }
            _ => {
                let s = 0.1 * v.pose.translation.norm();
                [(0.0, 0.0), (s, 0.0), (s, s), (0.0, s), (0.0, 0.0)]
            }
        };
        boards.push(
            corners
                .iter()
                .map(|&(x, y)| v.pose.transform_point(&Point3::new(x, y, 0.0)))
                .collect(),
        );
    }
    let far = boards
        .iter()
        .flatten()
        .map(|p| p.norm())
        .fold(0.0, f64::max)
        .max(1e-6);
    let depth = 0.25 * far;
    let k = camera.camera.intrinsics;
    let (w, h) = (
        camera.image_size.width as f64,
        camera.image_size.height as f64,
    );
    let frustum: Vec<Vector3<f64>> = [
        (0.0, 0.0),
        (w - 1.0, 0.0),
        (w - 1.0, h - 1.0),
        (0.0, h - 1.0),
    ]
    .iter()
    .map(|&(u, v)| Vector3::new((u - k.cx) / k.fx * depth, (v - k.cy) / k.fy * depth, depth))
    .collect();
    // Plot axes: x right, up = -y (camera y points down), depth z.
    let to = |p: &Vector3<f64>| (p.x, -p.y, p.z);
    let lim = boards
        .iter()
        .flatten()
        .map(|p| p.x.abs().max(p.y.abs()))
        .fold(depth, f64::max)
        * 1.05;
    let zmax = boards.iter().flatten().map(|p| p.z).fold(depth, f64::max) * 1.05;
    svg(
        |root| {
            let mut c = ChartBuilder::on(root)
                .caption(
                    "camera and boards (camera frame: x right, y up, z forward)",
                    ("sans-serif", 16),
                )
                .margin(10)
                .build_cartesian_3d(-lim..lim, -lim..lim, 0.0..zmax)?;
            c.with_projection(|mut p| {
                p.pitch = 0.35;
                p.yaw = 0.6;
                p.scale = 0.85;
                p.into_matrix()
            });
            c.configure_axes().draw()?;
            let origin = (0.0, 0.0, 0.0);
            for corner in &frustum {
                c.draw_series(std::iter::once(PathElement::new(
                    vec![origin, to(corner)],
                    BLACK.stroke_width(2),
                )))?;
            }
            let mut ring: Vec<(f64, f64, f64)> = frustum.iter().map(to).collect();
            ring.push(ring[0]);
            c.draw_series(std::iter::once(PathElement::new(
                ring,
                BLACK.stroke_width(2),
            )))?;
            let n = boards.len().max(1);
            for (i, b) in boards.iter().enumerate() {
                let col = colour(i as f64 / n as f64);
                c.draw_series(std::iter::once(PathElement::new(
                    b.iter().map(to).collect::<Vec<_>>(),
                    col.stroke_width(2),
                )))?;
            }
            Ok(())
        },
        (640, 560),
    )
}

/// The rig's cameras and the boards, in 3-D, in the reference camera's frame.
fn layout_svg(input: &ReportInput, layout: &RigLayout) -> DrawResult<String> {
    // Camera centres and viewing directions in the reference frame: C = -R^T T, d = R^T z.
    let centres: Vec<Vector3<f64>> = layout
        .transforms
        .iter()
        .map(|t| t.inverse().translation)
        .collect();
    let origins: Vec<Vector3<f64>> = layout.boards.iter().map(|b| b.translation).collect();
    let all = || centres.iter().chain(&origins);
    let mut lo = Vector3::repeat(f64::MAX);
    let mut hi = Vector3::repeat(f64::MIN);
    for p in all() {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let span = (hi - lo).amax().max(1e-6);
    let baseline = centres
        .iter()
        .flat_map(|a| centres.iter().map(move |b| (a - b).norm()))
        .filter(|d| *d > 0.0)
        .fold(f64::MAX, f64::min);
    let depth = if baseline.is_finite() && baseline < f64::MAX {
        (0.5 * baseline).min(0.15 * span)
    } else {
        0.15 * span
    }
    .max(1e-3 * span);
    // One scale on every axis (a cube around the middle), so angles look like angles.
    let half = 0.5 * span + 0.05 * span + depth;
    let mid = 0.5 * (lo + hi);
    let to = |p: &Vector3<f64>| (p.x, -p.y, p.z);
    let (x0, x1) = (mid.x - half, mid.x + half);
    let (y0, y1) = (-mid.y - half, -mid.y + half);
    let (z0, z1) = (mid.z - half, mid.z + half);
    svg(
        |root| {
            let mut c = ChartBuilder::on(root)
                .caption(
                    "cameras and boards (reference camera frame: x right, y up, z forward)",
                    ("sans-serif", 16),
                )
                .margin(10)
                .build_cartesian_3d(x0..x1, y0..y1, z0..z1)?;
            c.with_projection(|mut p| {
                p.pitch = 1.0;
                p.yaw = 0.3;
                p.scale = 0.75;
                p.into_matrix()
            });
            c.configure_axes().draw()?;
            let n = origins.len().max(1);
            c.draw_series(
                origins
                    .iter()
                    .enumerate()
                    .map(|(i, o)| Circle::new(to(o), 3, colour(i as f64 / n as f64).filled())),
            )?;
            for (camera, t) in input.cameras.iter().zip(&layout.transforms) {
                let back = t.inverse();
                let k = camera.camera.intrinsics;
                let (w, h) = (
                    camera.image_size.width as f64,
                    camera.image_size.height as f64,
                );
                let centre = back.translation;
                let corners: Vec<Vector3<f64>> = [
                    (0.0, 0.0),
                    (w - 1.0, 0.0),
                    (w - 1.0, h - 1.0),
                    (0.0, h - 1.0),
                ]
                .iter()
                .map(|&(u, v)| {
                    let ray = Vector3::new((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
                    back.rotation * (ray / ray.norm() * depth) + centre
                })
                .collect();
                for corner in &corners {
                    c.draw_series(std::iter::once(PathElement::new(
                        vec![to(&centre), to(corner)],
                        BLACK.stroke_width(2),
                    )))?;
                }
                let mut ring: Vec<(f64, f64, f64)> = corners.iter().map(to).collect();
                ring.push(ring[0]);
                c.draw_series(std::iter::once(PathElement::new(
                    ring,
                    BLACK.stroke_width(2),
                )))?;
                // The name above the frustum (the camera's -y, its up), clear of its lines.
                let above = centre + back.rotation * Vector3::new(0.0, -1.2 * depth, 0.0);
                c.draw_series(std::iter::once(Text::new(
                    camera.name.clone(),
                    to(&above),
                    ("sans-serif", 14).into_font().color(&BLUE),
                )))?;
            }
            Ok(())
        },
        (640, 560),
    )
}

fn distortion_svg(
    camera: &ReportCamera,
    validity: &camera_model::Validity,
) -> DrawResult<(String, f64)> {
    let size = camera.image_size;
    let k = camera.camera.intrinsics;
    let cell = (size.width.max(size.height) as f64 / 32.0).max(1.0);
    let (nx, ny) = (
        (size.width as f64 / cell).ceil() as usize,
        (size.height as f64 / cell).ceil() as usize,
    );
    // Shift at each cell centre: distorted pixel minus where the undistorted ray lands with K.
    let mut shifts = vec![None; nx * ny];
    for j in 0..ny {
        for i in 0..nx {
            let q = Vector2::new((i as f64 + 0.5) * cell - 0.5, (j as f64 + 0.5) * cell - 0.5);
            if let Ok(ray) = camera.camera.pixel_to_ray(&q, &UndistortOptions::default())
                && ray.z > 1e-6
            {
                let ideal = Vector2::new(k.fx * ray.x / ray.z + k.cx, k.fy * ray.y / ray.z + k.cy);
                shifts[j * nx + i] = Some(q - ideal);
            }
        }
    }
    let max_shift = shifts
        .iter()
        .flatten()
        .map(|s| s.norm())
        .fold(0.0, f64::max);
    let text = svg(
        |root| {
            let map = colour_bar(root, max_shift, "|distorted - undistorted| (px)")?;
            let mut c = image_chart(
                &map,
                size,
                &format!(
                    "distortion: |shift| up to {max_shift:.1} px (arrows x{:.1})",
                    0.9 * cell * 2.0 / max_shift.max(1e-9)
                ),
            )?;
            c.draw_series((0..nx * ny).filter_map(|k| {
                let s = shifts[k]?;
                let (i, j) = ((k % nx) as f64, (k / nx) as f64);
                Some(Rectangle::new(
                    [
                        (i * cell - 0.5, j * cell - 0.5),
                        ((i + 1.0) * cell - 0.5, (j + 1.0) * cell - 0.5),
                    ],
                    colour(s.norm() / max_shift.max(1e-9)).filled(),
                ))
            }))?;
            let arrow_scale = 0.9 * cell * 2.0 / max_shift.max(1e-9);
            c.draw_series(
                (0..nx * ny)
                    .filter(|k| (k % nx) % 2 == 0 && (k / nx) % 2 == 0)
                    .filter_map(|k| {
                        let s = shifts[k]?;
                        let (x, y) = (
                            ((k % nx) as f64 + 0.5) * cell - 0.5,
                            ((k / nx) as f64 + 0.5) * cell - 0.5,
                        );
                        Some(PathElement::new(
                            arrow(
                                Vector2::new(x - arrow_scale * s.x, y - arrow_scale * s.y),
                                Vector2::new(x, y),
                            ),
                            WHITE.stroke_width(1),
                        ))
                    }),
            )?;
            // The fold, where the walk found it (an ellipse when fx != fy): dashes inside the
            // image, every other segment between neighbouring rays.
            let style = if validity.covers_image(calib_core::diagnostics::VALIDITY_MARGIN) {
                BLACK.stroke_width(2)
            } else {
                RED.stroke_width(3)
            };
            let (w, h) = (size.width as f64, size.height as f64);
            let inside = |p: &Vector2<f64>| {
                (-0.5..=w - 0.5).contains(&p.x) && (-0.5..=h - 0.5).contains(&p.y)
            };
            let rays = validity.limit_px.len();
            c.draw_series((0..rays).step_by(2).filter_map(|i| {
                let (p0, p1) = (validity.limit_px[i]?, validity.limit_px[(i + 1) % rays]?);
                (inside(&p0) && inside(&p1))
                    .then(|| PathElement::new(vec![(p0.x, p0.y), (p1.x, p1.y)], style))
            }))?;
            Ok(())
        },
        heat_size(size),
    )?;
    Ok((text, max_shift))
}

/// The projection-uncertainty map and the numbers its caption quotes.
struct UncertaintyPlot {
    text: String,
    /// The distance of the map (the boards' median distance), board units.
    distance: f64,
    /// Median over the image of the worst-direction standard deviation at `distance`, pixels.
    median: f64,
    /// The same at infinity.
    median_infinity: f64,
    /// The same at twice `distance`.
    median_double: f64,
    /// The same from the intrinsics alone (camera frame held).
    median_intrinsics: f64,
    /// Pixel noise, pixels.
    sigma: f64,
}

/// `v` with four significant digits (no exponent for everyday magnitudes).
fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (3 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

/// The `q` quantile (0..=1) of the finite `values`; 0 if there are none.
fn percentile(values: &[f64], q: f64) -> f64 {
    let mut v: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    v[((v.len() - 1) as f64 * q).round() as usize]
}

/// The upper median of the finite `values` (NaN if there are none).
fn median(values: Vec<f64>) -> f64 {
    if values.iter().any(|v| v.is_finite()) {
        percentile(&values, 0.5)
    } else {
        f64::NAN
    }
}

fn uncertainty_svg(camera: &ReportCamera) -> DrawResult<UncertaintyPlot> {
    let views: Vec<CovarianceView> = camera
        .views
        .iter()
        .filter_map(|v| {
            let (object, pixels) = v.points.as_ref()?;
            let keep: Vec<usize> = (0..object.len())
                .filter(|i| !v.rejected.contains(i))
                .collect();
            Some(CovarianceView {
                pose: v.pose,
                object: keep.iter().map(|&i| object[i]).collect(),
                pixels: keep.iter().map(|&i| pixels[i]).collect(),
            })
        })
        .collect();
    let uncertainty = Uncertainty::new(&camera.camera, &views, &camera.fixed)?;
    // The boards' median distance: of each board's centre from the camera.
    let distance = median(
        views
            .iter()
            .filter(|v| !v.object.is_empty())
            .map(|v| {
                let centre =
                    v.object.iter().map(|p| p.coords).sum::<Vector3<f64>>() / v.object.len() as f64;
                (v.pose.rotation * centre + v.pose.translation).norm()
            })
            .collect(),
    );
    if !(distance.is_finite() && distance > 0.0) {
        return Err("no board distance".into());
    }
    let size = camera.image_size;
    let cell = (size.width.max(size.height) as f64 / 40.0).max(1.0);
    let (nx, ny) = (
        (size.width as f64 / cell).ceil() as usize,
        (size.height as f64 / cell).ceil() as usize,
    );
    let centre = |k: usize| {
        Vector2::new(
            ((k % nx) as f64 + 0.5) * cell - 0.5,
            ((k / nx) as f64 + 0.5) * cell - 0.5,
        )
    };
    let std_at = |q: &Vector2<f64>, d: Option<f64>| {
        uncertainty
            .projection(q, d)
            .map_or(f64::NAN, |c| worst_std(&c))
    };
    let values: Vec<f64> = (0..nx * ny)
        .map(|k| std_at(&centre(k), Some(distance)))
        .collect();
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return Err("no pixel could be evaluated".into());
    }
    let median_d = median(finite.clone());
    let top = finite.iter().copied().fold(0.0, f64::max).max(1e-12);
    // The comparison numbers on a coarser grid (every other cell).
    let coarse: Vec<Vector2<f64>> = (0..nx * ny)
        .filter(|k| (k % nx) % 2 == 0 && (k / nx) % 2 == 0)
        .map(centre)
        .collect();
    let median_infinity = median(coarse.iter().map(|q| std_at(q, None)).collect());
    let median_double = median(
        coarse
            .iter()
            .map(|q| std_at(q, Some(2.0 * distance)))
            .collect(),
    );
    let covariance = uncertainty.intrinsics_covariance();
    let median_intrinsics = median(
        coarse
            .iter()
            .map(|q| {
                camera
                    .camera
                    .pixel_to_ray(q, &UndistortOptions::default())
                    .ok()
                    .and_then(|ray| {
                        crate::covariance::projection_covariance(
                            &camera.camera,
                            &covariance,
                            &ray.into_inner(),
                        )
                    })
                    .map_or(f64::NAN, |c| worst_std(&c))
            })
            .collect(),
    );
    // Fixed bands (pixels), the same on every report: a good calibration is dark, a poor one
    // yellow, whatever its own range.
    let band = |v: f64| {
        let k = UNCERTAINTY_BANDS.iter().filter(|&&edge| v >= edge).count();
        (k as f64 + 0.5) / (UNCERTAINTY_BANDS.len() + 1) as f64
    };
    let text = svg(
        |root| {
            let map = band_bar(
                root,
                &UNCERTAINTY_BANDS,
                "projection std, worst direction (px), fixed bands",
            )?;
            let mut c = image_chart(
                &map,
                size,
                &format!(
                    "projection std (px) at distance {}: median {median_d:.3}, max {top:.3}",
                    significant(distance)
                ),
            )?;
            c.draw_series((0..nx * ny).filter(|k| values[*k].is_finite()).map(|k| {
                let (i, j) = ((k % nx) as f64, (k / nx) as f64);
                Rectangle::new(
                    [
                        (i * cell - 0.5, j * cell - 0.5),
                        ((i + 1.0) * cell - 0.5, (j + 1.0) * cell - 0.5),
                    ],
                    colour(band(values[k])).filled(),
                )
            }))?;
            Ok(())
        },
        heat_size(size),
    )?;
    Ok(UncertaintyPlot {
        text,
        distance,
        median: median_d,
        median_infinity,
        median_double,
        median_intrinsics,
        sigma: uncertainty.sigma(),
    })
}
