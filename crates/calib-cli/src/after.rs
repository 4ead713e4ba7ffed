//! `calib export`, `calib undistort`, `calib rectify`, and what `calib single` / `calib stereo`
//! share with them: `--export FORMAT=FILE` and `--intrinsics FILE` (crate `calib-export`,
//! `docs/after-calibration.md`).

use crate::run::check_not_input;
use crate::{Failure, Say, print_stdout, write_json};
use calib_export::remap::{read_image, write_image};
use calib_export::{
    Calibrated, CameraCalibration, ExportOptions, Format, PixelMap, export_paths,
    optimal_new_camera_matrix, read_calibration, remap_image, render_export, stereo_rectify,
};
use calib_single::CalibrationOptions;
use camera_model::{AnyCamera, CameraModel};
use clap::Args;
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// One `--export FORMAT=FILE`.
#[derive(Debug, Clone)]
pub struct ExportTarget {
    /// The format.
    pub format: Format,
    /// The file (for ROS stereo, the stem of the two files).
    pub path: PathBuf,
}

/// Parses the `--export` values.
pub fn export_targets(values: &[String]) -> Result<Vec<ExportTarget>, Failure> {
    values
        .iter()
        .map(|v| {
            let (format, path) = v.split_once('=').ok_or_else(|| {
                Failure(format!(
                    "--export {v}: expected FORMAT=FILE, e.g. opencv=camera.yaml"
                ))
            })?;
            let format: Format = format
                .parse()
                .map_err(|e| Failure(format!("--export {v}: {e}")))?;
            if path.is_empty() {
                return Err(Failure(format!("--export {v}: the file name is empty")));
            }
            if path == "-" {
                // Standard output holds the summary or the -o - result already.
                return Err(Failure(format!(
                    "--export {v}: give a file name (calib export RESULT --format {format} -o - prints an export)"
                )));
            }
            Ok(ExportTarget {
                format,
                path: PathBuf::from(path),
            })
        })
        .collect()
}

/// Exports rendered but not written ([`render_exports`]).
#[derive(Debug, Default)]
pub struct RenderedExports {
    /// `(path, text, format)` of every file.
    pub files: Vec<(PathBuf, String, Format)>,
    /// What the files leave out (an OpenCV stereo file without its rectification), as warnings
    /// for standard error, each naming its `--export`.
    pub warnings: Vec<String>,
}

/// Prints export warnings on standard error (whatever `-q` says, like the calibration's).
pub fn warn(warnings: &[String]) {
    use std::io::Write;
    let mut err = std::io::stderr().lock();
    for w in warnings {
        let _ = writeln!(err, "calib: warning: {w}");
    }
}

/// The files of the exports of `calibrated` (default options), rendered but not written,
/// refusing any that would replace an input. Rendering first lets a command fail (a model the
/// format cannot hold, a ROS stereo pair that cannot be rectified) before it replaces any
/// previous file.
pub fn render_exports(
    calibrated: &Calibrated,
    targets: &[ExportTarget],
    inputs: &[&str],
) -> Result<RenderedExports, Failure> {
    let mut rendered = RenderedExports::default();
    for target in targets {
        let paths = export_paths(calibrated, target.format, &target.path);
        for path in &paths {
            check_not_input(&path.to_string_lossy(), inputs)?;
        }
        let name = format!("--export {}={}", target.format, target.path.display());
        let export = render_export(calibrated, target.format, &ExportOptions::default())
            .map_err(|e| Failure(format!("{name}: {e}")))?;
        rendered.files.extend(
            paths
                .into_iter()
                .zip(export.texts)
                .map(|(path, text)| (path, text, target.format)),
        );
        rendered
            .warnings
            .extend(export.omissions.into_iter().map(|o| format!("{name}: {o}")));
    }
    Ok(rendered)
}

