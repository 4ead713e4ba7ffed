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
        "{path} is larger than {limit} bytes; raise the limit (--max-input-mb) if it really is an input file"
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
    if bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]) {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            "UTF-16 text (as some Windows tools save it); save it as UTF-8",
        )));
    }
    let mut text = String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text: {e}"),
        ))
    })?;
    // A UTF-8 byte order mark (Notepad, PowerShell's Out-File) is not part of the text.
    if text.starts_with('\u{feff}') {
        text.drain(..'\u{feff}'.len_utf8());
    }
    Ok((text, name))
}

/// Parses JSON text of type `T`; errors name `path` (any label, e.g. `<string>`) with the line
/// and column.
pub fn parse_json<T: serde::de::DeserializeOwned>(text: &str, path: &str) -> Result<T, ReadError> {
    if text.trim().is_empty() {
        return Err(ReadError::Content {
            path: path.to_string(),
            reason: "the file is empty".into(),
        });
    }
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
    if error.is_eof() {
        return ": the file ends before the JSON does (cut short by a copy or a write that did not finish?)".into();
    }
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

/// The kinds of calib's own JSON files, told apart by their top-level keys: to say, when a file
/// of one kind is given where another is read, what the file is and which command reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum JsonKind {
    /// A single camera's observations (`views`), the input of `calib single`.
    SingleObservations,
    /// A stereo rig's observations (`pairs`), the input of `calib stereo`.
    StereoObservations,
    /// A rig's observations (`cameras` and `frames`), the input of `calib rig`.
    RigObservations,
    /// A result of `calib single`.
    SingleResult,
    /// A result of `calib stereo`.
    StereoResult,
    /// A result of `calib rig`.
    RigResult,
}

impl JsonKind {
    /// The kind of a parsed JSON document, if it is one of calib's.
    pub fn of(value: &serde_json::Value) -> Option<JsonKind> {
        let object = value.as_object()?;
        let format = object.get("format").and_then(|f| f.as_str()).unwrap_or("");
        let has = |key: &str| object.contains_key(key);
        Some(if format.starts_with("calib-single-result/") {
            JsonKind::SingleResult
        } else if format.starts_with("calib-stereo-result/") {
            JsonKind::StereoResult
        } else if format.starts_with("calib-rig-result/") {
            JsonKind::RigResult
        } else if has("pairs") {
            JsonKind::StereoObservations
        } else if has("cameras") && has("frames") {
            JsonKind::RigObservations
        } else if has("views") {
            JsonKind::SingleObservations
        } else {
            return None;
        })
    }

    /// What the kind is, in user terms.
    pub fn description(self) -> &'static str {
        match self {
            JsonKind::SingleObservations => {
                "a single camera's observation file (with \"views\"; calib single reads it)"
            }
            JsonKind::StereoObservations => {
                "a stereo observation file (with \"pairs\"; calib stereo reads it)"
            }
            JsonKind::RigObservations => {
                "a rig observation file (with \"cameras\" and \"frames\"; calib rig reads it)"
            }
            JsonKind::SingleResult => "a result of calib single",
            JsonKind::StereoResult => "a result of calib stereo",
            JsonKind::RigResult => "a result of calib rig",
        }
    }

    fn is_result(self) -> bool {
        matches!(
            self,
            JsonKind::SingleResult | JsonKind::StereoResult | JsonKind::RigResult
        )
    }
}

