//! Accuracy of each refinement on rendered boards with known corners (docs/board-detect.md):
//! 640x480, 9x6 board, radial distortion k1 = -0.15, k2 = 0.05, uneven lighting, three poses
//! at four blur/noise levels.
//! `cargo run --release -p board-detect --example synth_eval`
use board_detect::synth::Scene;
use board_detect::{Board, DetectOptions, GrayView, Refinement, detect};

fn main() {
    let sad = Refinement::Saddle {
        blur: 0.1,
        window: 0.2,
        max_blur: 1.5,
        max_window: 4,
    };
    let grad = Refinement::Gradient {
        window: 0.4,
        max_half_window: 12,
    };
    let methods: Vec<(&str, Refinement, Option<usize>)> = vec![
        ("none", Refinement::None, None),
        (
            "gradient-0.25",
            Refinement::Gradient {
                window: 0.25,
                max_half_window: 12,
            },
            None,
        ),
        ("gradient-0.4", grad, None),
        (
            "saddle-uncapped",
            Refinement::Saddle {
                blur: 0.1,
                window: 0.2,
                max_blur: 6.0,
                max_window: 15,
            },
            None,
        ),
        ("saddle (default)", sad, None),
        ("saddle+warp2", sad, Some(2)),
        ("saddle+warp3", sad, Some(3)),
        ("saddle+warp4", sad, Some(4)),
    ];
    let scenes: Vec<(String, Scene)> = [(0.7, 1.0), (1.0, 2.0), (1.5, 2.0), (2.5, 3.0)]
        .iter()
        .flat_map(|&(blur, noise)| {
            [
                ([0.2, -0.3, 0.1], [-3.5, -2.0, 14.0]),
                ([0.5, 0.3, 3.0], [4.0, 2.0, 12.0]),
                ([-0.4, 0.5, -0.3], [-4.0, -2.5, 17.0]),
            ]
            .into_iter()
            .enumerate()
            .map(move |(k, (rv, t))| {
                (
                    format!("blur {blur} noise {noise} pose {k}"),
                    Scene {
                        blur,
                        noise,
                        rotation: rv,
                        translation: t,
                        seed: k as u64 + 7,
                        ..Scene::default()
                    },
                )
            })
        })
        .collect();
    let rendered: Vec<_> = scenes.iter().map(|(_, s)| s.render()).collect();
    println!("RMS corner error (px) against the truth; columns: one per scene");
    for (k, (name, _)) in scenes.iter().enumerate() {
        println!("  column {}: {name}", k + 1);
    }
    for (name, m, j) in &methods {
        let opts = DetectOptions {
            refinement: *m,
            joint_warp_degree: *j,
            ..DetectOptions::default()
        };
        print!("{name:18}");
        for ((_, s), r) in scenes.iter().zip(&rendered) {
            let board = Board::new(s.cols, s.rows, s.square).unwrap();
            let v = GrayView::packed(&r.pixels, s.width, s.height).unwrap();
            match detect(&v, &board, &opts) {
                Ok(d) => {
                    let e2: f64 = d
                        .corners
                        .iter()
                        .zip(&r.corners)
                        .map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2))
                        .sum();
                    print!(" {:.4}", (e2 / d.corners.len() as f64).sqrt());
                }
                Err(e) => print!(" [{e}]"),
            }
        }
        println!();
    }
}
