//! YAML as OpenCV, ROS and Kalibr write it: numbers that every reader parses back exactly, and a
//! tolerant reader.
//!
//! Writing is done by hand (a few `format!` lines per file) because each tool expects an exact
//! layout: OpenCV's `%YAML:1.0` header and `!!opencv-matrix` tags, ROS's `rows/cols/data`
//! mappings, Kalibr's nested lists. Reading goes through `serde_norway` (libyaml) after removing
//! OpenCV's non-standard `%YAML:1.0` directive; its `!!opencv-matrix` tag resolves to a plain
//! mapping.

use crate::error::ExportError;
use serde_norway::Value;

/// A number in a form that parses back to the same `f64` in Rust, C (`strtod`, OpenCV), yaml-cpp
/// and PyYAML: the shortest round-trip digits, always with a decimal point, and an exponent (if
/// any) with a sign (`1.0e-05`; PyYAML's YAML 1.1 resolver reads `1e-5` as a string).
pub(crate) fn float(v: f64) -> String {
    let s = format!("{v:?}");
    match s.split_once('e') {
        Some((mantissa, exponent)) => {
            let mantissa = if mantissa.contains('.') {
                mantissa.to_string()
            } else {
                format!("{mantissa}.0")
            };
            let exponent = if exponent.starts_with('-') {
                exponent.to_string()
            } else {
                format!("+{exponent}")
            };
            format!("{mantissa}e{exponent}")
        }
        None => s,
    }
}

/// `[a, b, c]` with [`float`] numbers.
pub(crate) fn list(values: &[f64]) -> String {
    let items: Vec<String> = values.iter().map(|v| float(*v)).collect();
    format!("[{}]", items.join(", "))
}

/// Refuses a non-finite value about to be written.
pub(crate) fn check_finite(what: &str, values: &[f64]) -> Result<(), ExportError> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(ExportError::invalid(what, format!("{v} is not finite"))),
        None => Ok(()),
    }
}

/// Parses YAML text (errors name `path`); OpenCV's `%YAML:1.0` first line is accepted.
pub(crate) fn parse(text: &str, path: &str) -> Result<Value, ExportError> {
    let body = strip_opencv_directive(text);
    let value: Value = serde_norway::from_str(body).map_err(|e| ExportError::Syntax {
        path: path.to_string(),
        reason: e.to_string(),
    })?;
    Ok(untag(value))
}

/// True if the text starts with OpenCV's `%YAML:1.0` (or `%YAML 1.0`) directive.
pub(crate) fn has_opencv_directive(text: &str) -> bool {
    let t = text.trim_start_matches('\u{feff}').trim_start();
    t.starts_with("%YAML:1.") || t.starts_with("%YAML 1.0")
}

fn strip_opencv_directive(text: &str) -> &str {
    let t = text.trim_start_matches('\u{feff}');
    if has_opencv_directive(t) {
        let t = t.trim_start();
        match t.find('\n') {
            Some(i) => &t[i + 1..],
            None => "",
        }
    } else {
        t
    }
}

/// Replaces tagged values (`!!opencv-matrix {...}`) by their content, recursively.
fn untag(value: Value) -> Value {
    match value {
        Value::Tagged(t) => untag(t.value),
        Value::Mapping(m) => Value::Mapping(m.into_iter().map(|(k, v)| (k, untag(v))).collect()),
        Value::Sequence(s) => Value::Sequence(s.into_iter().map(untag).collect()),
        other => other,
    }
}

/// Typed access to a parsed YAML document, with errors that name the file and the key.
pub(crate) struct Doc<'a> {
    pub path: &'a str,
}