/// Refuses, before calibrating, an `--export` whose format cannot hold one of `models` (the
/// calibrated cameras' lens models).
pub fn check_export_models(
    targets: &[ExportTarget],
    models: &[CameraModel],
) -> Result<(), Failure> {
    for target in targets {
        for &model in models {
            calib_export::check_format_takes_model(target.format, model).map_err(|e| {
                Failure(format!(
                    "--export {}={}: {e}",
                    target.format,
                    target.path.display()
                ))
            })?;
        }
    }
    Ok(())
}

/// Writes rendered exports ([`render_exports`]) as a group
/// ([`calib_core::io::write_group_atomically`]: a failure leaves every previous file as it was);
/// prints the files written unless quiet, and what they leave out on standard error.
pub fn write_rendered(rendered: &RenderedExports, say: Say) -> Result<(), Failure> {
    let files = &rendered.files;
    let group: Vec<(PathBuf, &[u8])> = files
        .iter()
        .map(|(path, text, _)| (path.clone(), text.as_bytes()))
        .collect();
    calib_core::io::write_group_atomically(&group).map_err(|(failed, e)| {
        let format = files
            .iter()
            .find(|(path, _, _)| *path == failed)
            .map_or(String::new(), |(_, _, f)| f.to_string());
        Failure(format!("--export {format}={}: {e}", failed.display()))
    })?;
    for (path, _, format) in files {
        say.text(&format!("wrote {} ({format})\n", path.display()))?;
    }
    warn(&rendered.warnings);
    Ok(())
}

/// Reads the camera of a single-camera calibration file (`what` names the option).
pub fn read_single_camera(path: &str, what: &str) -> Result<CameraCalibration, Failure> {
    read_camera(path, what, None)
}

/// Reads one camera from a calibration file: the file's only camera, or, from a stereo or rig
/// file, the camera named `name` (`what` names the option in messages).
pub fn read_camera(
    path: &str,
    what: &str,
    name: Option<&str>,
) -> Result<CameraCalibration, Failure> {
    let calibrated =
        read_calibration(Path::new(path)).map_err(|e| Failure(format!("{what}: {e}")))?;
    match (calibrated, name) {
        (Calibrated::Single(c), _) => Ok(c),
        (calibrated, Some(name)) => {
            let names: Vec<String> = calibrated
                .cameras()
                .iter()
                .map(|c| c.name.clone())
                .collect();
            calibrated
                .cameras()
                .into_iter()
                .find(|c| c.name == name)
                .cloned()
                .ok_or_else(|| {
                    Failure(format!(
                        "{what} {path}: {} without a camera named '{name}' (its cameras: {})",
                        calibrated.kind(),
                        names.join(", ")
                    ))
                })
        }
        (calibrated @ Calibrated::Stereo(_), None) => {
            let names: Vec<String> = calibrated
                .cameras()
                .iter()
                .map(|c| format!("'{}'", c.name))
                .collect();
            Err(Failure(format!(
                "{what} {path}: holds {} (cameras {}); name one (calib undistort --camera NAME) or give a single camera's file (calib stereo takes stereo files with --intrinsics, single cameras with --left-intrinsics / --right-intrinsics)",
                calibrated.kind(),
                names.join(" and ")
            )))
        }
        (calibrated @ Calibrated::Rig(_), None) => Err(Failure(format!(
            "{what} {path}: holds {}; give a single camera's file, or name the camera (calib undistort --camera NAME; calib rig --intrinsics NAME=FILE takes the camera NAME of a rig file)",
            calibrated.kind()
        ))),
    }
}

