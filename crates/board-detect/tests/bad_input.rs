//! Bad input: every failure is a typed reason, in bounded time, never a panic.

use std::path::Path;
use std::time::{Duration, Instant};

use board_detect::synth::Scene;
use board_detect::{
    Board, DetectError, DetectOptions, GrayView, decode_gray, detect, detect_image, load_gray,
};

fn board() -> Board {
    Board::new(9, 6, 1.0).unwrap()
}

/// Detection on `pixels`, with the time it took. Bounded time: the limit is generous for
/// the test profile on a loaded 2-core machine (a 640x480 image takes a few ms in release).
fn timed_detect(pixels: &[u8], w: usize, h: usize) -> Result<board_detect::Detection, DetectError> {
    let t = Instant::now();
    let r = GrayView::packed(pixels, w, h)
        .and_then(|v| detect(&v, &board(), &DetectOptions::default()));
    assert!(
        t.elapsed() < Duration::from_secs(3),
        "took {:?}",
        t.elapsed()
    );
    r
}

fn sample_jpeg() -> Vec<u8> {
    std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/sourishg1/images/left1.jpg"),
    )
    .unwrap()
}

#[test]
fn blank_image_has_no_board() {
    assert_eq!(
        timed_detect(&vec![128u8; 640 * 480], 640, 480),
        Err(DetectError::NoBoard)
    );
    assert_eq!(
        timed_detect(&vec![0u8; 640 * 480], 640, 480),
        Err(DetectError::NoBoard)
    );
}

/// Noise is no board, not a "partial board" of the few corners a texture gives (grids of 11
/// and 18 corners were reported as partial boards).
#[test]
fn noise_has_no_board() {
    for (seed, w, h) in [
        (0x1234_5678_u32, 640, 480),
        (1, 640, 360),
        (7, 640, 360),
        (99, 800, 600),
        (12345, 640, 480),
    ] {
        let mut x = seed.wrapping_mul(2654435761).max(1);
        let noise: Vec<u8> = (0..w * h)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                (x >> 24) as u8
            })
            .collect();
        assert_eq!(
            timed_detect(&noise, w, h).map(|_| ()),
            Err(DetectError::NoBoard),
            "noise {seed} {w}x{h}"
        );
    }
}

#[test]
fn tiny_images_are_refused() {
    assert_eq!(
        timed_detect(&[7u8], 1, 1),
        Err(DetectError::ImageTooSmall {
            width: 1,
            height: 1
        })
    );
    assert!(matches!(
        timed_detect(&[0u8; 15 * 400], 15, 400),
        Err(DetectError::ImageTooSmall { .. })
    ));
    // 16x16 is searched (and has no board).
    assert_eq!(timed_detect(&[0u8; 256], 16, 16), Err(DetectError::NoBoard));
}

#[test]
fn inconsistent_buffers_are_refused() {
    assert!(matches!(
        GrayView::new(&[0u8; 10], 4, 4, 4),
        Err(DetectError::InvalidImage(_))
    ));
    assert!(matches!(
        GrayView::new(&[0u8; 100], 10, 5, 8),
        Err(DetectError::InvalidImage(_))
    ));
    assert!(matches!(
        GrayView::new(&[], 0, 0, 0),
        Err(DetectError::InvalidImage(_))
    ));
    assert!(matches!(
        GrayView::new(&[0u8; 16], 4, usize::MAX, usize::MAX),
        Err(DetectError::InvalidImage(_))
    ));
    assert!(Board::new(2, 6, 1.0).is_err());
    assert!(Board::new(9, 6, 0.0).is_err());
    assert!(Board::new(9, 6, f64::NAN).is_err());
}

