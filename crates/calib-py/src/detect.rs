//! `detect_chessboard`, `imread_gray` and `board_points`: `board_detect` on NumPy images.

use crate::calibration_error;
use crate::convert;
use board_detect::{Board, DetectError, DetectOptions, GrayView, detect};
use numpy::{
    PyArray2, PyArray3, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyOSError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use std::io::Read;
use std::path::Path;

/// `(cols, rows)` of inner corners: a tuple, a list or an array of two integers (Python's or
/// NumPy's), as cv2's `patternSize` accepts.
fn pattern(obj: &Bound<'_, PyAny>, square: f64) -> PyResult<Board> {
    let bad = || {
        PyTypeError::new_err(format!(
            "pattern_size: expected (cols, rows) inner corners as two integers, got {}",
            convert::short_repr(obj)
        ))
    };
    if obj.is_instance_of::<pyo3::types::PyString>() {
        return Err(bad());
    }
    let items: Vec<Bound<'_, PyAny>> = obj
        .try_iter()
        .map_err(|_| bad())?
        .collect::<PyResult<_>>()
        .map_err(|_| bad())?;
    let side = |v: &Bound<'_, PyAny>| -> PyResult<i64> {
        v.call_method0("__index__")
            .and_then(|i| i.extract::<i64>())
            .map_err(|_| bad())
    };
    let [cols, rows] = items.as_slice() else {
        return Err(bad());
    };
    let (cols, rows) = (side(cols)?, side(rows)?);
    let side = |v: i64| usize::try_from(v).unwrap_or(0);
    Board::new(side(cols), side(rows), square)
        .map_err(|e| PyValueError::new_err(format!("pattern_size ({cols}, {rows}): {e}")))
}

/// The 8-bit grey pixels of an image array (copied, so that the GIL can be released while the
/// caller's array stays writable): (H, W) or (H, W, 1) grey, (H, W, 3) BGR or (H, W, 4) BGRA
/// as cv2 loads them. Colour is converted with OpenCV's BGR2GRAY weights in its fixed-point form
/// (0.299 R + 0.587 G + 0.114 B, rounded), so the grey image equals `cv2.cvtColor`'s.
fn gray_pixels(image: &Bound<'_, PyAny>) -> PyResult<(Vec<u8>, usize, usize)> {
    let array = convert::as_array(image, "image")?;
    if !array.dtype().is_equiv_to(&numpy::dtype::<u8>(image.py())) {
        return Err(PyTypeError::new_err(format!(
            "image: expected a uint8 array (8-bit grey or BGR), got dtype {}",
            array.dtype()
        )));
    }
    let array = array.cast::<PyArrayDyn<u8>>()?;
    let shape = array.shape().to_vec();
    let readonly = array.readonly();
    let view = readonly.as_array();
    let (h, w, channels) = match shape.as_slice() {
        [h, w] => (*h, *w, 1),
        [h, w, c @ (1 | 3 | 4)] => (*h, *w, *c),
        _ => {
            return Err(PyValueError::new_err(format!(
                "image: expected shape (H, W) grey, (H, W, 3) BGR or (H, W, 4) BGRA, got {:?}",
                shape
            )));
        }
    };
    // Any strides: views such as `img[10:, 10:]`, `rgb[..., ::-1]` or `bgra[..., :3]` are read
    // through their strides (ndarray's iteration is in logical, row-major order).
    let mut gray = Vec::with_capacity(h * w);
    if channels == 1 {
        gray.extend(view.iter().copied());
    } else {
        // `into_dimensionality` only checks the number of axes (3 here), whatever the strides.
        let v = view
            .into_dimensionality::<numpy::ndarray::Ix3>()
            .map_err(|e| PyValueError::new_err(format!("image: {e}")))?;
        for y in 0..h {
            for x in 0..w {
                let (b, g, r) = (
                    v[[y, x, 0]] as u32,
                    v[[y, x, 1]] as u32,
                    v[[y, x, 2]] as u32,
                );
                // OpenCV's cvtColor(BGR2GRAY) for 8 bits: weights 4899, 9617, 1868 over 2^14.
                gray.push(((r * 4899 + g * 9617 + b * 1868 + (1 << 13)) >> 14) as u8);
            }
        }
    }
    Ok((gray, w, h))
}