/// For a file that failed to parse as `expected`: when it is another of calib's kinds, or not a
/// JSON object at all, the error that says so (instead of serde's missing field deep inside).
fn wrong_kind(text: &str, path: &str, expected: JsonKind) -> Option<ReadError> {
    let value: serde_json::Value = serde_json::from_str(text).ok()?;
    let content = |reason: String| ReadError::Content {
        path: path.to_string(),
        reason,
    };
    if !value.is_object() {
        let found = match value {
            serde_json::Value::Array(_) => "a list",
            serde_json::Value::Null => "null",
            serde_json::Value::Bool(_) => "true or false",
            serde_json::Value::Number(_) => "a number",
            _ => "a string",
        };
        return Some(content(format!(
            "the file holds {found}, not {} (a JSON object {{ ... }}; see docs/formats.md)",
            expected.description()
        )));
    }
    let found = JsonKind::of(&value).filter(|&k| k != expected)?;
    let hint = if found.is_result() {
        "; a result is not calibrated again: give the observation file it was calibrated from"
    } else {
        ""
    };
    Some(content(format!(
        "this is {}, not {}{hint}",
        found.description(),
        expected.description()
    )))
}

/// An input file format read from JSON: implementors give the serde form of the file and the
/// conversion; reading (bounded in size) and parsing come with the trait.
pub trait JsonFile: Sized {
    /// The serde form of the file.
    type File: serde::de::DeserializeOwned;

    /// The kind of file this is, if one of calib's: a file of another kind is then refused by
    /// naming what it is (a stereo file given to a single-camera reader, a result given where
    /// observations are read).
    const KIND: Option<JsonKind> = None;

    /// Parses JSON text of this format; errors name `path`.
    fn parse(text: &str, path: &str) -> Result<Self, ReadError> {
        match parse_json::<Self::File>(text, path) {
            Ok(file) => Ok(Self::from_file(file)),
            Err(e @ ReadError::Json { .. }) => Err(Self::KIND
                .and_then(|k| wrong_kind(text, path, k))
                .unwrap_or(e)),
            Err(e) => Err(e),
        }
    }

    /// The value a parsed file describes.
    fn from_file(file: Self::File) -> Self;

    /// Parses JSON text (errors name `<string>` and the line and column).
    fn from_json(text: &str) -> Result<Self, ReadError> {
        Self::parse(text, "<string>")
    }

    /// Reads a file of at most [`DEFAULT_MAX_INPUT_BYTES`].
    fn read(path: impl AsRef<Path>) -> Result<Self, ReadError> {
        Self::read_bounded(path, DEFAULT_MAX_INPUT_BYTES)
    }

    /// Reads a file of at most `max_bytes` bytes.
    fn read_bounded(path: impl AsRef<Path>, max_bytes: u64) -> Result<Self, ReadError> {
        let (text, name) = read_text(path.as_ref(), max_bytes)?;
        Self::parse(&text, &name)
    }
}

/// Writes `contents` to `path` atomically: into a temporary file in the same directory, flushed
/// to disk, then renamed over `path`. A failure half way (full disk, killed process) leaves any
/// previous file at `path` untouched. A symbolic link is followed (the file it names is
/// replaced, the link stays); a device or pipe (`/dev/null`, `/dev/stdout`, a FIFO) is written
/// directly, never replaced; a read-only file is refused; a replaced file keeps its permissions.
pub fn write_atomically(path: &Path, contents: &[u8]) -> std::io::Result<()> {
    match target(path)? {
        Target::Direct => write_directly(path, contents),
        Target::Replace(path, permissions) => {
            let temporary = stage(&path, contents, permissions)?;
            let renamed = rename_into_place(&temporary, &path);
            if renamed.is_err() {
                discard(&temporary);
            }
            renamed
        }
    }
}

/// The temporary files of the writes in progress ([`stage`] to [`rename_into_place`]), for
/// [`remove_temporary_files`]; `closing` once they were removed.
struct InFlight {
    paths: Vec<std::path::PathBuf>,
    closing: bool,
}

static IN_FLIGHT: std::sync::Mutex<InFlight> = std::sync::Mutex::new(InFlight {
    paths: Vec::new(),
    closing: false,
});

fn in_flight() -> std::sync::MutexGuard<'static, InFlight> {
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// The error of a write asked for after [`remove_temporary_files`].
fn closing() -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::Interrupted,
        "the program is stopping (interrupted): nothing more is written",
    )
}

