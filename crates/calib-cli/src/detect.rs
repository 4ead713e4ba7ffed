//! `calib detect`, and the `--board` path of `calib single` / `calib stereo`: chessboard corners
//! from photographs (crate `board-detect`, `docs/board-detect.md`).

use crate::{Failure, parse_size, write_json};
use board_detect::{Board, DetectOptions, ImageResult, detect_file, draw_detection};
use clap::Args;
use serde_json::Value;
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The board and detection options shared by `calib detect`, `calib single` and `calib stereo`.
#[derive(Args, Debug, Clone)]
pub struct BoardArgs {
    /// Chessboard inner corners COLSxROWS (a 9x6 board has 10x7 squares). With it, the inputs
    /// of `calib single` and `calib stereo` (and `calib rig`'s --camera) are images instead of
    /// an observation file.
    #[arg(long, value_name = "COLSxROWS")]
    pub board: Option<String>,
    /// Side of a square, in the unit the translations should have (mm, m, ...).
    #[arg(long, default_value_t = 1.0, value_name = "SIZE")]
    pub square: f64,
    /// Write each image as PNG into DIR with the detected corners, their labels and the board
    /// outline drawn: DIR/<image name>.png, replacing a file of that name (refused when that
    /// is an input image); other files in DIR are left alone.
    #[arg(long, value_name = "DIR")]
    pub draw: Option<PathBuf>,
    /// Match the cameras' images by the number in their file names instead of by their order
    /// (`calib stereo`, `calib rig`, `calib detect` with --right or --camera): the last run of
    /// digits, leading zeros ignored (`left07.jpg` goes with `right7.png`, `cam0/000123.png`
    /// with `cam1/000123.png`). A camera may then lack images of some frames: a stereo pair is
    /// made of the numbers both cameras have (an image without a partner is listed in
    /// rejected_pairs), a rig frame holds the cameras that have its number. Every image needs a
    /// number, and each number one image per camera.
    #[arg(long)]
    pub frames_by_number: bool,
}

impl BoardArgs {
    /// The board, if `--board` was given.
    pub fn board(&self) -> Result<Option<Board>, Failure> {
        let Some(text) = &self.board else {
            return Ok(None);
        };
        let (cols, rows) = parse_size(text, "--board")?;
        Board::new(cols as usize, rows as usize, self.square)
            .map(Some)
            .map_err(|e| Failure(format!("--board {text} --square {}: {e}", self.square)))
    }
}

/// Arguments of `calib detect`.
#[derive(Args, Debug)]
#[command(mut_arg("board", |a| a.required(true)))]
pub struct DetectArgs {
    /// Images (JPEG or PNG) of the left or only camera.
    #[arg(required_unless_present = "camera_images", value_name = "IMAGE")]
    pub images: Vec<PathBuf>,
    /// Images of the right camera, paired in order with the others: writes the stereo
    /// observation file.
    #[arg(long, num_args = 1.., value_name = "IMAGE")]
    pub right: Vec<PathBuf>,
    /// A camera's name and its images in frame order, repeated per camera (--camera left
    /// L1.jpg ... --camera right R1.jpg ...): writes the rig observation file of `calib rig`
    /// (frame f is every camera's f-th image, or with --frames-by-number the images numbered
    /// alike).
    #[arg(
        long = "camera",
        num_args = 2..,
        action = clap::ArgAction::Append,
        value_names = ["NAME", "IMAGE"],
        conflicts_with_all = ["images", "right"]
    )]
    pub camera_images: Vec<String>,
    /// The --camera groups, `(name, images)` (regrouped from the command line by `main`).
    #[arg(skip)]
    pub cameras: Vec<(String, Vec<String>)>,
    #[command(flatten)]
    pub board: BoardArgs,
    /// Observation file to write ("-" for stdout).
    #[arg(short, long, value_name = "OBS.json")]
    pub output: String,
    /// Threads (0 = all cores, at most 1024).
    #[arg(long, default_value_t = 0, value_parser = crate::parse_threads)]
    pub threads: usize,
    /// No summary line.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Detects the board in every image (in parallel, with a progress line on a terminal when there