/// The stereo pair `LEFT,RIGHT` (camera names) of a rig, or the stereo rig itself.
pub fn select_pair(
    calibrated: Calibrated,
    pair: Option<&str>,
    source: &str,
) -> Result<Calibrated, Failure> {
    let Some(pair) = pair else {
        return Ok(calibrated);
    };
    let Some((left, right)) = pair.split_once(',') else {
        return Err(Failure(format!(
            "--pair {pair}: expected two camera names, LEFT,RIGHT"
        )));
    };
    let (left, right) = (left.trim(), right.trim());
    match calibrated {
        Calibrated::Rig(rig) => {
            let index = |name: &str| {
                rig.camera_index(name)
                    .map_err(|e| Failure(format!("--pair {pair}: {source}: {e}")))
            };
            let (l, r) = (index(left)?, index(right)?);
            rig.pair(l, r)
                .map(Calibrated::Stereo)
                .map_err(|e| Failure(format!("--pair {pair}: {e}")))
        }
        Calibrated::Stereo(s) if s.left.name == left && s.right.name == right => {
            Ok(Calibrated::Stereo(s))
        }
        // The pair the other way round: X_left = R^T X_right - R^T T.
        Calibrated::Stereo(s) if s.left.name == right && s.right.name == left => {
            let rotation = s.rotation.transpose();
            Ok(Calibrated::Stereo(calib_export::StereoRig {
                translation: -(rotation * s.translation),
                rotation,
                left: s.right,
                right: s.left,
            }))
        }
        other => Err(Failure(format!(
            "--pair {pair}: {source} holds {}, not a rig of several cameras",
            other.kind()
        ))),
    }
}

/// `camera` as a camera of `model`: itself, or padded with zero coefficients when `model` extends
/// its model (brown-conrady4 < brown-conrady5 < rational8 < thin-prism12); `None` otherwise.
pub fn widen(camera: &AnyCamera, model: CameraModel) -> Option<AnyCamera> {
    use CameraModel::*;
    let rank = |m: CameraModel| match m {
        BrownConrady4 => Some(0),
        BrownConrady5 => Some(1),
        Rational8 => Some(2),
        ThinPrism12 => Some(3),
        KannalaBrandt4 => None,
    };
    if camera.model == model {
        return Some(camera.clone());
    }
    let (from, to) = (rank(camera.model)?, rank(model)?);
    if from > to {
        return None;
    }
    let mut d = camera.distortion.clone();
    d.resize(model.num_distortion_params(), 0.0);
    AnyCamera::new(model, camera.intrinsics, d).ok()
}

/// Starts `options` from the camera of a file (`--intrinsics`): its model (unless `--model` was
/// given: then the file's camera must fit that model), intrinsics and distortion as the guess;
/// with `fix`, all of them held.
pub fn apply_camera_file(
    options: &mut CalibrationOptions,
    camera: &CameraCalibration,
    explicit_model: bool,
    fix: bool,
    what: &str,
) -> Result<(), Failure> {
    let start = if explicit_model {
        widen(&camera.camera, options.model).ok_or_else(|| {
            Failure(format!(
                "{what}: the file's camera is {}, which the requested model {} cannot start from (leave --model, or --right-model for the right camera, out to use the file's model)",
                camera.camera.model, options.model
            ))
        })?
    } else {
        camera.camera.clone()
    };
    if options.intrinsic_guess.is_some() || options.distortion_guess.is_some() {
        return Err(Failure(format!(
            "{what} is the start; a guess (--guess, --distortion-guess, --left-guess, --right-guess) would be ignored: give one or the other"
        )));
    }
    // Coefficients held by --fix carry over by name, not position.
    *options = options.for_model(start.model);
    options.intrinsic_guess = Some(start.intrinsics);
    options.distortion_guess = Some(start.distortion.clone());
    if fix {
        options.fix_focal_length = true;
        options.fix_principal_point = true;
        options.fixed_distortion = (0..start.model.num_distortion_params()).collect();
    }
    Ok(())
}

/// Refuses a camera file whose image size differs from the observations'.
pub fn check_image_size(
    camera: &CameraCalibration,
    size: Option<calib_core::ImageSize>,
    what: &str,
) -> Result<(), Failure> {
    let Some(size) = size else {
        return Ok(());
    };
    if camera.image_size != size {
        return Err(Failure(format!(
            "{what}: the file's camera has images of {}x{} but the observations are {}x{}; intrinsics in pixels only apply to the same image size",
            camera.image_size.width, camera.image_size.height, size.width, size.height
        )));
    }
    Ok(())
}

