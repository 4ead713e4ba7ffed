//! Reading input files with a bound on their size, and writing output files atomically.

use std::io::{Read, Write};
use std::path::Path;

/// Default bound on the size of an input file: 2 GiB (a 1000-view stereo file of 20x20 boards
/// is about 90 MB).
pub const DEFAULT_MAX_INPUT_BYTES: u64 = 2 << 30;

/// Problems reading an input file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ReadError {
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The path.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file is larger than the bound.
    #[error(
        "{path} is larger than {limit} bytes; raise the limit (--max-input) if it really is an input file"
    )]
    TooLarge {
        /// The path.
        path: String,
        /// The bound, bytes.
        limit: u64,
    },
    /// The file is not valid JSON of the expected format.
    #[error("{path}: {source}{context}")]
    Json {
        /// The path (or `<string>` for text parsed from memory).
        path: String,
        /// The parse error, with line and column.
        source: serde_json::Error,
        /// For a syntax or data error, the text there and what it means (`NaN` is not JSON);
        /// else empty.
        context: String,
    },
    /// The file is valid JSON but its content is inconsistent.
    #[error("{path}: {reason}")]
    Content {
        /// The path.
        path: String,
        /// What is wrong.
        reason: String,
    },
}

/// Reads a whole text file of at most `max_bytes` bytes: its text and the displayable path that
/// error messages name. Reads through a bound, so a device or pipe without end (`/dev/zero`)
/// fails with [`ReadError::TooLarge`] instead of exhausting memory.
pub fn read_text(path: &Path, max_bytes: u64) -> Result<(String, String), ReadError> {
    let name = path.display().to_string();
    let io = |source| ReadError::Io {
        path: name.clone(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::new();
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(ReadError::TooLarge {
            path: name,
            limit: max_bytes,
        });
    }
    let text = String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text: {e}"),
        ))
    })?;
    Ok((text, name))
}

/// Parses JSON text of type `T`; errors name `path` (any label, e.g. `<string>`) with the line
/// and column.
pub fn parse_json<T: serde::de::DeserializeOwned>(text: &str, path: &str) -> Result<T, ReadError> {
    serde_json::from_str(text).map_err(|source| ReadError::Json {
        path: path.to_string(),
        context: syntax_context(text, &source),
        source,
    })
}

/// For a syntax or data error (a value of the wrong kind, e.g. a camera index of -1): the text
/// at the error (files are often one long line, where a column alone does not help), and a hint
/// when it is a non-finite number, which JSON cannot hold.
fn syntax_context(text: &str, error: &serde_json::Error) -> String {
    if !(error.is_syntax() || error.is_data()) || error.line() == 0 {
        return String::new();
    }
    let Some(line) = text.lines().nth(error.line().saturating_sub(1)) else {
        return String::new();
    };
    // serde_json's column is 1-based and counts bytes.
    let at = error.column().saturating_sub(1).min(line.len());
    let floor = |mut i: usize| {
        while !line.is_char_boundary(i) {
            i -= 1;
        }
        i
    };
    let (from, to) = (
        floor(at.saturating_sub(40)),
        floor((at + 20).min(line.len())),
    );
    let here = line[floor(at)..].trim_start();
    let hint = if ["NaN", "nan", "Infinity", "-Infinity", "inf", "-inf"]
        .iter()
        .any(|w| here.starts_with(w))
    {
        ": JSON has no NaN or infinity; leave a corner that was not found out of its view (with its board point)"
    } else {
        ""
    };
    format!(", near \"{}\"{hint}", &line[from..to])
}

/// Reads a JSON file of type `T` of at most `max_bytes` bytes ([`read_text`], [`parse_json`]).
pub fn read_json<T: serde::de::DeserializeOwned>(
    path: &Path,
    max_bytes: u64,
) -> Result<T, ReadError> {
    let (text, name) = read_text(path, max_bytes)?;
    parse_json(&text, &name)
}

/// An input file format read from JSON: implementors give the serde form of the file and the
/// conversion; reading (bounded in size) and parsing come with the trait.
pub trait JsonFile: Sized {
    /// The serde form of the file.
    type File: serde::de::DeserializeOwned;

    /// The value a parsed file describes.
    fn from_file(file: Self::File) -> Self;

    /// Parses JSON text (errors name `<string>` and the line and column).
    fn from_json(text: &str) -> Result<Self, ReadError> {
        parse_json(text, "<string>").map(Self::from_file)
    }

    /// Reads a file of at most [`DEFAULT_MAX_INPUT_BYTES`].
    fn read(path: impl AsRef<Path>) -> Result<Self, ReadError> {
        Self::read_bounded(path, DEFAULT_MAX_INPUT_BYTES)
    }

    /// Reads a file of at most `max_bytes` bytes.
    fn read_bounded(path: impl AsRef<Path>, max_bytes: u64) -> Result<Self, ReadError> {
        read_json(path.as_ref(), max_bytes).map(Self::from_file)
    }
}

/// Writes `contents` to `path` atomically: into a temporary file in the same directory, flushed
/// to disk, then renamed over `path`. A failure half way (full disk, killed process) leaves any
/// previous file at `path` untouched.
pub fn write_atomically(path: &Path, contents: &[u8]) -> std::io::Result<()> {
    let temporary = stage(path, contents)?;
    let renamed = std::fs::rename(&temporary, path);
    if renamed.is_err() {
        let _ = std::fs::remove_file(&temporary);
    }
    renamed
}