/// are more than a few images), drawing overlays if asked (to `overlays[i]` for `paths[i]`).
pub fn detect_all(
    paths: &[PathBuf],
    board: &Board,
    overlays: Option<&[PathBuf]>,
    threads: usize,
    label: &str,
) -> Result<Vec<ImageResult>, Failure> {
    use rayon::prelude::*;
    if let Some(overlays) = overlays {
        for dir in overlays.iter().filter_map(|p| p.parent()) {
            crate::create_folder(dir, "--draw")?;
        }
    }
    let options = DetectOptions::default();
    let done = AtomicUsize::new(0);
    let total = paths.len();
    let progress = total > 4 && std::io::stderr().is_terminal();
    let run = || {
        paths
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let r = detect_file(p, board, &options);
                if let Some(out) = overlays.and_then(|o| o.get(i)) {
                    draw(out, p, board, &r, &options);
                }
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                if progress {
                    let _ = write!(std::io::stderr(), "\rdetecting {label}{n}/{total}");
                }
                r
            })
            .collect::<Vec<_>>()
    };
    let results = if threads == 0 {
        run()
    } else {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| Failure(format!("--threads {threads}: {e}")))?
            .install(run)
    };
    if progress {
        let _ = write!(std::io::stderr(), "\r{:40}\r", "");
    }
    Ok(results)
}

/// The overlay file of every image of `cameras` (each a folder under `dir`, `""` for `dir`
/// itself, and its images): `<folder>/<image stem>.png`, and when two images of a folder
/// would get one name (`a/1.jpg` and `b/1.jpg`, or `x.jpg` and `x.png`) the later ones in
/// input order get `<stem>-2.png`, `<stem>-3.png`, ... (names compared ignoring case, for
/// file systems that do).
pub fn overlay_paths(dir: &Path, cameras: &[(&str, &[PathBuf])]) -> Vec<Vec<PathBuf>> {
    cameras
        .iter()
        .map(|(folder, paths)| {
            let mut used = std::collections::HashSet::new();
            paths
                .iter()
                .map(|path| {
                    let stem = path
                        .file_stem()
                        .map(|s| s.to_string_lossy().into_owned())
                        .unwrap_or_else(|| "image".into());
                    let mut name = format!("{stem}.png");
                    let mut k = 2;
                    while !used.insert(name.to_lowercase()) {
                        name = format!("{stem}-{k}.png");
                        k += 1;
                    }
                    dir.join(folder).join(name)
                })
                .collect()
        })
        .collect()
}

/// Refuses overlays (`--draw DIR`) that would replace one of the input images: a PNG photograph
/// in DIR has the name of its overlay.
pub fn check_overlays(overlays: &[&[PathBuf]], inputs: &[&[PathBuf]]) -> Result<(), Failure> {
    let inputs: Vec<&str> = inputs
        .iter()
        .flat_map(|paths| paths.iter())
        .map(|p| p.to_str().unwrap_or(""))
        .collect();
    for out in overlays.iter().flat_map(|paths| paths.iter()) {
        crate::run::check_not_input(&out.to_string_lossy(), &inputs).map_err(|_| {
            Failure(format!(
                "--draw: the drawing {} would replace that input image; draw into another folder",
                out.display()
            ))
        })?;
    }
    Ok(())
}

/// Writes the overlay of one image, atomically (a failure to draw is reported, not fatal).
fn draw(out: &Path, path: &Path, board: &Board, result: &ImageResult, options: &DetectOptions) {
    let Ok(image) = board_detect::load_gray(path, options) else {
        return;
    };
    let drawn = draw_detection(&image, board, result.outcome.as_ref().ok());
    let written =
        calib_export::remap::write_image(&board_detect::image::DynamicImage::ImageRgb8(drawn), out);
    if let Err(e) = written {
        let _ = writeln!(std::io::stderr(), "calib: cannot draw: {e}");
    }
}

/// A one-line summary of a detection run (and the rejected images, one per line).
pub fn summary(results: &[ImageResult], file: &Value) -> String {
    let found = results.iter().filter(|r| r.outcome.is_ok()).count();
    let mut out = format!("detected the board in {found} of {} images", results.len());
    if let Some(pairs) = file["pairs"].as_array() {
        let total = pairs.len() + file["rejected_pairs"].as_array().map_or(0, Vec::len);
        out += &format!(", {} of {total} pairs usable", pairs.len());
    }
    if let Some(t) = file["detection_seconds_per_image"].as_f64() {
        out += &format!(" ({:.2} ms per image)", t * 1e3);
    }
    out.push('\n');
    for key in ["rejected_images", "rejected_pairs"] {
        for r in file[key].as_array().into_iter().flatten() {
            let name = r["image"].as_str().map(str::to_string).unwrap_or_else(|| {
                format!(
                    "{} / {}",
                    r["left_image"].as_str().unwrap_or("-"),
                    r["right_image"].as_str().unwrap_or("-")
                )
            });
            out += &format!(
                "  rejected {name}: {}\n",
                r["reason"].as_str().unwrap_or("")
            );
        }
    }
    out
}

