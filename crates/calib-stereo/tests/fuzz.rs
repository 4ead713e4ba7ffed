//! Fuzz-style test of the stereo reader and pipeline (issue 11): mutated valid stereo files
//! never panic, and whatever calibrates has only finite numbers in its result.

use calib_core::JsonFile;
use calib_stereo::synthetic::{SyntheticStereoConfig, generate_stereo};
use calib_stereo::{StereoObservations, StereoOptions, calibrate_stereo};
use calib_test_support::{all_finite, flip_byte, replace_number};
use proptest::prelude::*;
use serde_json::Value;

fn valid_file() -> Value {
    let mut config = SyntheticStereoConfig::default();
    config.left.views = 5;
    config.left.board_cols = 6;
    config.left.board_rows = 4;
    generate_stereo(&config)
        .unwrap()
        .observations
        .to_json_value()
}

#[derive(Debug, Clone)]
enum Mutation {
    FlipByte {
        at: usize,
        value: u8,
    },
    Number {
        at: usize,
        token: &'static str,
    },
    DeletePoint {
        pair: usize,
        key: usize,
        point: usize,
    },
    DuplicatePair {
        pair: usize,
    },
    SwapSides {
        pair: usize,
    },
    ReverseRight {
        pair: usize,
    },
    ScaleBoard {
        factor: f64,
    },
}

const KEYS: [&str; 3] = ["left_points", "right_points", "object_points"];

fn mutation() -> impl Strategy<Value = Mutation> {
    let token = prop::sample::select(vec![
        "0", "-1", "1e308", "1e-300", "1e999", "NaN", "null", "\"x\"", "-0", "[]",
    ]);
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(at, value)| Mutation::FlipByte { at, value }),
        (any::<usize>(), token).prop_map(|(at, token)| Mutation::Number { at, token }),
        (0..5usize, 0..3usize, 0..24usize).prop_map(|(pair, key, point)| Mutation::DeletePoint {
            pair,
            key,
            point
        }),
        (0..5usize).prop_map(|pair| Mutation::DuplicatePair { pair }),
        (0..5usize).prop_map(|pair| Mutation::SwapSides { pair }),
        (0..5usize).prop_map(|pair| Mutation::ReverseRight { pair }),
        prop::sample::select(vec![1e-9, 1e3, 1e9, -1.0])
            .prop_map(|factor| Mutation::ScaleBoard { factor }),
    ]
}

fn pair_mut(v: &mut Value, pair: usize) -> Option<&mut Value> {
    v.get_mut("pairs")?.as_array_mut()?.get_mut(pair)
}

fn apply(file: &Value, m: &Mutation) -> String {
    let mut v = file.clone();
    match *m {
        Mutation::FlipByte { at, value } => return flip_byte(&v.to_string(), at, value),
        Mutation::Number { at, token } => return replace_number(&v.to_string(), at, token),
        Mutation::DeletePoint { pair, key, point } => {
            if let Some(a) = pair_mut(&mut v, pair)
                .and_then(|p| p.get_mut(KEYS[key]))
                .and_then(Value::as_array_mut)
                && point < a.len()
            {
                a.remove(point);
            }
        }
        Mutation::DuplicatePair { pair } => {
            if let Some(copy) = pair_mut(&mut v, pair).cloned()
                && let Some(all) = v.get_mut("pairs").and_then(Value::as_array_mut)
            {
                all.push(copy);
            }
        }
        Mutation::SwapSides { pair } => {
            if let Some(p) = pair_mut(&mut v, pair) {
                let left = p["left_points"].take();
                p["left_points"] = p["right_points"].take();
                p["right_points"] = left;
            }
        }
        Mutation::ReverseRight { pair } => {
            if let Some(a) = pair_mut(&mut v, pair)
                .and_then(|p| p.get_mut("right_points"))
                .and_then(Value::as_array_mut)
            {
                a.reverse();
            }
        }
        Mutation::ScaleBoard { factor } => {
            for p in v["pairs"].as_array_mut().into_iter().flatten() {
                for q in p["object_points"].as_array_mut().into_iter().flatten() {
                    for c in q.as_array_mut().into_iter().flatten() {
                        if let Some(x) = c.as_f64() {
                            *c = serde_json::json!(x * factor);
                        }
                    }
                }
            }
        }
    }
    v.to_string()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn mutated_stereo_files_never_panic_or_produce_nan(
        mutations in prop::collection::vec(mutation(), 1..4)
    ) {
        let mut file = valid_file();
        let mut text = file.to_string();
        for m in &mutations {
            text = apply(&file, m);
            match serde_json::from_str::<Value>(&text) {
                Ok(v) => file = v,
                Err(_) => break,
            }
        }
        let Ok(observations) = StereoObservations::from_json(&text) else {
            return Ok(());
        };
        let mut skip = StereoOptions::default();
        skip.skip_bad_pairs = true;
        for options in [StereoOptions::default(), skip] {
            if let Ok(result) = calibrate_stereo(&observations, &options) {
                let json = result.to_json();
                prop_assert!(all_finite(&json), "{mutations:?}: {json}");
            }
        }
    }
}
