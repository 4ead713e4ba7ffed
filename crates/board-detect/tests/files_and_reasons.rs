//! Image files as cameras write them (16-bit, EXIF orientation), stereo pairs of two
//! resolutions, names that repeat, and the reasons given for images that are not one board.

use std::path::{Path, PathBuf};

use board_detect::image::{self, GrayImage, ImageEncoder};
use board_detect::{
    Board, DetectError, DetectOptions, Detection, ImageResult, decode_gray, detect_image,
    image_names, load_gray, observations_json, stereo_observations_json,
};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data/sourishg1/images")
        .join(name)
}

fn board() -> Board {
    Board::new(9, 6, 1.0).unwrap()
}

fn left1() -> GrayImage {
    load_gray(&data("left1.jpg"), &DetectOptions::default()).unwrap()
}

fn found(img: &GrayImage, board: &Board) -> Result<Detection, DetectError> {
    detect_image(img, board, &DetectOptions::default())
}

fn max_distance(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
        .fold(0.0, f64::max)
}

/// A sensor's 12-bit data in a 16-bit PNG (values 0..=4080, as many machine-vision cameras
/// write), also with three hot pixels at 65535 and on a pedestal of 60000: the board is found
/// where the 8-bit photograph has it. (Scaling by the largest value lost the board to one hot
/// pixel, and to the pedestal.)
#[test]
fn twelve_bit_data_in_a_sixteen_bit_png_is_found() {
    let gray = left1();
    let (w, h) = gray.dimensions();
    let eight = found(&gray, &board()).unwrap();
    let twelve_bit: Vec<u16> = gray.as_raw().iter().map(|&v| u16::from(v) << 4).collect();
    let mut hot = twelve_bit.clone();
    for i in [1000, 50_000, 120_000] {
        hot[i] = u16::MAX;
    }
    let pedestal: Vec<u16> = twelve_bit.iter().map(|&v| v + 60_000).collect();
    for (what, wide) in [
        ("12-bit", twelve_bit),
        ("hot pixels", hot),
        ("pedestal", pedestal),
    ] {
        let mut bytes = Vec::new();
        let raw: Vec<u8> = wide.iter().flat_map(|v| v.to_ne_bytes()).collect();
        image::codecs::png::PngEncoder::new(&mut bytes)
            .write_image(&raw, w, h, image::ExtendedColorType::L16)
            .unwrap();
        let decoded = decode_gray(&bytes, &DetectOptions::default()).unwrap();
        let max = decoded.as_raw().iter().copied().max().unwrap();
        assert!(max >= 250, "{what}: decoded to at most {max} of 255");
        let corners = found(&decoded, &board())
            .unwrap_or_else(|e| panic!("{what}: the board is not found: {e}"));
        assert!(
            max_distance(&corners.corners, &eight.corners) < 0.1,
            "{what}"
        );
    }
}