/// Fails when no image (no pair) has a usable board: with the count and the first reasons.
fn require_views(file: &Value, count: usize, stereo: bool) -> Result<(), Failure> {
    let (key, rejected_key) = if stereo {
        ("pairs", "rejected_pairs")
    } else {
        ("views", "rejected_images")
    };
    if file[key].as_array().is_some_and(|v| !v.is_empty()) {
        return Ok(());
    }
    let rejected: Vec<String> = file[rejected_key]
        .as_array()
        .into_iter()
        .flatten()
        .map(|r| {
            let reason = r["reason"].as_str().unwrap_or("");
            match r["image"].as_str() {
                Some(name) => format!("{name}: {reason}"),
                None => reason.to_string(),
            }
        })
        .collect();
    let shown = rejected
        .iter()
        .take(3)
        .cloned()
        .collect::<Vec<_>>()
        .join("; ");
    let more = match rejected.len() {
        n if n > 3 => format!("; and {} more", n - 3),
        _ => String::new(),
    };
    Err(Failure(match (stereo, count) {
        (true, 1) => format!("the pair does not show the board in both images ({shown})"),
        (true, _) => {
            format!("no pair of the {count} shows the board in both images ({shown}{more})")
        }
        (false, 1) => format!("no board found in the image ({shown})"),
        (false, _) => format!("no board found in any of the {count} images ({shown}{more})"),
    }))
}

/// Detects the board in single-camera images and returns the observation file; fails when
/// no image has the board.
pub fn single_observations(
    paths: &[PathBuf],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
) -> Result<(Vec<ImageResult>, Value), Failure> {
    let overlays = args
        .draw
        .as_ref()
        .map(|dir| overlay_paths(dir, &[("", paths)]).remove(0));
    if let Some(overlays) = &overlays {
        check_overlays(&[overlays], &[paths])?;
    }
    let results = detect_all(paths, board, overlays.as_deref(), threads, "")?;
    let file = board_detect::observations_json(&results, board);
    require_views(&file, paths.len(), false)?;
    Ok((results, file))
}

/// Refuses `--frames-by-number` where there is one camera (`what`: the command): it matches
/// the images of several.
pub fn refuse_frames_by_number(args: &BoardArgs, what: &str) -> Result<(), Failure> {
    if args.frames_by_number {
        return Err(Failure(format!(
            "--frames-by-number matches the images of several cameras (calib stereo, calib rig, calib detect with --right or --camera); {what} has one camera"
        )));
    }
    Ok(())
}

/// The number in a file name: its stem's last run of digits, without leading zeros (`left07.jpg`
/// -> `7`), or `None`.
fn file_number(path: &Path) -> Option<String> {
    let stem = path.file_stem()?.to_string_lossy().into_owned();
    let end = stem.rfind(|c: char| c.is_ascii_digit())? + 1;
    let start = stem[..end]
        .rfind(|c: char| !c.is_ascii_digit())
        .map_or(0, |i| i + 1);
    let digits = stem[start..end].trim_start_matches('0');
    Some(if digits.is_empty() { "0" } else { digits }.to_string())
}

/// Refuses images matched in order whose file numbers show the order is off: when every image
/// has a number in its name and the cameras' numbers agree in some frames (`left3.jpg` with
/// `right3.jpg`) but not in others (`left8.jpg` with `right9.jpg`: an image missing from one
/// camera and another extra, or the lists sorted differently). Names numbered independently
/// (timestamps, or one camera counting from 0 and another from 1) never agree, and are not
/// checked.
fn check_frame_numbers(cameras: &[(&str, &[PathBuf])], what: &str) -> Result<(), Failure> {
    let numbers: Option<Vec<Vec<String>>> = cameras
        .iter()
        .map(|(_, paths)| paths.iter().map(|p| file_number(p)).collect())
        .collect();
    let Some(numbers) = numbers else {
        return Ok(());
    };
    let frames = numbers.iter().map(Vec::len).min().unwrap_or(0);
    let agree = |f: usize| numbers.iter().all(|n| n[f] == numbers[0][f]);
    let Some(good) = (0..frames).find(|&f| agree(f)) else {
        return Ok(());
    };
    match (0..frames).find(|&f| !agree(f)) {
        None => Ok(()),
        Some(f) => {
            let listed: Vec<String> = cameras
                .iter()
                .map(|(name, paths)| format!("{name} {}", paths[f].display()))
                .collect();
            Err(Failure(format!(
                "{what} {f} matches {} by their order, but their file numbers differ while those of {what} {good} agree: is an image missing from one camera (or the lists sorted differently)? {what}s are matched in order; give every camera's images in the same order, one per {what}",
                listed.join(" with ")
            )))
        }
    }
}

