//! Files: decoding with a pixel budget, the parallel batch, and the observation JSON files.

use std::path::{Path, PathBuf};
use std::time::Instant;

use image::{ImageFormat, ImageReader};
use serde_json::{Value, json};

use crate::{Board, DetectError, DetectOptions, Detection, GrayView, detect};

/// Detects `board` in an [`image::GrayImage`].
pub fn detect_image(
    image: &image::GrayImage,
    board: &Board,
    options: &DetectOptions,
) -> Result<Detection, DetectError> {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let view = GrayView::packed(image.as_raw(), w, h)?;
    detect(&view, board, options)
}

/// Reads and decodes a JPEG or PNG file to 8-bit grayscale. The header is read first and an
/// image above `options.max_pixels` (or below 16 pixels on a side) is refused before its
/// pixels are decoded; decoder memory is limited accordingly.
pub fn load_gray(path: &Path, options: &DetectOptions) -> Result<image::GrayImage, DetectError> {
    load_upright(path, options).map(to_gray8)
}

/// Reads a JPEG or PNG file as `cv2.imread` does, keeping its channels and depth: the EXIF
/// orientation (JPEG, and PNG's `eXIf` chunk) is applied, so the image is the upright,
/// displayed picture. The same header checks and memory limit as [`load_gray`]. The image
/// every command of the workspace works on (detection, undistortion, rectification), so that
/// their sizes and pixels agree.
pub fn load_upright(
    path: &Path,
    options: &DetectOptions,
) -> Result<image::DynamicImage, DetectError> {
    let reader = open_checked(path)?;
    if reader.format() != Some(ImageFormat::Jpeg) {
        return decode_upright(reader, options);
    }
    // The JPEG decoder reads the whole file into memory anyway: read it here, once, to check
    // that it is complete before decoding it.
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut reader.into_inner(), &mut bytes).map_err(|e| {
        DetectError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        }
    })?;
    check_jpeg_complete(&bytes)?;
    decode_upright(
        ImageReader::with_format(std::io::Cursor::new(bytes.as_slice()), ImageFormat::Jpeg),
        options,
    )
}