/// Arguments of `calib export`.
#[derive(Args, Debug)]
pub struct ExportArgs {
    /// A calibration: a result of calib single, calib stereo or calib rig (JSON), or any
    /// exported file.
    #[arg(value_name = "RESULT")]
    pub input: String,
    /// Format to write: opencv (FileStorage YAML), ros (camera_info YAML; a stereo rig writes
    /// FILE-left.yaml and FILE-right.yaml, a rig FILE-NAME.yaml per camera), kalibr (camchain
    /// YAML).
    #[arg(long, value_name = "FORMAT")]
    pub format: String,
    /// Of a rig, export the stereo pair of these two cameras (names), with its rectification:
    /// OpenCV's M1 ... Q, ROS's rectified left and right files.
    #[arg(long, value_name = "LEFT,RIGHT")]
    pub pair: Option<String>,
    /// File to write ("-" for standard output, when the export is one file).
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Free scaling of the rectification (stereo) and of ROS's projection matrix: 0 (only valid
    /// pixels) to 1 (every source pixel), or -1 for OpenCV's default scaling (stereo).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_negative_numbers = true,
        value_name = "A"
    )]
    pub alpha: f64,
    /// Multiply translations by this (board units to the other tool's: 0.001 for a board in mm
    /// when ROS or Kalibr expect metres).
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    pub translation_scale: f64,
    /// Do not print the files written.
    #[arg(short, long)]
    pub quiet: bool,
}

/// `--alpha` as the library's option: `-1` is OpenCV's default scaling.
fn alpha_option(alpha: f64) -> Result<Option<f64>, Failure> {
    if alpha == -1.0 {
        Ok(None)
    } else if (0.0..=1.0).contains(&alpha) {
        Ok(Some(alpha))
    } else {
        Err(Failure(format!(
            "--alpha: expected 0 to 1 (or -1 for OpenCV's default), got {alpha}"
        )))
    }
}

pub fn run_export(args: &ExportArgs) -> Result<(), Failure> {
    let format: Format = args
        .format
        .parse()
        .map_err(|e| Failure(format!("--format: {e}")))?;
    let options = ExportOptions::new(alpha_option(args.alpha)?, args.translation_scale)
        .map_err(|e| Failure(e.to_string()))?;
    let calibrated = select_pair(
        read_calibration(Path::new(&args.input))?,
        args.pair.as_deref(),
        &args.input,
    )?;
    let rendered = render_export(&calibrated, format, &options)
        .map_err(|e| Failure(format!("{}: {e}", args.input)))?;
    let warnings: Vec<String> = rendered
        .omissions
        .iter()
        .map(|o| format!("{}: {o}", args.output.display()))
        .collect();
    if args.output.as_os_str() == "-" {
        // Standard output: one file's text only (a ROS stereo pair or rig is several files).
        let [text] = rendered.texts.as_slice() else {
            return Err(Failure(format!(
                "-o -: the {format} export of {} is {} files; give a file name (each camera gets a file named from it)",
                args.input,
                rendered.texts.len()
            )));
        };
        print_stdout(text)?;
        warn(&warnings);
        return Ok(());
    }
    let paths = export_paths(&calibrated, format, &args.output);
    for path in &paths {
        check_not_input(&path.to_string_lossy(), &[&args.input])?;
    }
    calib_export::write_export(&rendered, &paths)
        .map_err(|e| Failure(format!("{}: {e}", args.input)))?;
    warn(&warnings);
    if !args.quiet {
        for path in paths {
            print_stdout(&format!("wrote {} ({format})\n", path.display()))?;
        }
    }
    Ok(())
}

