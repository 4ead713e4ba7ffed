//! Fuzz-style test of the reader and the pipeline (issue 11): mutated valid observation files
//! (byte flips, changed numbers, huge and tiny tokens, deleted or duplicated points and views,
//! swapped points, unit changes, truncation) never panic, and whatever calibrates has only
//! finite numbers in its result.

use calib_core::JsonFile;
use calib_single::synthetic::{SyntheticConfig, generate};
use calib_single::{CalibrationOptions, Observations, calibrate};
use calib_test_support::{all_finite, flip_byte, replace_number};
use proptest::prelude::*;
use serde_json::Value;

fn valid_file() -> Value {
    let set = generate(&SyntheticConfig {
        views: 6,
        board_cols: 6,
        board_rows: 4,
        ..Default::default()
    })
    .unwrap();
    set.observations.to_json_value()
}

/// A mutation of the file's JSON or text.
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
        view: usize,
        point: usize,
        both: bool,
    },
    DuplicateView {
        view: usize,
    },
    DeleteView {
        view: usize,
    },
    ScaleBoard {
        factor: f64,
    },
    SwapPoints {
        view: usize,
        a: usize,
        b: usize,
    },
    Truncate {
        at: usize,
    },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let token = prop::sample::select(vec![
        "0",
        "-1",
        "1e308",
        "-1e308",
        "1e-300",
        "1e999",
        "NaN",
        "Infinity",
        "null",
        "\"x\"",
        "18446744073709551616",
        "-0",
        "3.5",
        "[]",
        "{}",
    ]);
    prop_oneof![
        (any::<usize>(), any::<u8>()).prop_map(|(at, value)| Mutation::FlipByte { at, value }),
        (any::<usize>(), token).prop_map(|(at, token)| Mutation::Number { at, token }),
        (0..6usize, 0..24usize, any::<bool>())
            .prop_map(|(view, point, both)| Mutation::DeletePoint { view, point, both }),
        (0..6usize).prop_map(|view| Mutation::DuplicateView { view }),
        (0..6usize).prop_map(|view| Mutation::DeleteView { view }),
        prop::sample::select(vec![1e-9, 1e-3, 1e3, 1e6, 1e12, -1.0])
            .prop_map(|factor| Mutation::ScaleBoard { factor }),
        (0..6usize, 0..24usize, 0..24usize).prop_map(|(view, a, b)| Mutation::SwapPoints {
            view,
            a,
            b
        }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
    ]
}

fn apply(file: &Value, m: &Mutation) -> String {
    let mut v = file.clone();
    let views = |v: &mut Value| v["views"].as_array().cloned().unwrap_or_default();
    match *m {
        Mutation::FlipByte { at, value } => return flip_byte(&v.to_string(), at, value),
        Mutation::Number { at, token } => return replace_number(&v.to_string(), at, token),
        Mutation::DeletePoint { view, point, both } => {
            let Some(w) = v["views"].get_mut(view) else {
                return v.to_string();
            };
            for key in ["image_points", "object_points"] {
                if let Some(a) = w[key].as_array_mut()
                    && point < a.len()
                {
                    a.remove(point);
                }
                if !both {
                    break;
                }
            }
        }
        Mutation::DuplicateView { view } => {
            let mut all = views(&mut v);
            let view = view % all.len().max(1);
            if let Some(copy) = all.get(view).cloned() {
                all.push(copy);
            }
            v["views"] = Value::Array(all);
        }
        Mutation::DeleteView { view } => {
            let mut all = views(&mut v);
            if view < all.len() {
                all.remove(view);
            }
            v["views"] = Value::Array(all);
        }
        Mutation::ScaleBoard { factor } => {
            // Earlier mutations may have broken the structure: scale what is still numbers.
            for w in v["views"].as_array_mut().into_iter().flatten() {
                for p in w["object_points"].as_array_mut().into_iter().flatten() {
                    for c in p.as_array_mut().into_iter().flatten() {
                        if let Some(x) = c.as_f64() {
                            *c = serde_json::json!(x * factor);
                        }
                    }
                }
            }
        }
        Mutation::SwapPoints { view, a, b } => {
            if let Some(points) = v["views"]
                .get_mut(view)
                .and_then(|w| w.get_mut("image_points"))
                .and_then(Value::as_array_mut)
                .filter(|p| !p.is_empty())
            {
                let n = points.len();
                points.swap(a % n, b % n);
            }
        }
        Mutation::Truncate { at } => {
            let text = v.to_string();
            return text[..at % text.len()].to_string();
        }
    }
    v.to_string()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, ..ProptestConfig::default() })]

    #[test]
    fn mutated_files_never_panic_or_produce_nan(
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
        let Ok(observations) = Observations::from_json(&text) else {
            return Ok(());
        };
        let mut skip = CalibrationOptions::default();
        skip.skip_bad_views = true;
        for options in [CalibrationOptions::default(), skip] {
            if let Ok(result) = calibrate(&observations, &options) {
                let json = result.to_json();
                prop_assert!(all_finite(&json), "{mutations:?}: {json}");
                prop_assert!(result.rms.is_finite() && result.rms_all_points.is_finite());
            }
        }
    }
}