/// A frame matched by file number: the number, and per camera the index of its image of the
/// frame (`None`: the camera has none).
type NumberedFrame = (String, Vec<Option<usize>>);

/// The frames of `cameras` matched by [`file_number`] (`--frames-by-number`): each frame's
/// number and, per camera, the index of its image of that frame (`None`: it has none), in
/// increasing order of the numbers. Fails, naming the image, when an image has no number or
/// two images of one camera have the same number.
fn frames_by_number(cameras: &[(&str, &[PathBuf])]) -> Result<Vec<NumberedFrame>, Failure> {
    let mut frames: std::collections::BTreeMap<(usize, String), Vec<Option<usize>>> =
        Default::default();
    for (c, (name, paths)) in cameras.iter().enumerate() {
        for (i, path) in paths.iter().enumerate() {
            let number = file_number(path).ok_or_else(|| {
                Failure(format!(
                    "--frames-by-number: {} (camera '{name}') has no number in its file name to match it by; rename it, or match the images by their order (leave out --frames-by-number)",
                    path.display()
                ))
            })?;
            // Numbers without leading zeros compare by length, then digit by digit.
            let slots = frames
                .entry((number.len(), number.clone()))
                .or_insert_with(|| vec![None; cameras.len()]);
            if let Some(earlier) = slots[c] {
                return Err(Failure(format!(
                    "--frames-by-number: {} and {} (camera '{name}') have the same number {number}: give each camera one image per number",
                    paths[earlier].display(),
                    path.display()
                )));
            }
            slots[c] = Some(i);
        }
    }
    Ok(frames
        .into_iter()
        .map(|((_, number), slots)| (number, slots))
        .collect())
}

/// Detects the board in paired images and returns the stereo observation file; fails when no
/// pair has the board in both images. Overlays go to `DIR/left/` and `DIR/right/`.
pub fn stereo_observations(
    left: &[PathBuf],
    right: &[PathBuf],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
) -> Result<(Vec<ImageResult>, Value), Failure> {
    if args.frames_by_number {
        return stereo_observations_by_number(left, right, board, args, threads);
    }
    if left.len() != right.len() {
        return Err(Failure(format!(
            "{} left images but {} right images: the pairs are matched in order, so the counts must be equal (or match them by the numbers in their file names: --frames-by-number)",
            left.len(),
            right.len()
        )));
    }
    check_frame_numbers(&[("left", left), ("right", right)], "pair")?;
    let (all, file) = detect_pairs(left, right, board, args, threads)?;
    require_views(&file, left.len(), true)?;
    Ok((all, file))
}

/// Detects the board in `left[i]` and `right[i]` (overlays to `DIR/left/` and `DIR/right/`):
/// every result (left ones first) and the stereo observation file.
fn detect_pairs(
    left: &[PathBuf],
    right: &[PathBuf],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
) -> Result<(Vec<ImageResult>, Value), Failure> {
    let overlays = args
        .draw
        .as_ref()
        .map(|dir| overlay_paths(dir, &[("left", left), ("right", right)]));
    if let Some(overlays) = &overlays {
        check_overlays(&[&overlays[0], &overlays[1]], &[left, right])?;
    }
    let overlays_of = |k: usize| overlays.as_ref().map(|o| o[k].as_slice());
    let l = detect_all(left, board, overlays_of(0), threads, "left ")?;
    let r = detect_all(right, board, overlays_of(1), threads, "right ")?;
    let file = board_detect::stereo_observations_json(&l, &r, board);
    let mut all = l;
    all.extend(r);
    Ok((all, file))
}

