//! An overlay picture of a detection, for users to see at once what was found.

use std::path::Path;

use image::{GrayImage, Rgb, RgbImage};

use crate::{Board, DetectError, Detection};

/// Draws the detection over the image: the board outline (green), every row of corners as a
/// polyline in a colour that runs from red (row 0) to blue (last row), each corner as a
/// small circle, corner 0 as a large white-and-red ring, and the index of the first corner of
/// every row (`0, cols, 2 cols, ...`) in digits next to it. `None` (no board) draws a red
/// frame around the image.
pub fn draw_detection(image: &GrayImage, board: &Board, detection: Option<&Detection>) -> RgbImage {
    let mut out = RgbImage::from_fn(image.width(), image.height(), |x, y| {
        let v = image.get_pixel(x, y)[0];
        Rgb([v, v, v])
    });
    let scale = ((image.width().max(image.height()) as f64 / 640.0).round() as i64).max(1);
    let Some(d) = detection else {
        let red = Rgb([230, 30, 30]);
        let (w, h) = (out.width() as f64 - 1.0, out.height() as f64 - 1.0);
        for t in 0..(2 * scale) {
            let t = t as f64;
            line(&mut out, [t, t], [w - t, t], red);
            line(&mut out, [w - t, t], [w - t, h - t], red);
            line(&mut out, [w - t, h - t], [t, h - t], red);
            line(&mut out, [t, h - t], [t, t], red);
        }
        return out;
    };
    let (cols, rows) = (board.cols, board.rows);
    if d.corners.len() != cols * rows {
        return out;
    }
    let p = |c: usize, r: usize| d.corners[r * cols + c];
    let green = Rgb([40, 220, 40]);
    let outline = [
        p(0, 0),
        p(cols - 1, 0),
        p(cols - 1, rows - 1),
        p(0, rows - 1),
        p(0, 0),
    ];
    for w in outline.windows(2) {
        line(&mut out, w[0], w[1], green);
    }
    for r in 0..rows {
        let t = if rows > 1 {
            r as f64 / (rows - 1) as f64
        } else {
            0.0
        };
        let colour = Rgb([
            (255.0 * (1.0 - t)) as u8,
            (120.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
            (255.0 * t) as u8,
        ]);
        for c in 0..cols {
            if c + 1 < cols {
                line(&mut out, p(c, r), p(c + 1, r), colour);
            }
            circle(&mut out, p(c, r), 2.5 * scale as f64, colour);
        }
        // Row start index, placed away from the board (opposite the row direction).
        let a = p(0, r);
        let b = p(1, r);
        let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
        let n = dx.hypot(dy).max(1e-9);
        let label = (r * cols).to_string();
        let lw = (label.len() as f64 * 4.0 - 1.0) * scale as f64;
        let off = 6.0 * scale as f64 + 0.5 * lw;
        let pos = [
            a[0] + dx / n * off - 0.5 * lw,
            a[1] + dy / n * off - 2.5 * scale as f64,
        ];
        text(&mut out, &label, pos, scale, Rgb([255, 255, 0]));
    }
    let c0 = p(0, 0);
    circle(&mut out, c0, 7.0 * scale as f64, Rgb([255, 255, 255]));
    circle(&mut out, c0, 5.5 * scale as f64, Rgb([230, 30, 30]));
    out
}

/// Decodes nothing: draws [`draw_detection`] and writes it as a PNG file.
pub fn write_overlay_png(
    path: &Path,
    image: &GrayImage,
    board: &Board,
    detection: Option<&Detection>,
) -> Result<(), DetectError> {
    draw_detection(image, board, detection)
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| DetectError::Io {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: Rgb<u8>) {
    if x >= 0 && y >= 0 && (x as u64) < img.width() as u64 && (y as u64) < img.height() as u64 {
        img.put_pixel(x as u32, y as u32, c);
    }
}

/// A one-pixel line by uniform steps (at most one step per pixel of the longer axis).
fn line(img: &mut RgbImage, a: [f64; 2], b: [f64; 2], c: Rgb<u8>) {
    if !(a[0].is_finite() && a[1].is_finite() && b[0].is_finite() && b[1].is_finite()) {
        return;
    }
    let n = ((b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil() as i64).clamp(1, 100_000);
    for i in 0..=n {
        let t = i as f64 / n as f64;
        put(
            img,
            (a[0] + t * (b[0] - a[0])).round() as i64,
            (a[1] + t * (b[1] - a[1])).round() as i64,
            c,
        );
    }
}

/// A one-pixel circle outline.
fn circle(img: &mut RgbImage, p: [f64; 2], r: f64, c: Rgb<u8>) {
    if !(p[0].is_finite() && p[1].is_finite()) {
        return;
    }
    let n = ((r * 8.0).ceil() as usize).max(8);
    for i in 0..n {
        let a = i as f64 * std::f64::consts::TAU / n as f64;
        put(
            img,
            (p[0] + r * a.cos()).round() as i64,
            (p[1] + r * a.sin()).round() as i64,
            c,
        );
    }
}

/// 3x5 bitmaps of the digits, one row per entry, bit 2 = left column.
const DIGITS: [[u8; 5]; 10] = [
    [7, 5, 5, 5, 7],
    [2, 6, 2, 2, 7],
    [7, 1, 7, 4, 7],
    [7, 1, 7, 1, 7],
    [5, 5, 7, 1, 1],
    [7, 4, 7, 1, 7],
    [7, 4, 7, 5, 7],
    [7, 1, 1, 1, 1],
    [7, 5, 7, 5, 7],
    [7, 5, 7, 1, 7],
];

fn text(img: &mut RgbImage, s: &str, pos: [f64; 2], scale: i64, c: Rgb<u8>) {
    let (x0, y0) = (pos[0].round() as i64, pos[1].round() as i64);
    for (k, ch) in s.chars().enumerate() {
        let Some(d) = ch.to_digit(10) else { continue };
        let glyph = DIGITS[d as usize];
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) != 0 {
                    for sy in 0..scale {
                        for sx in 0..scale {
                            let x = x0 + (k as i64 * 4 + col) * scale + sx;
                            let y = y0 + row as i64 * scale + sy;
                            put(img, x, y, c);
                        }
                    }
                }
            }
        }
    }
}
