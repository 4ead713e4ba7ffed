//! Mutations of JSON input files for fuzz tests, and the check of their results.

use serde_json::Value;

/// `text` with the byte at `at` (modulo its length) replaced by `value`; invalid UTF-8 is
/// replaced lossily, as a reader of the file would see it.
pub fn flip_byte(text: &str, at: usize, value: u8) -> String {
    let mut bytes = text.as_bytes().to_vec();
    if bytes.is_empty() {
        return String::new();
    }
    let i = at % bytes.len();
    bytes[i] = value;
    String::from_utf8_lossy(&bytes).into_owned()
}

/// `text` with its `at`-th number (modulo the count of numbers) replaced by `token` (e.g.
/// `"NaN"`, `"1e999"`, `"null"`, `"[]"`); `text` unchanged if it has no number.
pub fn replace_number(text: &str, at: usize, token: &str) -> String {
    let bytes = text.as_bytes();
    let starts: Vec<usize> = text
        .char_indices()
        .filter(|&(i, c)| {
            c.is_ascii_digit()
                && (i == 0 || (!bytes[i - 1].is_ascii_digit() && bytes[i - 1] != b'.'))
        })
        .map(|(i, _)| i)
        .collect();
    if starts.is_empty() {
        return text.to_string();
    }
    let start = starts[at % starts.len()];
    let end = text[start..]
        .find(|c: char| !(c.is_ascii_digit() || "+-.eE".contains(c)))
        .map_or(text.len(), |e| start + e);
    format!("{}{}{}", &text[..start], token, &text[end..])
}

/// Keys of result files whose value may be null by design (no trial step, no detail, no
/// validity limit).
pub const OPTIONAL_KEYS: [&str; 4] = [
    "termination_detail",
    "trial_cost",
    "gain_ratio",
    "valid_radius_px",
];

/// True if every number of a result's JSON is finite. serde_json writes NaN and infinities as
/// null, so a null fails too, except under [`OPTIONAL_KEYS`].
pub fn all_finite(value: &Value) -> bool {
    fn walk(value: &Value, key: &str) -> bool {
        match value {
            Value::Number(n) => n.as_f64().is_some_and(f64::is_finite),
            Value::Array(a) => a.iter().all(|v| walk(v, key)),
            Value::Object(o) => o.iter().all(|(k, v)| walk(v, k)),
            Value::Null => OPTIONAL_KEYS.contains(&key),
            _ => true,
        }
    }
    walk(value, "")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mutations_change_what_they_say() {
        let text = r#"{"a":[1.5,-20,3e4],"b":7}"#;
        assert_eq!(
            replace_number(text, 0, "NaN"),
            r#"{"a":[NaN,-20,3e4],"b":7}"#
        );
        // The sign stays: the number is the digit run and what follows it.
        assert_eq!(replace_number(text, 1, "0"), r#"{"a":[1.5,-0,3e4],"b":7}"#);
        assert_eq!(
            replace_number(text, 2, "null"),
            r#"{"a":[1.5,-20,null],"b":7}"#
        );
        // Counting wraps around (an exponent's digits count as a run of their own).
        assert_eq!(replace_number(text, 6, "x"), r#"{"a":[1.5,-x,3e4],"b":7}"#);
        assert_eq!(replace_number("7", 0, "x"), "x");
        assert_eq!(replace_number("{}", 3, "x"), "{}");
        assert_eq!(flip_byte("abc", 4, b'X'), "aXc");
        assert_eq!(flip_byte("", 4, b'X'), "");
    }

    #[test]
    fn all_finite_refuses_nulls_except_optional_keys() {
        let v = |s: &str| serde_json::from_str::<Value>(s).unwrap();
        assert!(all_finite(&v(r#"{"a":[1,2],"gain_ratio":null}"#)));
        assert!(!all_finite(&v(r#"{"a":[1,null]}"#)));
        assert!(!all_finite(&v(r#"{"rms":null}"#)));
        assert!(all_finite(&v(r#"{"solver":{"trial_cost":null,"x":"s"}}"#)));
    }
}