/// [`stereo_observations`] with the pairs matched by file number (`--frames-by-number`): the
/// numbers both cameras have, in increasing order; an image whose number the other camera
/// lacks is not detected and is listed in `rejected_pairs` ("no right image numbered 12").
fn stereo_observations_by_number(
    left: &[PathBuf],
    right: &[PathBuf],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
) -> Result<(Vec<ImageResult>, Value), Failure> {
    let frames = frames_by_number(&[("left", left), ("right", right)])?;
    let (mut l_paths, mut r_paths, mut unpaired) = (Vec::new(), Vec::new(), Vec::new());
    for (number, slots) in &frames {
        match (slots[0], slots[1]) {
            (Some(l), Some(r)) => {
                l_paths.push(left[l].clone());
                r_paths.push(right[r].clone());
            }
            (Some(l), None) => unpaired.push(serde_json::json!({
                "left_image": board_detect::file_name(&left[l]),
                "right_image": null,
                "reason": format!("no right image numbered {number}"),
            })),
            (None, Some(r)) => unpaired.push(serde_json::json!({
                "left_image": null,
                "right_image": board_detect::file_name(&right[r]),
                "reason": format!("no left image numbered {number}"),
            })),
            (None, None) => {}
        }
    }
    if l_paths.is_empty() {
        return Err(Failure(format!(
            "--frames-by-number: no number is in both the left images ({}) and the right ones ({}): check that both lists are of the same capture",
            describe_numbers(&frames, 0),
            describe_numbers(&frames, 1)
        )));
    }
    let (all, mut file) = detect_pairs(&l_paths, &r_paths, board, args, threads)?;
    if let Some(rejected) = file["rejected_pairs"].as_array_mut() {
        rejected.extend(unpaired);
    }
    require_views(&file, frames.len(), true)?;
    Ok((all, file))
}

/// Camera `c`'s numbers in `frames`, for a message: "1 to 29, 29 images", or the few there are.
fn describe_numbers(frames: &[NumberedFrame], c: usize) -> String {
    let numbers: Vec<&str> = frames
        .iter()
        .filter(|(_, slots)| slots[c].is_some())
        .map(|(n, _)| n.as_str())
        .collect();
    match numbers.as_slice() {
        [] => "none".into(),
        [one] => format!("number {one}"),
        [first, .., last] if numbers.len() > 4 => {
            format!("{first} to {last}, {} images", numbers.len())
        }
        all => format!("numbers {}", all.join(", ")),
    }
}

/// Detects the board in every camera's images, frame `f` being each camera's `f`-th image, and
/// returns the rig observation file ([`board_detect::rig_observations_json`]); fails when the
/// cameras give different numbers of images or a camera has no image with the board. Overlays
/// go to `DIR/NAME/`.
pub fn rig_observations(
    cameras: &[(String, Vec<PathBuf>)],
    board: &Board,
    args: &BoardArgs,
    threads: usize,
) -> Result<(Vec<ImageResult>, Value), Failure> {
    let named: Vec<(&str, &[PathBuf])> = cameras
        .iter()
        .map(|(n, p)| (n.as_str(), p.as_slice()))
        .collect();
    let matched = if args.frames_by_number {
        Some(frames_by_number(&named)?)
    } else {
        let frames = cameras.first().map_or(0, |(_, p)| p.len());
        if let Some((name, paths)) = cameras.iter().find(|(_, p)| p.len() != frames) {
            return Err(Failure(format!(
                "camera '{name}' has {} images but camera '{}' has {frames}: frames are matched in order (the f-th image of every camera is frame f), so every camera needs one image per frame, in the same order (or match them by the numbers in their file names: --frames-by-number)",
                paths.len(),
                cameras[0].0
            )));
        }
        check_frame_numbers(&named, "frame")?;
        None
    };
    let overlays = args.draw.as_ref().map(|dir| overlay_paths(dir, &named));
    if let Some(overlays) = &overlays {
        let outs: Vec<&[PathBuf]> = overlays.iter().map(Vec::as_slice).collect();
        let ins: Vec<&[PathBuf]> = cameras.iter().map(|(_, p)| p.as_slice()).collect();
        check_overlays(&outs, &ins)?;
    }
    let mut detected = Vec::with_capacity(cameras.len());
    for (c, (name, paths)) in cameras.iter().enumerate() {
        let overlay = overlays.as_ref().map(|o| o[c].as_slice());
        let results = detect_all(paths, board, overlay, threads, &format!("{name} "))?;
        detected.push((name.clone(), results));
    }
    for (name, results) in &detected {
        let one = board_detect::observations_json(results, board);
        require_views(&one, results.len(), false)
            .map_err(|Failure(m)| Failure(format!("camera '{name}': {m}")))?;
    }
    let file = match matched {
        Some(frames) => {
            let slots: Vec<Vec<Option<usize>>> = frames.into_iter().map(|(_, s)| s).collect();
            board_detect::rig_observations_json_matched(&detected, &slots, board)
        }
        None => board_detect::rig_observations_json(&detected, board),
    };
    Ok((detected.into_iter().flat_map(|(_, r)| r).collect(), file))
}