/// A JPEG whose EXIF orientation is 6 (turn 90 degrees clockwise to display), as phones write
/// them: read upright, as cv2.imread reads it, so the size and the corners are the
/// displayed picture's.
#[test]
fn exif_orientation_is_applied() {
    let original = std::fs::read(data("left1.jpg")).unwrap();
    // An APP1 EXIF segment with one tag, Orientation (0x0112) = 6, right after the SOI marker:
    // the compressed pixels stay the same.
    let mut tiff = b"II*\0".to_vec();
    tiff.extend(8u32.to_le_bytes());
    tiff.extend(1u16.to_le_bytes());
    tiff.extend(0x0112u16.to_le_bytes());
    tiff.extend(3u16.to_le_bytes());
    tiff.extend(1u32.to_le_bytes());
    tiff.extend(6u32.to_le_bytes());
    tiff.extend(0u32.to_le_bytes());
    let mut app1 = b"Exif\0\0".to_vec();
    app1.extend(tiff);
    let mut jpeg = original[..2].to_vec();
    jpeg.extend([0xff, 0xe1]);
    jpeg.extend(((app1.len() + 2) as u16).to_be_bytes());
    jpeg.extend(app1);
    jpeg.extend(&original[2..]);

    let upright = decode_gray(&jpeg, &DetectOptions::default()).unwrap();
    assert_eq!(upright.dimensions(), (360, 640), "width and height swap");
    let turned = found(&upright, &board()).unwrap();
    assert_eq!(turned.image_size, [360, 640]);
    // Turning 90 degrees clockwise takes the pixel (x, y) of the stored 640x360 image to
    // (359 - y, x); the colour rule keeps every label on its physical corner.
    let stored = found(&left1(), &board()).unwrap();
    let expected: Vec<[f64; 2]> = stored
        .corners
        .iter()
        .map(|p| [359.0 - p[1], p[0]])
        .collect();
    let d = max_distance(&turned.corners, &expected);
    assert!(d < 0.05, "corners {d} px from the turned ones");

    // The colour reader every command uses (undistortion, rectification) and the header-only
    // size agree with the detector: upright, colour kept (they read the stored 640x360 before).
    let file = Path::new(env!("CARGO_TARGET_TMPDIR")).join("left1-orientation6.jpg");
    std::fs::write(&file, &jpeg).unwrap();
    assert_eq!(board_detect::upright_dimensions(&file).unwrap(), (360, 640));
    let colour = board_detect::load_upright(&file, &DetectOptions::default()).unwrap();
    assert_eq!((colour.width(), colour.height()), (360, 640));
    assert_eq!(colour.color(), image::ColorType::Rgb8);
    let grey = board_detect::load_gray(&file, &DetectOptions::default()).unwrap();
    assert_eq!(grey.as_raw(), upright.as_raw());
}

fn result(
    path: &str,
    size: [usize; 2],
    outcome: Result<Vec<[f64; 2]>, DetectError>,
) -> ImageResult {
    ImageResult {
        path: PathBuf::from(path),
        image_size: Some(size),
        outcome: outcome.map(|corners| Detection {
            corners,
            image_size: size,
            homography_rms: 0.0,
        }),
        detection_seconds: Some(0.001),
    }
}

fn corners(scale: f64) -> Vec<[f64; 2]> {
    board()
        .object_points()
        .iter()
        .map(|p| [scale * (100.0 + 20.0 * p[0]), scale * (50.0 + 20.0 * p[1])])
        .collect()
}

/// Two cameras of different resolutions (640x360 and 1280x720): every pair is kept, each
/// camera with its own image size.
#[test]
fn stereo_cameras_may_have_different_sizes() {
    let (small, large) = ([640, 360], [1280, 720]);
    let left: Vec<ImageResult> = (1..=3)
        .map(|i| result(&format!("l/left{i}.jpg"), small, Ok(corners(1.0))))
        .collect();
    let mut right: Vec<ImageResult> = (1..=3)
        .map(|i| result(&format!("r/right{i}.png"), large, Ok(corners(2.0))))
        .collect();
    let file = stereo_observations_json(&left, &right, &board());
    assert_eq!(file["pairs"].as_array().unwrap().len(), 3, "{file}");
    assert_eq!(file["image_size"], serde_json::json!([640, 360]));
    assert_eq!(file["right_image_size"], serde_json::json!([1280, 720]));
    assert_eq!(
        file["pairs"][0]["right_points"][0],
        serde_json::json!([200.0, 100.0])
    );

    // Within one camera the size must not change: the odd right image is named with both
    // sizes and the camera's first image.
    right[2] = result("r/right3.png", [1920, 1080], Ok(corners(3.0)));
    let file = stereo_observations_json(&left, &right, &board());
    assert_eq!(file["pairs"].as_array().unwrap().len(), 2);
    let reason = file["rejected_pairs"][0]["reason"].as_str().unwrap();
    for part in ["right3.png", "1920x1080", "1280x720", "right1.png"] {
        assert!(reason.contains(part), "{reason}");
    }

    // Same sizes: no right_image_size.
    let same: Vec<ImageResult> = (1..=3)
        .map(|i| result(&format!("r/right{i}.png"), small, Ok(corners(1.0))))
        .collect();
    let file = stereo_observations_json(&left, &same, &board());
    assert!(file.get("right_image_size").is_none(), "{file}");
}

