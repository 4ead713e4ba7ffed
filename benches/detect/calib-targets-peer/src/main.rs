//! calib-targets peer for benches/detect/run.sh: `calib-targets-peer COLS ROWS SQUARE OUT.json IMAGES...`.
//! Labels: calib-targets puts grid (0, 0) at the visual top-left; a transposed grid is relabelled
//! so that the calibration sees a consistent planar board (any consistent labelling gives the
//! same calibration RMS). Timing: detection only, decoding excluded.
use calib_targets::chessboard::ChessboardParams;
use calib_targets::detect;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    // usage: peer-ct COLS ROWS SQUARE OUT.json [--sweep] IMAGES...
    let cols: i32 = args[1].parse().unwrap();
    let rows: i32 = args[2].parse().unwrap();
    let square: f64 = args[3].parse().unwrap();
    let out = &args[4];
    let mut sweep = false;
    let mut files = vec![];
    for a in &args[5..] {
        if a == "--sweep" {
            sweep = true
        } else {
            files.push(a.clone())
        }
    }
    let cfg = detect::default_chess_config();
    let params = ChessboardParams::default();
    let sweep_p = ChessboardParams::sweep_default();
    let mut views = vec![];
    let mut rejected = vec![];
    let mut times = vec![];
    let mut size = [0u32; 2];
    for f in &files {
        let img = image::open(f).unwrap().to_luma8();
        size = [img.width(), img.height()];
        let name = std::path::Path::new(f)
            .file_name()
            .unwrap()
            .to_string_lossy()
            .to_string();
        let t = Instant::now();
        let r = if sweep {
            detect::detect_chessboard_best(&img, &cfg, &sweep_p)
        } else {
            detect::detect_chessboard(&img, &cfg, &params)
        };
        times.push(t.elapsed().as_secs_f64());
        let det = match r {
            Ok(d) => d,
            Err(e) => {
                rejected.push(serde_json::json!({"image": name, "reason": e.to_string()}));
                continue;
            }
        };
        let n = det.corners.len() as i32;
        let umin = det.corners.iter().map(|c| c.grid.u).min().unwrap();
        let vmin = det.corners.iter().map(|c| c.grid.v).min().unwrap();
        let umax = det.corners.iter().map(|c| c.grid.u).max().unwrap() - umin;
        let vmax = det.corners.iter().map(|c| c.grid.v).max().unwrap() - vmin;
        let transposed = if umax == cols - 1 && vmax == rows - 1 {
            false
        } else if umax == rows - 1 && vmax == cols - 1 {
            true
        } else {
            rejected.push(serde_json::json!({"image": name, "reason": format!("partial {n} corners, span {}x{}", umax+1, vmax+1)}));
            continue;
        };
        if n != cols * rows {
            rejected.push(serde_json::json!({"image": name, "reason": format!("{n} corners")}));
            continue;
        }
        let mut pts: Vec<(i32, i32, f64, f64)> = det
            .corners
            .iter()
            .map(|c| {
                let (u, v) = (c.grid.u - umin, c.grid.v - vmin);
                let (cc, rr) = if transposed { (v, u) } else { (u, v) };
                (rr, cc, c.position.x as f64, c.position.y as f64)
            })
            .collect();
        pts.sort_by_key(|p| (p.0, p.1));
        let obj: Vec<_> = pts
            .iter()
            .map(|p| serde_json::json!([p.1 as f64 * square, p.0 as f64 * square, 0.0]))
            .collect();
        let ip: Vec<_> = pts.iter().map(|p| serde_json::json!([p.2, p.3])).collect();
        views.push(serde_json::json!({"image": name, "object_points": obj, "image_points": ip}));
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let med = times[times.len() / 2];
    eprintln!(
        "found {}/{} median {:.2} ms",
        views.len(),
        files.len(),
        med * 1e3
    );
    let v = serde_json::json!({"image_size": size, "views": views, "rejected_images": rejected, "detection_seconds_per_image": med, "board": {"cols": cols, "rows": rows, "square": square}});
    std::fs::write(out, serde_json::to_string(&v).unwrap()).unwrap();
}