/// Finds a chessboard's inner corners in an image, like ``cv2.findChessboardCorners`` followed
/// by sub-pixel refinement.
///
/// ``image``: uint8 array, (H, W) grey or (H, W, 3) BGR (as ``cv2.imread`` gives; colour is
/// converted like ``cv2.cvtColor(..., COLOR_BGR2GRAY)``). ``pattern_size``: (cols, rows) inner
/// corners (a 9x6 board has 10x7 squares).
///
/// Returns the corners as an (N, 1, 2) array (float32 like cv2, or ``dtype=numpy.float64``),
/// row-major (index ``r * cols + c``, so they match :func:`board_points`), in OpenCV's pixel
/// convention; or ``None`` when the whole board is not found, or two whole boards are
/// (``raise_on_failure=True`` raises :class:`CalibrationError` with the reason instead). The
/// GIL is released while it runs.
#[pyfunction]
#[pyo3(signature = (image, pattern_size, *, dtype=None, raise_on_failure=false))]
fn detect_chessboard<'py>(
    py: Python<'py>,
    image: &Bound<'py, PyAny>,
    pattern_size: &Bound<'py, PyAny>,
    dtype: Option<&Bound<'py, PyAny>>,
    #[pyo3(from_py_with = crate::args::raise_on_failure)] raise_on_failure: bool,
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let board = pattern(pattern_size, 1.0)?;
    let float64 = match dtype.filter(|d| !d.is_none()) {
        None => false,
        Some(d) => {
            let d = numpy::PyArrayDescr::new(py, d).map_err(|e| {
                PyTypeError::new_err(format!("dtype: expected float32 or float64 ({e})"))
            })?;
            if d.is_equiv_to(&numpy::dtype::<f64>(py)) {
                true
            } else if d.is_equiv_to(&numpy::dtype::<f32>(py)) {
                false
            } else {
                return Err(PyTypeError::new_err(format!(
                    "dtype: expected float32 or float64, got {d}"
                )));
            }
        }
    };
    let (gray, w, h) = gray_pixels(image)?;
    let outcome = py.detach(|| {
        let view = GrayView::packed(&gray, w, h)?;
        detect(&view, &board, &DetectOptions::default())
    });
    let detection = match outcome {
        Ok(d) => d,
        Err(e) if raise_on_failure => return Err(calibration_error(e)),
        Err(DetectError::InvalidImage(m)) => {
            return Err(PyValueError::new_err(format!("image: {m}")));
        }
        Err(_) => return Ok(None),
    };
    let n = detection.corners.len();
    let array = if float64 {
        let flat: Vec<f64> = detection.corners.iter().flatten().copied().collect();
        numpy::PyArray1::from_vec(py, flat)
            .reshape([n, 1, 2])?
            .into_any()
    } else {
        let flat: Vec<f32> = detection
            .corners
            .iter()
            .flatten()
            .map(|&v| v as f32)
            .collect();
        let a: Bound<'py, PyArray3<f32>> =
            numpy::PyArray1::from_vec(py, flat).reshape([n, 1, 2])?;
        a.into_any()
    };
    Ok(Some(array))
}

/// Why `path` cannot be read, asked again of the operating system: `board_detect` keeps only
/// the message of the error. A folder is read (which fails, as `open()` does on it); a device
/// or pipe is not opened again (that could block, or take data).
fn read_error(path: &Path) -> Option<std::io::Error> {
    let metadata = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) => return Some(e),
    };
    if metadata.is_dir() {
        std::fs::File::open(path)
            .and_then(|mut f| f.read(&mut [0u8; 1]))
            .err()
    } else if metadata.is_file() {
        std::fs::File::open(path).err()
    } else {
        None
    }
}

/// Reads a JPEG or PNG file as an 8-bit grey image (H, W), the way the ``calib`` command reads
/// photographs (so detections equal ``calib detect``'s). A file that cannot be read raises the
/// ``OSError`` subclass ``open()`` raises (``FileNotFoundError``, ``PermissionError``,
/// ``IsADirectoryError``), with ``filename``; an unsupported or corrupt one
/// :class:`CalibrationError`.
#[pyfunction]
fn imread_gray<'py>(
    py: Python<'py>,
    #[pyo3(from_py_with = crate::args::path)] path: std::path::PathBuf,
) -> PyResult<Bound<'py, PyArray2<u8>>> {
    let image = py
        .detach(|| board_detect::load_gray(&path, &DetectOptions::default()))
        .map_err(|e| match e {
            DetectError::Io { .. } => read_error(&path)
                .and_then(|io| crate::os_error(py, &io, &path.to_string_lossy()))
                .unwrap_or_else(|| PyOSError::new_err(e.to_string())),
            other => calibration_error(other),
        })?;
    let (w, h) = (image.width() as usize, image.height() as usize);
    numpy::PyArray1::from_vec(py, image.into_raw()).reshape([h, w])
}

/// The board points of a chessboard with ``pattern_size`` = (cols, rows) inner corners and
/// squares of side ``square``: ``(c * square, r * square, 0)`` row-major, shape (N, 3), in the
/// order :func:`detect_chessboard` returns the corners. float64 (``dtype=numpy.float32`` for
/// cv2, whose calibrateCamera wants float32 object points).
#[pyfunction]
#[pyo3(signature = (pattern_size, square=1.0, *, dtype=None))]
fn board_points<'py>(
    py: Python<'py>,
    pattern_size: &Bound<'py, PyAny>,
    #[pyo3(from_py_with = crate::args::square)] square: f64,
    dtype: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let board = pattern(pattern_size, square)?;
    let points = board.object_points();
    let flat: Vec<f64> = points.iter().flatten().copied().collect();
    let array = numpy::PyArray1::from_vec(py, flat).reshape([points.len(), 3])?;
    match dtype.filter(|d| !d.is_none()) {
        None => Ok(array.into_any()),
        Some(d) => array.call_method1("astype", (d,)),
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(detect_chessboard, m)?)?;
    m.add_function(wrap_pyfunction!(imread_gray, m)?)?;
    m.add_function(wrap_pyfunction!(board_points, m)?)?;
    Ok(())
}