/// Arguments of `calib undistort`.
#[derive(Args, Debug)]
pub struct UndistortArgs {
    /// The camera: a calib single result (JSON) or an exported file (OpenCV, ROS, Kalibr); or a
    /// stereo or rig file with --camera.
    #[arg(value_name = "CAMERA")]
    pub camera: String,
    /// The camera of a stereo or rig file to undistort for (its name).
    #[arg(long = "camera", value_name = "NAME")]
    pub camera_name: Option<String>,
    /// Images to undistort (JPEG or PNG), all of the calibrated size.
    #[arg(required = true, value_name = "IMAGE")]
    pub images: Vec<PathBuf>,
    /// Output folder (created if needed): each image keeps its file name (and format), replacing
    /// a file of that name (refused when that is an input image); the new camera matrix goes to
    /// DIR/undistortion.json; other files in DIR are left alone.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Free scaling: 0 keeps only valid pixels, 1 keeps every source pixel (OpenCV's
    /// getOptimalNewCameraMatrix).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_negative_numbers = true,
        value_name = "A"
    )]
    pub alpha: f64,
    /// Threads (0 = all cores, at most 1024).
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// Do not print the summary.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Output paths `dir/<file name>` of `images`, refusing duplicates and inputs.
fn output_paths(images: &[&PathBuf], dir: &Path, inputs: &[&str]) -> Result<Vec<PathBuf>, Failure> {
    let mut out: Vec<PathBuf> = Vec::with_capacity(images.len());
    for image in images {
        let name = image
            .file_name()
            .ok_or_else(|| Failure(format!("{}: not a file name", image.display())))?;
        let path = dir.join(name);
        if out.contains(&path) {
            return Err(Failure(format!(
                "two inputs are named {}: outputs keep the input names, so they would overwrite each other",
                name.to_string_lossy()
            )));
        }
        check_not_input(&path.to_string_lossy(), inputs).map_err(|_| {
            Failure(format!(
                "{}: writing there would replace the input image; choose another output folder",
                path.display()
            ))
        })?;
        out.push(path);
    }
    Ok(out)
}

/// Checks that every image can be opened and has `size` (upright, from its header, without
/// decoding), so that a bad input is refused before any output is written.
fn check_images(images: &[&PathBuf], size: calib_core::ImageSize) -> Result<(), Failure> {
    for input in images {
        let dimensions = board_detect::upright_dimensions(input)
            .map_err(|e| Failure(format!("{}: {e}", input.display())))?;
        if dimensions != (size.width, size.height) {
            return Err(Failure(format!(
                "{}: {}x{} pixels, but the calibration is for {}x{} (nothing was written)",
                input.display(),
                dimensions.0,
                dimensions.1,
                size.width,
                size.height
            )));
        }
    }
    Ok(())
}

/// Remaps `images` with `map` into `outputs` in parallel; every image must have `map`'s size.
fn remap_all(images: &[&PathBuf], outputs: &[PathBuf], map: &PixelMap) -> Result<(), Failure> {
    images
        .par_iter()
        .zip(outputs)
        .map(|(input, output)| {
            let image = read_image(input)?;
            if (image.width(), image.height()) != (map.size.width, map.size.height) {
                return Err(calib_export::ExportError::Image {
                    path: input.display().to_string(),
                    reason: format!(
                        "{}x{} pixels, but the calibration is for {}x{}",
                        image.width(),
                        image.height(),
                        map.size.width,
                        map.size.height
                    ),
                });
            }
            write_image(&remap_image(&image, map), output)
        })
        .collect::<Result<Vec<()>, _>>()
        .map_err(|e| Failure(e.to_string()))?;
    Ok(())
}

fn with_threads<T: Send>(
    threads: usize,
    f: impl FnOnce() -> Result<T, Failure> + Send,
) -> Result<T, Failure> {
    if threads == 0 {
        return f();
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Failure(format!("--threads: {e}")))?
        .install(f)
}

fn rows<const R: usize, const C: usize>(m: &nalgebra::SMatrix<f64, R, C>) -> serde_json::Value {
    serde_json::json!(
        (0..R)
            .map(|i| (0..C).map(|k| m[(i, k)]).collect::<Vec<f64>>())
            .collect::<Vec<_>>()
    )
}