/// Writes several files as a group: each into a temporary file beside it, flushed to disk, and
/// only when all are written, each renamed over its path. A failure while writing (full disk, a
/// folder where a file should go) leaves every previous file untouched and removes the temporary
/// files; the renames that follow are the only step that can leave the group half replaced.
/// The error names the path that failed.
pub fn write_group_atomically(
    files: &[(std::path::PathBuf, &[u8])],
) -> Result<(), (std::path::PathBuf, std::io::Error)> {
    let mut temporaries: Vec<std::path::PathBuf> = Vec::with_capacity(files.len());
    let cleanup = |temporaries: &[std::path::PathBuf]| {
        for t in temporaries {
            let _ = std::fs::remove_file(t);
        }
    };
    for (path, contents) in files {
        let staged = if path.is_dir() {
            Err(std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "a folder is in the way of this file",
            ))
        } else {
            stage(path, contents)
        };
        match staged {
            Ok(t) => temporaries.push(t),
            Err(e) => {
                cleanup(&temporaries);
                return Err((path.clone(), e));
            }
        }
    }
    for (i, ((path, _), temporary)) in files.iter().zip(&temporaries).enumerate() {
        if let Err(e) = std::fs::rename(temporary, path) {
            cleanup(&temporaries[i..]);
            return Err((path.clone(), e));
        }
    }
    Ok(())
}

/// Writes `contents` into a new temporary file beside `path`, flushed to disk; returns its path.
fn stage(path: &Path, contents: &[u8]) -> std::io::Result<std::path::PathBuf> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file path"))?;
    let mut temporary = dir.join(format!(
        ".{}.tmp-{}",
        file_name.to_string_lossy(),
        std::process::id()
    ));
    let mut attempt = 0;
    let mut file = loop {
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temporary)
        {
            Ok(f) => break f,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && attempt < 100 => {
                attempt += 1;
                temporary = dir.join(format!(
                    ".{}.tmp-{}-{attempt}",
                    file_name.to_string_lossy(),
                    std::process::id()
                ));
            }
            Err(e) => return Err(e),
        }
    };
    let written = file.write_all(contents).and_then(|()| file.sync_all());
    match written {
        Ok(()) => Ok(temporary),
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            Err(e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounded_reads_and_atomic_writes() {
        let dir = std::env::temp_dir().join(format!("calib-core-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.json");
        write_atomically(&path, b"first").unwrap();
        write_atomically(&path, b"second").unwrap();
        assert_eq!(read_text(&path, 100).unwrap().0, "second");
        assert!(matches!(
            read_text(&path, 3),
            Err(ReadError::TooLarge { limit: 3, .. })
        ));
        #[cfg(unix)]
        assert!(matches!(
            read_text(Path::new("/dev/zero"), 1 << 20),
            Err(ReadError::TooLarge { .. })
        ));
        // Writing into a missing directory fails and leaves nothing behind.
        assert!(write_atomically(&dir.join("missing/b.json"), b"x").is_err());
        let leftovers = std::fs::read_dir(&dir).unwrap().count();
        assert_eq!(leftovers, 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_group_is_written_whole_or_not_at_all() {
        let dir = std::env::temp_dir().join(format!("calib-core-group-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("b.json")).unwrap();
        let (a, b) = (dir.join("a.json"), dir.join("b.json"));
        write_atomically(&a, b"old").unwrap();
        // The second path is a folder: nothing is replaced, no temporary file is left.
        let (failed, _) =
            write_group_atomically(&[(a.clone(), b"new"), (b.clone(), b"new")]).unwrap_err();
        assert_eq!(failed, b);
        assert_eq!(std::fs::read(&a).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
        std::fs::remove_dir(&b).unwrap();
        write_group_atomically(&[(a.clone(), b"new"), (b.clone(), b"also")]).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"new");
        assert_eq!(std::fs::read(&b).unwrap(), b"also");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A non-finite number (what some detectors write for a corner they did not find) is a JSON
    /// syntax error: the message quotes the text there and says what to do; any other syntax
    /// error gets the text only.
    #[test]
    fn syntax_errors_quote_the_text_and_name_non_finite_numbers() {
        let err = parse_json::<serde_json::Value>(
            r#"{"image_points": [[1.5, 2.0], [NaN, 3.0]]}"#,
            "v.json",
        )
        .unwrap_err()
        .to_string();
        assert!(err.starts_with("v.json: expected value at line 1"), "{err}");
        assert!(
            err.contains("[NaN, 3.0]") && err.contains("JSON has no NaN"),
            "{err}"
        );
        let err = parse_json::<serde_json::Value>(r#"{"a": [1.5 2.0]}"#, "w.json")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("near \"{\"a\": [1.5 2.0]}\"") && !err.contains("NaN"),
            "{err}"
        );
        // A value of the wrong kind (a negative camera index) is quoted too.
        let err = parse_json::<Vec<usize>>("[3, -1]", "c.json")
            .unwrap_err()
            .to_string();
        assert!(err.contains("near \"[3, -1]\""), "{err}");
    }
}