/// A JPEG cut short anywhere after its header is refused as such, before decoding: decoders
/// fill the missing part with grey (before, half an image decoded without a word). Bytes after
/// the end-of-image marker are allowed.
#[test]
fn a_jpeg_cut_short_anywhere_is_named() {
    let bytes = sample_jpeg();
    let opts = DetectOptions::default();
    let mut cut: Vec<usize> = (20..bytes.len()).step_by(97).collect();
    cut.extend([bytes.len() / 2, bytes.len() - 2, bytes.len() - 1]);
    for keep in cut {
        assert_eq!(
            decode_gray(&bytes[..keep], &opts).map(|_| ()),
            Err(DetectError::Truncated),
            "{keep} of {} bytes",
            bytes.len()
        );
    }
    assert!(decode_gray(&bytes, &opts).is_ok());
    let mut trailing = bytes.clone();
    trailing.extend_from_slice(b"\0\0 bytes some cameras append");
    assert!(decode_gray(&trailing, &opts).is_ok());
    let err = DetectError::Truncated.to_string();
    assert!(err.contains("cut short (truncated JPEG"), "{err}");
    // From a file, too.
    let dir = std::env::temp_dir().join(format!("board-detect-cut-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("left3.jpg");
    std::fs::write(&f, &bytes[..bytes.len() / 2]).unwrap();
    assert_eq!(
        load_gray(&f, &opts).map(|_| ()),
        Err(DetectError::Truncated)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn truncated_jpeg_is_a_reason() {
    let bytes = sample_jpeg();
    for keep in [0, 2, 100, bytes.len() / 3, bytes.len() - 10] {
        let t = Instant::now();
        let r = decode_gray(&bytes[..keep], &DetectOptions::default())
            .and_then(|img| detect_image(&img, &board(), &DetectOptions::default()));
        assert!(t.elapsed() < Duration::from_secs(3));
        // A decoder may fill a truncated scan with grey and return an image; then the board
        // is partial or absent. Any typed error is acceptable, never a panic or a board
        // from half an image... except when only the final bytes are missing.
        if keep < bytes.len() / 2 {
            assert!(r.is_err(), "{keep} bytes: {r:?}");
        }
    }
}

#[test]
fn unsupported_formats_are_a_reason() {
    let opts = DetectOptions::default();
    assert!(matches!(
        decode_gray(b"hello, I am not an image", &opts),
        Err(DetectError::UnsupportedFormat(_))
    ));
    // A BMP header: a real format, not a supported one.
    let mut bmp = b"BM".to_vec();
    bmp.extend_from_slice(&[0u8; 60]);
    assert!(matches!(
        decode_gray(&bmp, &opts),
        Err(DetectError::UnsupportedFormat(_))
    ));
    let dir = std::env::temp_dir().join(format!("board-detect-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let f = dir.join("notes.jpg");
    std::fs::write(&f, b"not a jpeg at all").unwrap();
    // Named .jpg, so the decoder tries JPEG: either reason is right.
    assert!(matches!(
        load_gray(&f, &opts),
        Err(DetectError::UnsupportedFormat(_) | DetectError::Decode(_))
    ));
    assert!(matches!(
        load_gray(&dir.join("missing.png"), &opts),
        Err(DetectError::Io { .. })
    ));
    std::fs::remove_dir_all(&dir).ok();
}

fn crc32(data: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in data {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// A PNG that declares 20000x20000 pixels (8-bit grey) and has almost no pixel data: refused from
/// its header, nothing of 400 MB is allocated.
#[test]
fn huge_png_is_refused_from_its_header() {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend_from_slice(&20000u32.to_be_bytes());
    ihdr.extend_from_slice(&20000u32.to_be_bytes());
    ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
    png.extend_from_slice(&13u32.to_be_bytes());
    png.extend_from_slice(&ihdr);
    png.extend_from_slice(&crc32(&ihdr).to_be_bytes());
    // The start of a zlib stream (far too short for the declared pixels), then the end.
    for (kind, data) in [
        (&b"IDAT"[..], &[0x78u8, 0x9c, 0x03, 0x00][..]),
        (&b"IEND"[..], &[][..]),
    ] {
        let mut chunk = kind.to_vec();
        chunk.extend_from_slice(data);
        png.extend_from_slice(&(data.len() as u32).to_be_bytes());
        png.extend_from_slice(&chunk);
        png.extend_from_slice(&crc32(&chunk).to_be_bytes());
    }
    let t = Instant::now();
    match decode_gray(&png, &DetectOptions::default()) {
        Err(DetectError::ImageTooLarge {
            width: 20000,
            height: 20000,
            limit,
        }) => assert_eq!(limit, 100_000_000),
        other => panic!("expected ImageTooLarge, got {other:?}"),
    }
    assert!(t.elapsed() < Duration::from_millis(500));
}

/// The same for a JPEG whose frame header is patched to 20000x20000.
#[test]
fn huge_jpeg_is_refused_from_its_header() {
    let mut bytes = sample_jpeg();
    let sof = (0..bytes.len() - 9)
        .find(|&i| bytes[i] == 0xFF && (bytes[i + 1] == 0xC0 || bytes[i + 1] == 0xC2))
        .expect("SOF marker");
    bytes[sof + 5..sof + 7].copy_from_slice(&20000u16.to_be_bytes());
    bytes[sof + 7..sof + 9].copy_from_slice(&20000u16.to_be_bytes());
    match decode_gray(&bytes, &DetectOptions::default()) {
        Err(DetectError::ImageTooLarge {
            width: 20000,
            height: 20000,
            ..
        }) => {}
        other => panic!(
            "expected ImageTooLarge, got {:?}",
            other.map(|i| i.dimensions())
        ),
    }
}

/// The pixel budget applies to buffers too (tested with a small budget rather than a 400 MB
/// buffer), and large images within the budget are searched on a downscaled copy.
#[test]
fn pixel_budget_and_downscaled_search() {
    let scene = Scene {
        width: 1600,
        height: 1200,
        fx: 1500.0,
        fy: 1500.0,
        cx: 799.5,
        cy: 599.5,
        blur: 1.5,
        ..Scene::default()
    };
    let r = scene.render();
    let view = GrayView::packed(&r.pixels, 1600, 1200).unwrap();
    let small_budget = DetectOptions {
        max_pixels: 1_000_000,
        ..DetectOptions::default()
    };
    assert!(matches!(
        detect(&view, &board(), &small_budget),
        Err(DetectError::ImageTooLarge { .. })
    ));
    // Search on at most 0.5 MP (downscale 3), refinement at full resolution.
    let opts = DetectOptions {
        search_max_pixels: 500_000,
        ..DetectOptions::default()
    };
    let det = detect(&view, &board(), &opts).expect("board");
    let rms = (det
        .corners
        .iter()
        .zip(&r.corners)
        .map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2))
        .sum::<f64>()
        / 54.0)
        .sqrt();
    assert!(rms < 0.06, "RMS {rms:.4} px");
}

/// Rows of corners hidden behind a grey bar: a partial board, not a mislabelled one, down to
/// half the board (three full rows of a 9x6 board, which read as "no board" when a partial
/// board needed 4 corners on each side).
#[test]
fn hidden_rows_are_a_partial_board() {
    let scene = Scene::default();
    let r = scene.render();
    for (first_hidden, most_found) in [(45, 45), (27, 27)] {
        let mut pixels = r.pixels.clone();
        // Cover the rows of corners from `first_hidden` on with a band around their points.
        let hidden: Vec<[f64; 2]> = r.corners[first_hidden..54].to_vec();
        for y in 0..scene.height {
            for x in 0..scene.width {
                let near = hidden
                    .iter()
                    .any(|p| (p[0] - x as f64).abs() < 30.0 && (p[1] - y as f64).abs() < 12.0);
                if near {
                    pixels[y * scene.width + x] = 128;
                }
            }
        }
        match timed_detect(&pixels, scene.width, scene.height) {
            Err(DetectError::PartialBoard {
                found,
                expected: 54,
            }) => assert!(found <= most_found, "found {found}"),
            other => panic!("{first_hidden}: expected PartialBoard, got {other:?}"),
        }
    }
}