pub fn run_undistort(args: &UndistortArgs) -> Result<(), Failure> {
    if !(0.0..=1.0).contains(&args.alpha) {
        return Err(Failure(format!(
            "--alpha {}: expected 0 (only valid pixels) to 1 (every source pixel)",
            args.alpha
        )));
    }
    let camera = read_camera(&args.camera, "CAMERA", args.camera_name.as_deref())?;
    let (k_new, roi) = optimal_new_camera_matrix(&camera.camera, camera.image_size, args.alpha)
        .map_err(|e| Failure(format!("{}: {e}", args.camera)))?;
    if args.output.exists() && !args.output.is_dir() {
        crate::create_folder(&args.output, "-o")?;
    }
    let images: Vec<&PathBuf> = args.images.iter().collect();
    let mut inputs: Vec<String> = args
        .images
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    inputs.push(args.camera.clone());
    let input_refs: Vec<&str> = inputs.iter().map(String::as_str).collect();
    let outputs = output_paths(&images, &args.output, &input_refs)?;
    let sidecar = args.output.join("undistortion.json");
    check_not_input(&sidecar.to_string_lossy(), &input_refs)?;
    check_images(&images, camera.image_size)?;
    // Created once the inputs are checked: a refused run leaves no empty folder behind.
    crate::create_folder(&args.output, "-o")?;
    let start = std::time::Instant::now();
    with_threads(args.threads, || {
        let map = PixelMap::undistort(&camera, &k_new).map_err(|e| Failure(e.to_string()))?;
        remap_all(&images, &outputs, &map)
    })?;
    let json = serde_json::json!({
        "format": "calib-undistortion/1",
        "source": args.camera,
        "model": camera.camera.model,
        "image_size": camera.image_size,
        "alpha": args.alpha,
        "camera_matrix": rows(&camera.matrix()),
        "dist_coeffs": camera.camera.distortion,
        "new_camera_matrix": rows(&k_new),
        "valid_roi": roi,
        "images": args.images.iter().map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned())).collect::<Vec<_>>(),
    });
    write_json(&sidecar.to_string_lossy(), &json)?;
    if !args.quiet {
        print_stdout(&format!(
            "undistorted {} images into {} in {:.2} s (alpha {}, new fx fy cx cy = {:.3} {:.3} {:.3} {:.3}, valid region {:?})\n",
            images.len(),
            args.output.display(),
            start.elapsed().as_secs_f64(),
            args.alpha,
            k_new[(0, 0)],
            k_new[(1, 1)],
            k_new[(0, 2)],
            k_new[(1, 2)],
            roi
        ))?;
    }
    Ok(())
}