/// Removes the temporary files of every write in progress (the `.NAME.tmp-PID` files beside
/// the outputs) and makes every later write fail, so none is left behind: for a program that
/// exits on Ctrl-C (SIGINT) or SIGTERM, called from its signal-handling thread just before it
/// exits. A write either finished (its file replaced whole) or leaves the previous file as it
/// was. Returns how many files were removed. (A process killed outright, SIGKILL or a power
/// cut, cannot do this: its leftover `.NAME.tmp-PID` files are incomplete copies, safe to
/// delete.)
pub fn remove_temporary_files() -> usize {
    let mut in_flight = in_flight();
    in_flight.closing = true;
    let paths = std::mem::take(&mut in_flight.paths);
    paths
        .iter()
        .filter(|p| std::fs::remove_file(p).is_ok())
        .count()
}

/// Renames a staged temporary file over `path`, unless [`remove_temporary_files`] came first
/// (then the temporary file is gone and this fails).
fn rename_into_place(temporary: &Path, path: &Path) -> std::io::Result<()> {
    let mut in_flight = in_flight();
    if in_flight.closing {
        return Err(closing());
    }
    std::fs::rename(temporary, path)?;
    in_flight.paths.retain(|p| p != temporary);
    Ok(())
}

/// Removes a staged temporary file that is not to be renamed.
fn discard(temporary: &Path) {
    let mut in_flight = in_flight();
    let _ = std::fs::remove_file(temporary);
    in_flight.paths.retain(|p| p != temporary);
}

/// How a path is written.
enum Target {
    /// Not a regular file (a device, a pipe): written in place.
    Direct,
    /// A regular file, or none yet: this path (links resolved) is replaced by a temporary file,
    /// which gets the previous file's permissions.
    Replace(std::path::PathBuf, Option<std::fs::Permissions>),
}

/// How `path` is to be written; refuses a folder and a read-only file.
fn target(path: &Path) -> std::io::Result<Target> {
    let error = |kind, message: &str| Err(std::io::Error::new(kind, message.to_string()));
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => error(
            std::io::ErrorKind::IsADirectory,
            "that is a folder; give a file name",
        ),
        Ok(m) if !m.is_file() => Ok(Target::Direct),
        Ok(m) if m.permissions().readonly() => error(
            std::io::ErrorKind::PermissionDenied,
            "the file is read-only (it was protected from changes); make it writable or choose another path",
        ),
        Ok(m) => Ok(Target::Replace(
            std::fs::canonicalize(path)?,
            Some(m.permissions()),
        )),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            Ok(Target::Replace(dangling_link_target(path), None))
        }
        Err(e) => Err(e),
    }
}

/// The file a path names once its symbolic links are followed, when it does not exist yet (a
/// link to a file to create); the path itself when it is no link.
fn dangling_link_target(path: &Path) -> std::path::PathBuf {
    let mut path = path.to_path_buf();
    for _ in 0..40 {
        let Ok(link) = std::fs::read_link(&path) else {
            break;
        };
        path = match path.parent() {
            Some(dir) if link.is_relative() => dir.join(link),
            _ => link,
        };
    }
    path
}

/// Writes into an existing device or pipe.
fn write_directly(path: &Path, contents: &[u8]) -> std::io::Result<()> {
    let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
    file.write_all(contents)?;
    file.flush()
}