/// Files of one name from two folders keep distinct names in the observation file.
#[test]
fn repeated_file_names_are_told_apart() {
    let results = vec![
        result("cam0/1.jpg", [640, 360], Ok(corners(1.0))),
        result("cam1/1.jpg", [640, 360], Ok(corners(1.0))),
        result("cam1/2.jpg", [640, 360], Err(DetectError::NoBoard)),
    ];
    assert_eq!(image_names(&results), ["cam0/1.jpg", "cam1/1.jpg", "2.jpg"]);
    let file = observations_json(&results, &board());
    assert_eq!(file["views"][0]["image"], "cam0/1.jpg");
    assert_eq!(file["views"][1]["image"], "cam1/1.jpg");
    assert_eq!(file["rejected_images"][0]["image"], "2.jpg");
}

/// A board of another size is reported with the size of the grid in the image, in the order
/// `--board COLSxROWS` takes: the 9x6 photograph as 9x6 (or 6x9 for a 4x7 board).
#[test]
fn size_mismatch_reports_the_grid_in_the_image() {
    let img = left1();
    for (cols, rows, found_cols, found_rows) in [(7, 4, 9, 6), (3, 3, 9, 6), (4, 7, 6, 9)] {
        let board = Board::new(cols, rows, 1.0).unwrap();
        match found(&img, &board) {
            Err(DetectError::SizeMismatch {
                found_cols: c,
                found_rows: r,
                ..
            }) => assert_eq!((c, r), (found_cols, found_rows), "--board {cols}x{rows}"),
            other => panic!("--board {cols}x{rows}: {other:?}"),
        }
    }
}

/// Two complete boards in one image (the photograph beside a smaller copy of itself): the
/// image is refused with the reason, not labelled on one board chosen by corner strength.
#[test]
fn two_complete_boards_are_refused() {
    let img = left1();
    let small = image::imageops::resize(&img, 384, 216, image::imageops::FilterType::Triangle);
    let mut both = GrayImage::from_pixel(640 + 384, 360, image::Luma([128]));
    image::imageops::replace(&mut both, &img, 0, 0);
    image::imageops::replace(&mut both, &small, 640, 72);
    // Each half alone has its board.
    assert!(found(&small, &board()).is_ok());
    match found(&both, &board()) {
        Err(e @ DetectError::SeveralBoards { count: 2, .. }) => {
            assert!(e.to_string().contains("one board per image"), "{e}")
        }
        other => panic!("{other:?}"),
    }
}

/// A board above a large checkered floor (a tilted 16x11 or 40x28 checker pattern filling the
/// lower half of the image): the floor alone is a size mismatch, but beside it the board is
/// found with all its corners where it is found alone (within 1e-3 px).
#[test]
fn a_board_beside_a_checkered_floor_is_found() {
    use board_detect::synth::Scene;
    let img = left1();
    let alone = found(&img, &board()).unwrap();
    for (cols, rows, square) in [(16, 11, 0.8), (40, 28, 0.3)] {
        let scene = Scene {
            width: 640,
            height: 360,
            cols,
            rows,
            square,
            rotation: [1.0, 0.0, 0.0],
            translation: [
                -(cols as f64 + 1.0) * square / 2.0,
                -(rows as f64 + 1.0) * square / 2.0,
                12.0,
            ],
            ..Scene::default()
        };
        let floor = GrayImage::from_raw(640, 360, scene.render().pixels).unwrap();
        assert!(matches!(
            found(&floor, &board()),
            Err(DetectError::SizeMismatch { .. })
        ));
        let mut both = GrayImage::from_pixel(640, 720, image::Luma([128]));
        image::imageops::replace(&mut both, &img, 0, 0);
        image::imageops::replace(&mut both, &floor, 0, 360);
        let det = found(&both, &board()).unwrap_or_else(|e| panic!("{cols}x{rows} floor: {e}"));
        // Measured: identical with the 16x11 floor, 1e-4 px apart with the 40x28 one.
        let d = max_distance(&det.corners, &alone.corners);
        assert!(
            d < 1e-3,
            "{cols}x{rows} floor: corners {d} px from those found alone"
        );
    }
}