/// Arguments of `calib rectify`.
#[derive(Args, Debug)]
pub struct RectifyArgs {
    /// The stereo calibration: a calib stereo result (JSON), an OpenCV stereo YAML or a Kalibr
    /// camchain of two cameras; or a rig (calib rig result, OpenCV rig YAML, Kalibr camchain)
    /// with --pair.
    #[arg(value_name = "STEREO_RESULT")]
    pub input: String,
    /// Of a rig, rectify the pair of these two cameras (names): LEFT's images with --images,
    /// RIGHT's with --right. Of a stereo file, right,left rectifies it the other way round.
    #[arg(long, value_name = "LEFT,RIGHT")]
    pub pair: Option<String>,
    /// Free scaling: 0 keeps only valid pixels in both rectified images, 1 keeps every source
    /// pixel, -1 is OpenCV's default scaling.
    #[arg(
        long,
        default_value_t = 0.0,
        allow_negative_numbers = true,
        value_name = "A"
    )]
    pub alpha: f64,
    /// Write R1, R2, P1, P2, Q (and the valid regions) as JSON to this file ("-" for stdout),
    /// after the rectified images (--out): a run that fails on an image writes no JSON.
    #[arg(short, long, value_name = "RECT.json")]
    pub output: Option<String>,
    /// Left images to rectify (with --right and --out).
    #[arg(long, num_args = 1.., value_name = "LEFT")]
    pub images: Vec<PathBuf>,
    /// Right images to rectify.
    #[arg(long, num_args = 1.., value_name = "RIGHT")]
    pub right: Vec<PathBuf>,
    /// Folder for the rectified images: DIR/left/ and DIR/right/, each image keeping its input
    /// file name.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Threads (0 = all cores, at most 1024).
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// Do not print the summary.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run_rectify(args: &RectifyArgs) -> Result<(), Failure> {
    let calibrated = select_pair(
        read_calibration(Path::new(&args.input))?,
        args.pair.as_deref(),
        &args.input,
    )?;
    let rig = match calibrated {
        Calibrated::Stereo(s) => s,
        Calibrated::Single(_) => {
            return Err(Failure(format!(
                "{}: a single camera; rectification needs a stereo rig",
                args.input
            )));
        }
        Calibrated::Rig(r) => {
            let names: Vec<&str> = r.cameras.iter().map(|c| c.name.as_str()).collect();
            return Err(Failure(format!(
                "{}: a rig of {} cameras ({}); choose the pair to rectify with --pair LEFT,RIGHT",
                args.input,
                names.len(),
                names.join(", ")
            )));
        }
    };
    let has_images = !args.images.is_empty() || !args.right.is_empty();
    if has_images && args.out.is_none() {
        return Err(Failure(
            "--images/--right: give --out DIR for the rectified images".into(),
        ));
    }
    if args.out.is_some() && !has_images {
        return Err(Failure(
            "--out: give the images to rectify with --images LEFT... --right RIGHT...".into(),
        ));
    }
    if args.output.is_none() && !has_images {
        return Err(Failure(
            "nothing to do: give -o RECT.json and/or --images ... --right ... --out DIR".into(),
        ));
    }
    if has_images && args.images.len() != args.right.len() {
        return Err(Failure(format!(
            "--images and --right: {} left and {} right images; give them as pairs, in the same order",
            args.images.len(),
            args.right.len()
        )));
    }
    let rect = stereo_rectify(&rig, alpha_option(args.alpha)?)
        .map_err(|e| Failure(format!("{}: {e}", args.input)))?;
    if has_images {
        let all: Vec<&PathBuf> = args.images.iter().chain(&args.right).collect();
        check_images(&all, rect.image_size)?;
    }
    if let Some(path) = &args.output {
        check_not_input(path, &[&args.input])?;
    }
    if let Some(dir) = &args.out {
        crate::create_folder(dir, "--out")?;
        let mut inputs: Vec<String> = args
            .images
            .iter()
            .chain(&args.right)
            .map(|p| p.display().to_string())
            .collect();
        inputs.push(args.input.clone());
        let input_refs: Vec<&str> = inputs.iter().map(String::as_str).collect();
        let left: Vec<&PathBuf> = args.images.iter().collect();
        let right: Vec<&PathBuf> = args.right.iter().collect();
        // One folder per camera: the two cameras' images often share names (cam0/0001.png,
        // cam1/0001.png), as `calib detect --draw` keeps them apart too.
        let (left_dir, right_dir) = (dir.join("left"), dir.join("right"));
        let left_out = output_paths(&left, &left_dir, &input_refs)?;
        let right_out = output_paths(&right, &right_dir, &input_refs)?;
        for d in [&left_dir, &right_dir] {
            crate::create_folder(d, "--out")?;
        }
        let k = rect.camera_matrix();
        with_threads(args.threads, || {
            let left_map = PixelMap::new(&rig.left, &rect.r1, &k, rect.image_size)
                .map_err(|e| Failure(e.to_string()))?;
            remap_all(&left, &left_out, &left_map)?;
            let right_map = PixelMap::new(&rig.right, &rect.r2, &k, rect.image_size)
                .map_err(|e| Failure(e.to_string()))?;
            remap_all(&right, &right_out, &right_map)
        })?;
    }
    // The JSON last: a run whose images failed (or that was interrupted) leaves no JSON that
    // claims a finished rectification.
    if let Some(path) = &args.output {
        write_json(path, &rect.to_json())?;
    }
    let say = match (args.quiet, args.output.as_deref()) {
        (true, _) => Say::Nothing,
        // The JSON alone on standard output.
        (false, Some("-")) => Say::Stderr,
        (false, _) => Say::Stdout,
    };
    if say != Say::Nothing {
        let t = (rect.p2[(0, 3)].abs() + rect.p2[(1, 3)].abs()) / rect.p2[(0, 0)];
        say.text(&format!(
            "rectified: f = {:.3} px, principal point ({:.3}, {:.3}), baseline {:.4} (board units), valid regions {:?} {:?}{}\n",
            rect.p1[(0, 0)],
            rect.p1[(0, 2)],
            rect.p1[(1, 2)],
            t,
            rect.roi1,
            rect.roi2,
            match &args.out {
                Some(d) => format!(
                    "; {} + {} images written to {} and {}",
                    args.images.len(),
                    args.right.len(),
                    d.join("left").display(),
                    d.join("right").display()
                ),
                None => String::new(),
            }
        ))?;
    }
    Ok(())
}