/// Writes several files as a group: each into a temporary file beside it, flushed to disk, and
/// only when all are written, each renamed over its path. A failure while writing (full disk, a
/// folder where a file should go) leaves every previous file untouched and removes the temporary
/// files; the renames that follow are the only step that can leave the group half replaced.
/// Paths are treated as by [`write_atomically`] (links followed, devices written in place, after
/// the renames). The error names the path that failed.
pub fn write_group_atomically(
    files: &[(std::path::PathBuf, &[u8])],
) -> Result<(), (std::path::PathBuf, std::io::Error)> {
    // (temporary file, the file it replaces, the path as given)
    let mut temporaries: Vec<(std::path::PathBuf, std::path::PathBuf, &std::path::PathBuf)> =
        Vec::with_capacity(files.len());
    let mut direct: Vec<(&std::path::PathBuf, &[u8])> = Vec::new();
    let cleanup =
        |temporaries: &[(std::path::PathBuf, std::path::PathBuf, &std::path::PathBuf)]| {
            for (t, _, _) in temporaries {
                discard(t);
            }
        };
    for (path, contents) in files {
        let staged = match target(path) {
            Ok(Target::Direct) => {
                direct.push((path, contents));
                continue;
            }
            Ok(Target::Replace(real, permissions)) => {
                stage(&real, contents, permissions).map(|t| (t, real, path))
            }
            Err(e) => Err(e),
        };
        match staged {
            Ok(t) => temporaries.push(t),
            Err(e) => {
                cleanup(&temporaries);
                return Err((path.clone(), e));
            }
        }
    }
    for (i, (temporary, real, path)) in temporaries.iter().enumerate() {
        if let Err(e) = rename_into_place(temporary, real) {
            cleanup(&temporaries[i..]);
            return Err(((*path).clone(), e));
        }
    }
    for (path, contents) in direct {
        write_directly(path, contents).map_err(|e| (path.clone(), e))?;
    }
    Ok(())
}