impl Doc<'_> {
    /// `map[key]`, or an error naming `key` (dotted `prefix.key`).
    pub fn get<'v>(
        &self,
        map: &'v Value,
        prefix: &str,
        key: &str,
    ) -> Result<&'v Value, ExportError> {
        map.get(key)
            .ok_or_else(|| ExportError::field(self.path, &join(prefix, key), "missing"))
    }

    /// A number.
    pub fn number(&self, v: &Value, key: &str) -> Result<f64, ExportError> {
        let x = v.as_f64().ok_or_else(|| {
            ExportError::field(
                self.path,
                key,
                format!("expected a number, got {}", show(v)),
            )
        })?;
        if !x.is_finite() {
            return Err(ExportError::field(
                self.path,
                key,
                format!("{x} is not finite"),
            ));
        }
        Ok(x)
    }

    /// A non-negative integer that fits `u32`.
    pub fn size(&self, v: &Value, key: &str) -> Result<u32, ExportError> {
        v.as_u64()
            .and_then(|x| u32::try_from(x).ok())
            .ok_or_else(|| {
                ExportError::field(
                    self.path,
                    key,
                    format!("expected a non-negative integer, got {}", show(v)),
                )
            })
    }

    /// A string.
    pub fn string<'v>(&self, v: &'v Value, key: &str) -> Result<&'v str, ExportError> {
        v.as_str().ok_or_else(|| {
            ExportError::field(
                self.path,
                key,
                format!("expected a string, got {}", show(v)),
            )
        })
    }

    /// A flat list of numbers (of length `len` if given).
    pub fn numbers(
        &self,
        v: &Value,
        key: &str,
        len: Option<usize>,
    ) -> Result<Vec<f64>, ExportError> {
        let seq = v.as_sequence().ok_or_else(|| {
            ExportError::field(
                self.path,
                key,
                format!("expected a list of numbers, got {}", show(v)),
            )
        })?;
        let values = seq
            .iter()
            .enumerate()
            .map(|(i, x)| self.number(x, &format!("{key}[{i}]")))
            .collect::<Result<Vec<f64>, _>>()?;
        if let Some(n) = len
            && values.len() != n
        {
            return Err(ExportError::field(
                self.path,
                key,
                format!("expected {n} numbers, got {}", values.len()),
            ));
        }
        Ok(values)
    }

    /// A `{rows, cols, data}` matrix (OpenCV's `!!opencv-matrix` or ROS's), row-major; checks
    /// the shape against `shape` when given and that `data` has `rows * cols` numbers.
    pub fn matrix(
        &self,
        v: &Value,
        key: &str,
        shape: Option<(usize, usize)>,
    ) -> Result<(usize, usize, Vec<f64>), ExportError> {
        let rows = self.size(self.get(v, key, "rows")?, &join(key, "rows"))? as usize;
        let cols = self.size(self.get(v, key, "cols")?, &join(key, "cols"))? as usize;
        if let Some(dt) = v.get("dt") {
            let dt = self.string(dt, &join(key, "dt"))?;
            if !matches!(dt, "d" | "f") {
                return Err(ExportError::field(
                    self.path,
                    &join(key, "dt"),
                    format!("expected a floating-point matrix (dt: d or f), got '{dt}'"),
                ));
            }
        }
        let data = self.numbers(
            self.get(v, key, "data")?,
            &join(key, "data"),
            Some(rows * cols),
        )?;
        if let Some((r, c)) = shape
            && (r, c) != (rows, cols)
        {
            return Err(ExportError::field(
                self.path,
                key,
                format!("expected a {r}x{c} matrix, got {rows}x{cols}"),
            ));
        }
        Ok((rows, cols, data))
    }
}

pub(crate) fn join(prefix: &str, key: &str) -> String {
    if prefix.is_empty() {
        key.to_string()
    } else {
        format!("{prefix}.{key}")
    }
}

/// A short description of a value for messages.
fn show(v: &Value) -> String {
    let s = serde_norway::to_string(v).unwrap_or_default();
    let s = s.trim();
    if s.chars().count() > 40 {
        format!("{}...", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_round_trip_through_the_yaml_reader() {
        for v in [
            0.0,
            -0.0,
            1.0,
            463.0270001,
            1e-5,
            -2.5e-17,
            1e16,
            1e300,
            0.1 + 0.2,
            5e-324,
            f64::MAX,
            -123456789.125,
        ] {
            let s = float(v);
            assert!(s.contains('.'), "{s}");
            if let Some((_, e)) = s.split_once('e') {
                assert!(e.starts_with('+') || e.starts_with('-'), "{s}");
            }
            let back: f64 = s.parse().unwrap();
            assert_eq!(back.to_bits(), v.to_bits(), "{s}");
            let parsed = parse(&format!("x: {s}\n"), "t").unwrap();
            assert_eq!(parsed["x"].as_f64().unwrap().to_bits(), v.to_bits(), "{s}");
        }
    }

    #[test]
    fn opencv_header_and_tags_are_accepted() {
        let text = "%YAML:1.0\n---\nm: !!opencv-matrix\n   rows: 1\n   cols: 3\n   dt: d\n   data: [ 4.6e+02, 0., 1e-5 ]\n";
        let v = parse(text, "t").unwrap();
        let doc = Doc { path: "t" };
        let (r, c, d) = doc.matrix(&v["m"], "m", Some((1, 3))).unwrap();
        assert_eq!((r, c), (1, 3));
        assert_eq!(d, vec![460.0, 0.0, 1e-5]);
        let err = doc.matrix(&v["m"], "m", Some((3, 3))).unwrap_err();
        assert!(err.to_string().contains("expected a 3x3 matrix"), "{err}");
        let err = parse("a: [1, 2\n", "bad.yaml").unwrap_err();
        assert!(err.to_string().starts_with("bad.yaml:"), "{err}");
    }
}