/// Writes a report, saying where.
pub fn write_report_to(
    input: &calib_export::ReportInput,
    dir: &Path,
    say: Say,
    option: &str,
) -> Result<(), Failure> {
    if dir.exists() && !dir.is_dir() {
        crate::create_folder(dir, option)?;
    }
    let written = calib_export::write_report(input, dir)
        .map_err(|e| Failure(format!("{option} {}: {e}", dir.display())))?;
    say.text(&format!(
        "report: {} ({} files)\n",
        dir.join("index.html").display(),
        written.len()
    ))
}

/// Arguments of `calib report`.
#[derive(Args, Debug)]
pub struct ReportArgs {
    /// A result of calib single, calib stereo or calib rig (JSON).
    #[arg(value_name = "RESULT.json")]
    pub input: String,
    /// The observation file the result was calibrated from (from the user or calib detect):
    /// needed for the residual, coverage and uncertainty plots.
    #[arg(long, value_name = "OBS.json")]
    pub observations: Option<String>,
    /// Folder to write index.html and the SVG plots into (created if needed). A previous
    /// report's files there are replaced (its plots this report lacks removed); other files
    /// are left alone.
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Do not print where the report went.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run_report(args: &ReportArgs) -> Result<(), Failure> {
    let (text, name) = calib_core::read_text(
        Path::new(&args.input),
        calib_core::io::DEFAULT_MAX_INPUT_BYTES,
    )?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Failure(format!("{name}: {e}")))?;
    let format = value
        .get("format")
        .and_then(|f| f.as_str())
        .unwrap_or("")
        .to_string();
    let observations = args.observations.as_deref();
    let input = if format.starts_with("calib-single-result/") {
        report_input(
            value,
            &name,
            observations,
            calib_single::Calibration::from_json,
            calib_export::ReportInput::single,
        )
    } else if format.starts_with("calib-stereo-result/") {
        report_input(
            value,
            &name,
            observations,
            calib_stereo::StereoCalibration::from_json,
            calib_export::ReportInput::stereo,
        )
    } else if format.starts_with("calib-rig-result/") {
        report_input(
            value,
            &name,
            observations,
            calib_rig::RigCalibration::from_json,
            calib_export::ReportInput::rig,
        )
    } else {
        Err(Failure(format!(
            "{name}: not a calib single, calib stereo or calib rig result (format '{format}')"
        )))
    }?;
    write_report_to(
        &input,
        &args.output,
        if args.quiet {
            Say::Nothing
        } else {
            Say::Stdout
        },
        "-o",
    )
}

/// The report of the result `value` (from file `name`) with its observation file, if given.
fn report_input<R, O: calib_core::JsonFile>(
    value: serde_json::Value,
    name: &str,
    observations: Option<&str>,
    from_json: impl FnOnce(serde_json::Value) -> Result<R, calib_core::ResultFormatError>,
    report: impl FnOnce(&R, Option<&O>) -> Result<calib_export::ReportInput, calib_export::ExportError>,
) -> Result<calib_export::ReportInput, Failure> {
    let result = from_json(value).map_err(|e| Failure(format!("{name}: {e}")))?;
    let observations = observations.map(O::read).transpose()?;
    report(&result, observations.as_ref()).map_err(|e| Failure(format!("{name}: {e}")))
}