/// Writes `contents` into a new temporary file beside `path` (with `permissions`, if given),
/// flushed to disk; returns its path, registered for [`remove_temporary_files`] from its
/// creation until it is renamed ([`rename_into_place`]) or removed ([`discard`]).
fn stage(
    path: &Path,
    contents: &[u8],
    permissions: Option<std::fs::Permissions>,
) -> std::io::Result<std::path::PathBuf> {
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
    // Created and registered under the lock: an interruption removes the file or comes before it.
    let mut registry = in_flight();
    if registry.closing {
        return Err(closing());
    }
    let mut file = loop {
        match std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temporary)
        {
            Ok(f) => {
                registry.paths.push(temporary.clone());
                break f;
            }
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
    // The contents are written without the lock: an interruption need not wait for them.
    drop(registry);
    let written = file
        .write_all(contents)
        .and_then(|()| match permissions {
            Some(p) => file.set_permissions(p),
            None => Ok(()),
        })
        .and_then(|()| file.sync_all());
    match written {
        Ok(()) => Ok(temporary),
        Err(e) => {
            discard(&temporary);
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

    /// Files as editors and other tools save them: a UTF-8 byte order mark is skipped; UTF-16,
    /// an empty file and a cut-short file are named as such.
    #[test]
    fn byte_order_marks_empty_and_truncated_files() {
        let dir = std::env::temp_dir().join(format!("calib-core-bom-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.json");
        std::fs::write(&path, "\u{feff}{\"a\": 1}").unwrap();
        let value: serde_json::Value = read_json(&path, 100).unwrap();
        assert_eq!(value["a"], 1);
        std::fs::write(&path, b"\xff\xfe{\x00}\x00").unwrap();
        let err = read_text(&path, 100).unwrap_err().to_string();
        assert!(
            err.contains("UTF-16") && err.contains("save it as UTF-8"),
            "{err}"
        );
        let err = parse_json::<serde_json::Value>(" \n", "e.json")
            .unwrap_err()
            .to_string();
        assert_eq!(err, "e.json: the file is empty");
        let err = parse_json::<serde_json::Value>("{\"views\": [[1.0, 2", "t.json")
            .unwrap_err()
            .to_string();
        assert!(err.contains("the file ends before the JSON does"), "{err}");
        let err = read_text(&dir.join("missing.json"), 1 << 20)
            .map(|_| ())
            .unwrap_err();
        assert!(matches!(err, ReadError::Io { .. }));
        let err = ReadError::TooLarge {
            path: "x".into(),
            limit: 1,
        };
        assert!(err.to_string().contains("--max-input-mb"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A file of another of calib's kinds (a stereo file where a single camera's observations
    /// are read, a result where observations are read) or no JSON object at all is named as
    /// such, not by serde's missing field deep inside.
    #[test]
    fn files_of_another_kind_are_named() {
        #[derive(Debug)]
        struct Views;
        #[derive(serde::Deserialize)]
        #[allow(dead_code)]
        struct ViewsFile {
            views: Vec<serde_json::Value>,
        }
        impl JsonFile for Views {
            type File = ViewsFile;
            const KIND: Option<JsonKind> = Some(JsonKind::SingleObservations);
            fn from_file(_: ViewsFile) -> Self {
                Views
            }
        }
        let err = Views::from_json(r#"{"image_size": [4, 4], "pairs": []}"#)
            .unwrap_err()
            .to_string();
        assert_eq!(
            err,
            "<string>: this is a stereo observation file (with \"pairs\"; calib stereo reads it), not a single camera's observation file (with \"views\"; calib single reads it)"
        );
        let err = Views::from_json(r#"{"format": "calib-single-result/2", "views": [1]}"#);
        assert!(
            err.is_ok(),
            "a parsable file is read whatever it looks like"
        );
        let err = Views::from_json(r#"{"format": "calib-rig-result/1", "cameras": []}"#)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("this is a result of calib rig")
                && err.contains("give the observation file it was calibrated from"),
            "{err}"
        );
        let err = Views::from_json("[]").unwrap_err().to_string();
        assert!(
            err.contains("the file holds a list, not a single camera's"),
            "{err}"
        );
        // A file of the right kind with an error inside keeps serde's message.
        let err = Views::from_json(r#"{"views": 3}"#).unwrap_err().to_string();
        assert!(err.contains("invalid type"), "{err}");
    }

    /// Output paths as users give them: a link is followed (the link stays), a pipe or device is
    /// written in place (never replaced by a file), a read-only file is refused, a replaced
    /// file keeps its permissions, a folder is named as such.
    #[cfg(unix)]
    #[test]
    fn links_pipes_read_only_files_and_folders() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("calib-core-paths-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (real, link) = (dir.join("real.json"), dir.join("link.json"));
        std::fs::write(&real, "old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o600)).unwrap();
        std::os::unix::fs::symlink("real.json", &link).unwrap();
        write_atomically(&link, b"new").unwrap();
        assert!(
            std::fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        let mode = std::fs::metadata(&real).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600);
        // A link to a file not written yet.
        let dangling = dir.join("dangling.json");
        std::os::unix::fs::symlink("later.json", &dangling).unwrap();
        write_atomically(&dangling, b"later").unwrap();
        assert_eq!(std::fs::read(dir.join("later.json")).unwrap(), b"later");
        // A read-only file.
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o444)).unwrap();
        let err = write_atomically(&real, b"newer").unwrap_err().to_string();
        assert!(err.contains("read-only"), "{err}");
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        // A folder.
        let err = write_atomically(&dir, b"x").unwrap_err().to_string();
        assert!(err.contains("folder"), "{err}");
        // A named pipe, as `-o >(jq .)` or `mkfifo` give: written through, still a pipe.
        let fifo = dir.join("fifo");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let reader = {
                let fifo = fifo.clone();
                std::thread::spawn(move || std::fs::read(fifo).unwrap())
            };
            write_atomically(&fifo, b"through").unwrap();
            assert_eq!(reader.join().unwrap(), b"through");
            let kind = std::fs::symlink_metadata(&fifo).unwrap().file_type();
            assert!(!kind.is_file(), "the pipe was replaced by a file");
            write_group_atomically(&[(dir.join("g.json"), b"g")]).unwrap();
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