/// The images a calibration from photographs left out, for its result: the observation
/// file's `rejected_images` (or `rejected_pairs`), and how many there were in all.
pub struct Skipped {
    /// `rejected_images` or `rejected_pairs`.
    pub key: &'static str,
    /// Its entries (`image` or `left_image` and `right_image`, and `reason`).
    pub entries: Vec<Value>,
    /// Images (pairs) given.
    pub total: usize,
}

impl Skipped {
    /// From an observation file written by [`single_observations`] or [`stereo_observations`].
    pub fn from_file(file: &Value, total: usize) -> Self {
        let key = if file.get("rejected_pairs").is_some() {
            "rejected_pairs"
        } else {
            "rejected_images"
        };
        Skipped {
            key,
            entries: file[key].as_array().cloned().unwrap_or_default(),
            total,
        }
    }

    /// The `images-skipped` warning, or none when every image was used: the images (pairs)
    /// without a usable board, and apart from them the images `--frames-by-number` found no
    /// partner for.
    pub fn warning(&self) -> Option<calib_core::Warning> {
        if self.entries.is_empty() {
            return None;
        }
        let name = |r: &Value| match r["image"].as_str() {
            Some(name) => name.to_string(),
            None => format!(
                "{} / {}",
                r["left_image"].as_str().unwrap_or("-"),
                r["right_image"].as_str().unwrap_or("-")
            ),
        };
        let unpaired = |r: &&Value| {
            r["reason"].as_str().is_some_and(|t| {
                t.starts_with("no left image numbered") || t.starts_with("no right image numbered")
            })
        };
        let list = |entries: Vec<&Value>| {
            let shown: Vec<String> = entries.iter().take(5).map(|r| name(r)).collect();
            let more = match entries.len() {
                n if n > 5 => format!(" and {} more", n - 5),
                _ => String::new(),
            };
            format!("{}{more}", shown.join(", "))
        };
        let (without_partner, without_board): (Vec<&Value>, Vec<&Value>) =
            self.entries.iter().partition(|r| unpaired(r));
        let advice = match (without_board.is_empty(), without_partner.is_empty()) {
            (false, true) => "retake them or check --board",
            (true, false) => "check that the other camera's images of those numbers were given",
            _ => {
                "retake those without a board or check --board, and check that the other camera's images of the other numbers were given"
            }
        };
        let mut parts = Vec::new();
        if !without_board.is_empty() {
            parts.push(format!("no usable board: {}", list(without_board)));
        }
        if !without_partner.is_empty() {
            parts.push(format!(
                "no image of the other camera with the same number: {}",
                list(without_partner)
            ));
        }
        let what = if self.key == "rejected_pairs" {
            "image pairs"
        } else {
            "images"
        };
        Some(calib_core::Warning::new(
            calib_core::WarningCode::ImagesSkipped,
            format!(
                "{} of {} {what} left out, {} (reasons in the result's {}; {advice})",
                self.entries.len(),
                self.total,
                parts.join("; "),
                self.key
            ),
        ))
    }
}

pub fn run(args: &DetectArgs) -> Result<(), Failure> {
    let board = args
        .board
        .board()?
        .ok_or_else(|| Failure("--board COLSxROWS is required".into()))?;
    crate::run::check_not_input(
        &args.output,
        &args
            .images
            .iter()
            .chain(&args.right)
            .map(|p| p.to_str().unwrap_or(""))
            .chain(
                args.cameras
                    .iter()
                    .flat_map(|(_, p)| p.iter().map(String::as_str)),
            )
            .collect::<Vec<_>>(),
    )?;
    let (results, file) = if !args.cameras.is_empty() {
        let cameras: Vec<(String, Vec<PathBuf>)> = args
            .cameras
            .iter()
            .map(|(n, p)| (n.clone(), p.iter().map(PathBuf::from).collect()))
            .collect();
        rig_observations(&cameras, &board, &args.board, args.threads)?
    } else if args.right.is_empty() {
        refuse_frames_by_number(&args.board, "calib detect without --right or --camera")?;
        single_observations(&args.images, &board, &args.board, args.threads)?
    } else {
        stereo_observations(&args.images, &args.right, &board, &args.board, args.threads)?
    };
    if !args.quiet {
        let _ = write!(std::io::stderr(), "{}", summary(&results, &file));
    }
    write_json(&args.output, &file)?;
    Ok(())
}