/// Refuses a JPEG stream that ends before its end-of-image marker (`FF D9`), which decoders
/// accept silently, filling the missing rows with grey. The marker segments are followed by
/// their lengths (an EXIF thumbnail's own `FF D9` inside APP1 does not count) and the
/// entropy-coded data of each scan up to the next marker, as libjpeg reads them (where it
/// warns "Premature end of JPEG file"); bytes after the end-of-image marker are allowed. A
/// stream that is not JPEG at all is left to the decoder.
pub(crate) fn check_jpeg_complete(bytes: &[u8]) -> Result<(), DetectError> {
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return Ok(());
    }
    let n = bytes.len();
    let mut i = 2;
    loop {
        // The next marker: 0xFF (and any fill 0xFFs), then its code. Stray bytes between
        // segments are skipped, as libjpeg does.
        let Some(ff) = memchr::memchr(0xFF, &bytes[i..]) else {
            return Err(DetectError::Truncated);
        };
        i += ff;
        while i < n && bytes[i] == 0xFF {
            i += 1;
        }
        let Some(&code) = bytes.get(i) else {
            return Err(DetectError::Truncated);
        };
        i += 1;
        match code {
            0xD9 => return Ok(()),
            // Markers without a length: restart markers, TEM, SOI, and a stuffed 0x00 out of
            // place.
            0x00 | 0x01 | 0xD0..=0xD8 => {}
            _ => {
                let Some(length) = bytes.get(i..i + 2) else {
                    return Err(DetectError::Truncated);
                };
                // The length counts its own two bytes.
                i += usize::from(u16::from_be_bytes([length[0], length[1]])).max(2);
                if i > n {
                    return Err(DetectError::Truncated);
                }
                if code == 0xDA {
                    // Start of scan: entropy-coded data up to the next marker other than a
                    // stuffed byte (FF 00) or a restart marker (FF D0 ... FF D7).
                    loop {
                        let Some(ff) = memchr::memchr(0xFF, &bytes[i..]) else {
                            return Err(DetectError::Truncated);
                        };
                        let at = i + ff;
                        match bytes.get(at + 1) {
                            None => return Err(DetectError::Truncated),
                            Some(0x00 | 0xD0..=0xD7) => i = at + 2,
                            Some(0xFF) => i = at + 1,
                            Some(_) => {
                                i = at;
                                break;
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The upright size `(width, height)` of a JPEG or PNG file ([`load_upright`]'s), from its
/// header and EXIF block alone: width and height swap for the orientations that turn the image
/// by 90 degrees.
pub fn upright_dimensions(path: &Path) -> Result<(u32, u32), DetectError> {
    let mut decoder = open_checked(path)?.into_decoder().map_err(map_image_err)?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    use image::metadata::Orientation as O;
    Ok(
        match image::ImageDecoder::orientation(&mut decoder).unwrap_or(O::NoTransforms) {
            O::Rotate90 | O::Rotate270 | O::Rotate90FlipH | O::Rotate270FlipH => (h, w),
            _ => (w, h),
        },
    )
}

/// The file opened with its format guessed from the content: JPEG or PNG, else an error.
fn open_checked(
    path: &Path,
) -> Result<ImageReader<std::io::BufReader<std::fs::File>>, DetectError> {
    let io_err = |e: std::io::Error| DetectError::Io {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let reader = ImageReader::open(path)
        .map_err(io_err)?
        .with_guessed_format()
        .map_err(io_err)?;
    check_format(reader.format())?;
    Ok(reader)
}

/// JPEG and PNG are read; anything else is refused with what it is.
fn check_format(format: Option<ImageFormat>) -> Result<(), DetectError> {
    match format {
        Some(ImageFormat::Jpeg | ImageFormat::Png) => Ok(()),
        Some(f) => Err(DetectError::UnsupportedFormat(format!(
            "{f:?} (only JPEG and PNG are supported)"
        ))),
        None => Err(DetectError::UnsupportedFormat(
            "not a JPEG or PNG file".into(),
        )),
    }
}

/// Decodes an in-memory JPEG or PNG file to 8-bit grayscale, with the same checks as
/// [`load_gray`].
pub fn decode_gray(bytes: &[u8], options: &DetectOptions) -> Result<image::GrayImage, DetectError> {
    let reader = ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| DetectError::Decode(e.to_string()))?;
    check_format(reader.format())?;
    if reader.format() == Some(ImageFormat::Jpeg) {
        check_jpeg_complete(bytes)?;
    }
    decode_upright(reader, options).map(to_gray8)
}

fn decode_upright<R: std::io::BufRead + std::io::Seek>(
    reader: ImageReader<R>,
    options: &DetectOptions,
) -> Result<image::DynamicImage, DetectError> {
    let mut decoder = reader.into_decoder().map_err(map_image_err)?;
    let (w, h) = image::ImageDecoder::dimensions(&decoder);
    crate::detect::check_size(w as u64, h as u64, options)?;
    // The decoded buffer of up to 4 channels of 16 bits, plus the decoder's own working memory.
    let mut limits = image::Limits::default();
    limits.max_alloc = Some((w as u64 * h as u64 * 8).saturating_add(64 << 20));
    image::ImageDecoder::set_limits(&mut decoder, limits).map_err(map_image_err)?;
    // The EXIF orientation, applied as cv2.imread does. An unreadable EXIF block is ignored, as
    // OpenCV ignores it.
    let orientation = image::ImageDecoder::orientation(&mut decoder)
        .unwrap_or(image::metadata::Orientation::NoTransforms);
    let mut img = image::DynamicImage::from_decoder(decoder).map_err(map_image_err)?;
    img.apply_orientation(orientation);
    Ok(img)
}

/// 8-bit grey from any decoded image. 16-bit images are stretched from their 0.1th to their
/// 99.9th percentile, not scaled by 65535: a sensor's 10-, 12- or 14-bit data stored in 16 bits
/// (values up to 1023, 4095, 16383), possibly on a pedestal, would otherwise keep only a few
/// grey levels, and the percentiles (rather than the extremes) keep a few hot pixels from
/// crushing the rest.
fn to_gray8(img: image::DynamicImage) -> image::GrayImage {
    use image::DynamicImage as D;
    match img {
        D::ImageLuma16(_) | D::ImageLumaA16(_) | D::ImageRgb16(_) | D::ImageRgba16(_) => {
            let wide = img.into_luma16();
            let (w, h) = wide.dimensions();
            let (lo, hi) = percentile_range(wide.as_raw());
            let span = u32::from(hi - lo).max(1);
            let pixels = wide
                .as_raw()
                .iter()
                .map(|&v| {
                    let above = u32::from(v.clamp(lo, hi) - lo);
                    ((above * 255 + span / 2) / span) as u8
                })
                .collect();
            image::GrayImage::from_raw(w, h, pixels).unwrap_or_else(|| image::GrayImage::new(w, h))
        }
        other => other.into_luma8(),
    }
}

/// The 0.1th and 99.9th percentiles of 16-bit values (from a histogram; equal for a flat
/// image).
fn percentile_range(values: &[u16]) -> (u16, u16) {
    let mut histogram = vec![0usize; 1 << 16];
    for &v in values {
        histogram[usize::from(v)] += 1;
    }
    // The smallest value with more than `rank` values at or below it.
    let value_at = |rank: usize| {
        let mut seen = 0;
        for (v, &n) in histogram.iter().enumerate() {
            seen += n;
            if seen > rank {
                return v as u16;
            }
        }
        u16::MAX
    };
    let n = values.len();
    (value_at(n / 1000), value_at(n - 1 - n / 1000))
}

fn map_image_err(e: image::ImageError) -> DetectError {
    match e {
        image::ImageError::Unsupported(u) => DetectError::UnsupportedFormat(u.to_string()),
        image::ImageError::Limits(l) => DetectError::Decode(format!("decoder memory limit: {l}")),
        other => DetectError::Decode(other.to_string()),
    }
}

/// The outcome for one image file of [`detect_files`].
#[derive(Debug, Clone)]
pub struct ImageResult {
    /// The file.
    pub path: PathBuf,
    /// `[width, height]` in pixels when the image could be decoded.
    pub image_size: Option<[usize; 2]>,
    /// The board, or why not.
    pub outcome: Result<Detection, DetectError>,
    /// Wall time of detection and refinement in seconds, decoding excluded; `None` when the
    /// image could not be decoded.
    pub detection_seconds: Option<f64>,
}

impl ImageResult {
    /// The file name (last path component).
    pub fn file_name(&self) -> String {
        file_name(&self.path)
    }
}

/// The file name (last component) of `path`, as observation files name images; the path as
/// given when it has none (`..`).
pub fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// The names the observation files and messages use for `results`: each file's name, or its
/// path as given when another file of the list has the same name (`cam0/1.jpg` and
/// `cam1/1.jpg`), so that every name says which file it is.
pub fn image_names(results: &[ImageResult]) -> Vec<String> {
    let names: Vec<String> = results.iter().map(ImageResult::file_name).collect();
    names
        .iter()
        .zip(results)
        .map(|(n, r)| {
            if names.iter().filter(|m| *m == n).count() > 1 {
                r.path.display().to_string()
            } else {
                n.clone()
            }
        })
        .collect()
}

/// Decodes `path` and detects `board` in it, timing the detection alone.
pub fn detect_file(path: &Path, board: &Board, options: &DetectOptions) -> ImageResult {
    let img = match load_gray(path, options) {
        Ok(img) => img,
        Err(e) => {
            return ImageResult {
                path: path.to_path_buf(),
                image_size: None,
                outcome: Err(e),
                detection_seconds: None,
            };
        }
    };
    let t = Instant::now();
    let outcome = detect_image(&img, board, options);
    let dt = t.elapsed().as_secs_f64();
    ImageResult {
        path: path.to_path_buf(),
        image_size: Some([img.width() as usize, img.height() as usize]),
        outcome,
        detection_seconds: Some(dt),
    }
}

/// Detects `board` in every file, in parallel over images with rayon: `threads = None` uses
/// rayon's global pool (all cores), `Some(n)` a pool of `n` threads (`Some(1)`: sequential).
/// Results are in the order of `paths`, whatever the thread count.
pub fn detect_files(
    paths: &[PathBuf],
    board: &Board,
    options: &DetectOptions,
    threads: Option<usize>,
) -> Vec<ImageResult> {
    use rayon::prelude::*;
    let run = || {
        paths
            .par_iter()
            .map(|p| detect_file(p, board, options))
            .collect::<Vec<_>>()
    };
    match threads {
        None => run(),
        Some(n) => match rayon::ThreadPoolBuilder::new()
            .num_threads(n.max(1))
            .build()
        {
            Ok(pool) => pool.install(run),
            Err(_) => paths
                .iter()
                .map(|p| detect_file(p, board, options))
                .collect(),
        },
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    Some(if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    })
}

fn board_json(board: &Board) -> Value {
    json!({"cols": board.cols, "rows": board.rows, "square": board.square})
}

fn points_json(p: &[[f64; 2]]) -> Value {
    Value::Array(p.iter().map(|q| json!([q[0], q[1]])).collect())
}

/// The size of the first image of `results` where the board was found, and that image's name.
fn first_size<'a>(
    results: &'a [ImageResult],
    names: &'a [String],
) -> Option<([usize; 2], &'a str)> {
    results
        .iter()
        .zip(names)
        .find_map(|(r, n)| r.outcome.as_ref().ok().map(|d| (d.image_size, n.as_str())))
}

/// The corners of one image, or why it cannot be used: no board, or a size other than the
/// first image's of the same camera (`first`).
fn usable(
    r: &ImageResult,
    first: Option<([usize; 2], &str)>,
    camera: &str,
) -> Result<Vec<[f64; 2]>, String> {
    match (&r.outcome, first) {
        (Ok(d), Some((size, _))) if d.image_size == size => Ok(d.corners.clone()),
        (Ok(d), Some((size, name))) => Err(format!(
            "image size {}x{} differs from {size_w}x{size_h} of {name}, the first {camera}image with a board (all images of a camera must have one size)",
            d.image_size[0],
            d.image_size[1],
            size_w = size[0],
            size_h = size[1],
        )),
        (Ok(d), None) => Ok(d.corners.clone()),
        (Err(e), _) => Err(e.to_string()),
    }
}

/// The single-camera observation file (see `docs/formats.md`): `image_size` (of the first
/// detected image), `views` with `image` ([`image_names`]), `object_points` and
/// `image_points`, `rejected_images` with `image` and `reason` (also images whose size
/// differs from the first), `detection_seconds_per_image` (median over the images that were
/// decoded) and `board`.
pub fn observations_json(results: &[ImageResult], board: &Board) -> Value {
    let names = image_names(results);
    let first = first_size(results, &names);
    let obj: Value = Value::Array(board.object_points().iter().map(|p| json!(p)).collect());
    let mut views = Vec::new();
    let mut rejected = Vec::new();
    for (r, name) in results.iter().zip(&names) {
        match usable(r, first, "") {
            Ok(corners) => views.push(json!({
                "image": name,
                "object_points": obj.clone(),
                "image_points": points_json(&corners),
            })),
            Err(reason) => rejected.push(json!({"image": name, "reason": reason})),
        }
    }
    json!({
        "image_size": first.map(|f| f.0),
        "views": views,
        "rejected_images": rejected,
        "detection_seconds_per_image": median(results.iter().filter_map(|r| r.detection_seconds).collect()),
        "board": board_json(board),
    })
}

/// The rig observation file (see `docs/formats.md`) for `cameras`, each a name and its images
/// in frame order (`cameras[c].1[f]` is camera `c`'s image of frame `f`; the lists have one
/// length): `cameras` with `name` and `image_size` (of the camera's first image with a board;
/// absent when none has one), `frames` with the board's `object_points` and one observation
/// (`camera`, `image` ([`image_names`] of that camera), `image_points`) per camera whose image
/// of the frame shows the board, one frame per input index (a frame no camera saw has no
/// observations, so that frame `f` is always the `f`-th images); `rejected_images` with
/// `camera` (the name), `image` and `reason`; `detection_seconds_per_image` (median over all
/// images) and `board`.
pub fn rig_observations_json(cameras: &[(String, Vec<ImageResult>)], board: &Board) -> Value {
    let frames_given = cameras.iter().map(|(_, r)| r.len()).max().unwrap_or(0);
    let frames: Vec<Vec<Option<usize>>> = (0..frames_given)
        .map(|f| {
            cameras
                .iter()
                .map(|(_, r)| (f < r.len()).then_some(f))
                .collect()
        })
        .collect();
    rig_observations_json_matched(cameras, &frames, board)
}

/// [`rig_observations_json`] for cameras that need not have an image of every frame:
/// `frames[f][c]` is the index in `cameras[c].1` of camera `c`'s image of frame `f`, `None`
/// when it has none (that camera is then not in the frame, and nothing is rejected). Images
/// no frame refers to are left out. The frames are written in the order of `frames`.
pub fn rig_observations_json_matched(
    cameras: &[(String, Vec<ImageResult>)],
    frames: &[Vec<Option<usize>>],
    board: &Board,
) -> Value {
    let obj: Value = Value::Array(board.object_points().iter().map(|p| json!(p)).collect());
    let names: Vec<Vec<String>> = cameras.iter().map(|(_, r)| image_names(r)).collect();
    let firsts: Vec<Option<([usize; 2], &str)>> = cameras
        .iter()
        .zip(&names)
        .map(|((_, r), n)| first_size(r, n))
        .collect();
    let mut frames_json = Vec::with_capacity(frames.len());
    let mut rejected = Vec::new();
    for frame in frames {
        let mut observations = Vec::new();
        for (c, (name, results)) in cameras.iter().enumerate() {
            let Some(i) = frame.get(c).copied().flatten() else {
                continue;
            };
            let (Some(r), Some(image)) = (results.get(i), names[c].get(i)) else {
                continue;
            };
            match usable(r, firsts[c], &format!("{name} ")) {
                Ok(corners) => observations.push(json!({
                    "camera": c,
                    "image": image,
                    "image_points": points_json(&corners),
                })),
                Err(reason) => {
                    rejected.push(json!({"camera": name, "image": image, "reason": reason}))
                }
            }
        }
        frames_json.push(json!({"object_points": obj.clone(), "observations": observations}));
    }
    let camera_list: Vec<Value> = cameras
        .iter()
        .zip(&firsts)
        .map(|((name, _), first)| match first {
            Some((size, _)) => json!({"name": name, "image_size": size}),
            None => json!({"name": name}),
        })
        .collect();
    json!({
        "cameras": camera_list,
        "frames": frames_json,
        "rejected_images": rejected,
        "detection_seconds_per_image": median(cameras.iter().flat_map(|(_, r)| r.iter()).filter_map(|r| r.detection_seconds).collect()),
        "board": board_json(board),
    })
}

/// The stereo observation file for paired lists (`left[i]` with `right[i]`; extra entries of
/// the longer list are reported as unpaired): `image_size` (the left camera's, from its first
/// image with a board), `right_image_size` (the right camera's, likewise; written when it
/// differs from the left one's: the two cameras may have different resolutions), `pairs` with
/// `left_image`, `right_image` ([`image_names`] of each camera), `object_points`,
/// `left_points`, `right_points`; `rejected_pairs` with `left_image`, `right_image` and
/// `reason` (a pair is dropped when either side fails, or an image's size differs from its
/// own camera's first image's); `detection_seconds_per_image` (median over both cameras) and
/// `board`.
pub fn stereo_observations_json(
    left: &[ImageResult],
    right: &[ImageResult],
    board: &Board,
) -> Value {
    let (left_names, right_names) = (image_names(left), image_names(right));
    let left_first = first_size(left, &left_names);
    let right_first = first_size(right, &right_names);
    let obj: Value = Value::Array(board.object_points().iter().map(|p| json!(p)).collect());
    let mut pairs = Vec::new();
    let mut rejected = Vec::new();
    let n = left.len().max(right.len());
    for i in 0..n {
        let (l, r) = (left.get(i), right.get(i));
        let (ln, rn) = (left_names.get(i), right_names.get(i));
        let (Some(l), Some(r)) = (l, r) else {
            rejected.push(
                json!({"left_image": ln, "right_image": rn, "reason": "no image to pair with"}),
            );
            continue;
        };
        let (ln, rn) = (&left_names[i], &right_names[i]);
        let side = |x: &ImageResult, name: &str, first, camera| {
            usable(x, first, camera).map_err(|e| format!("{name}: {e}"))
        };
        match (
            side(l, ln, left_first, "left "),
            side(r, rn, right_first, "right "),
        ) {
            (Ok(lp), Ok(rp)) => pairs.push(json!({
                "left_image": ln,
                "right_image": rn,
                "object_points": obj.clone(),
                "left_points": points_json(&lp),
                "right_points": points_json(&rp),
            })),
            (a, b) => {
                let reasons: Vec<String> = [a.err(), b.err()].into_iter().flatten().collect();
                rejected.push(json!({
                    "left_image": ln,
                    "right_image": rn,
                    "reason": reasons.join("; "),
                }));
            }
        }
    }
    let mut file = json!({
        "image_size": left_first.map(|f| f.0),
        "pairs": pairs,
        "rejected_pairs": rejected,
        "detection_seconds_per_image": median(left.iter().chain(right.iter()).filter_map(|r| r.detection_seconds).collect()),
        "board": board_json(board),
    });
    let right_size = right_first.map(|f| f.0);
    if right_size.is_some() && right_size != left_first.map(|f| f.0) {
        file["right_image_size"] = json!(right_size);
    }
    file
}
