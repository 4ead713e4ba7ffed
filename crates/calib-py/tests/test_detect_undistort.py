"""detect_chessboard, imread_gray, board_points and undistort_points."""

import numpy as np
import pytest

import calib
from conftest import DATA, single_arrays

IMAGES = DATA / "sourishg1" / "images"


def test_detection_equals_calib_detect(calib_cli):
    names = ["left1.jpg", "left2.jpg", "right7.jpg"]
    expected = calib_cli("detect", "--board", "9x6", *[IMAGES / n for n in names])
    assert [v["image"] for v in expected["views"]] == names
    for n, view in zip(names, expected["views"]):
        image = calib.imread_gray(IMAGES / n)
        assert image.dtype == np.uint8 and image.shape == (360, 640)
        corners = calib.detect_chessboard(image, (9, 6), dtype=np.float64)
        assert corners.shape == (54, 1, 2) and corners.dtype == np.float64
        assert np.array_equal(corners[:, 0, :], np.array(view["image_points"]))
        as_f32 = calib.detect_chessboard(image, (9, 6))
        assert as_f32.dtype == np.float32 and np.array_equal(as_f32, corners.astype(np.float32))
        assert np.array_equal(calib.board_points((9, 6)), np.array(view["object_points"]))


def test_colour_grey_and_strided_images():
    gray = calib.imread_gray(IMAGES / "left3.jpg")
    reference = calib.detect_chessboard(gray, (9, 6))
    # Grey replicated into BGR (and BGRA) converts back to the same grey exactly.
    bgr = np.repeat(gray[:, :, None], 3, axis=2)
    assert np.array_equal(calib.detect_chessboard(bgr, (9, 6)), reference)
    bgra = np.concatenate([bgr, np.full_like(gray[:, :, None], 255)], axis=2)
    assert np.array_equal(calib.detect_chessboard(bgra, (9, 6)), reference)
    assert np.array_equal(calib.detect_chessboard(gray[:, :, None], (9, 6)), reference)
    # A non-contiguous view of a wider buffer.
    wide = np.zeros((360, 1280), np.uint8)
    wide[:, ::2] = gray
    assert np.array_equal(calib.detect_chessboard(wide[:, ::2], (9, 6)), reference)


def test_colour_views_with_any_strides():
    # Colour views that are not C-contiguous were refused ("IncompatibleLayout"): a crop, RGB
    # turned to BGR by a reversed axis, the BGR channels of a BGRA image.
    gray = calib.imread_gray(IMAGES / "left3.jpg")
    reference = calib.detect_chessboard(gray, (9, 6))
    bgr = np.repeat(gray[:, :, None], 3, axis=2)
    padded = np.zeros((370, 650, 3), np.uint8)
    padded[10:, 10:] = bgr
    assert np.array_equal(calib.detect_chessboard(padded[10:, 10:], (9, 6)), reference)
    rgb = np.ascontiguousarray(bgr[..., ::-1])
    assert np.array_equal(calib.detect_chessboard(rgb[..., ::-1], (9, 6)), reference)
    bgra = np.concatenate([bgr, np.full_like(gray[:, :, None], 7)], axis=2)
    assert np.array_equal(calib.detect_chessboard(bgra[..., :3], (9, 6)), reference)
    assert np.array_equal(calib.detect_chessboard(bgr[::-1, ::-1][::-1, ::-1], (9, 6)), reference)
    # A real colour conversion through a strided view equals the contiguous copy's.
    rng = np.random.default_rng(3)
    colour = np.clip(bgr.astype(int) + rng.integers(-20, 21, bgr.shape), 0, 255).astype(np.uint8)
    crop = np.zeros((370, 650, 4), np.uint8)
    crop[10:, 10:, :3] = colour
    view = crop[10:, 10:, :3]
    assert not view.flags.c_contiguous
    a = calib.detect_chessboard(view, (9, 6))
    b = calib.detect_chessboard(np.ascontiguousarray(view), (9, 6))
    assert a is not None and np.array_equal(a, b)


def test_no_board_gives_none_or_the_reason():
    blank = np.full((200, 300), 128, np.uint8)
    assert calib.detect_chessboard(blank, (9, 6)) is None
    with pytest.raises(calib.CalibrationError, match="no board found"):
        calib.detect_chessboard(blank, (9, 6), raise_on_failure=True)
    gray = calib.imread_gray(IMAGES / "left3.jpg")
    assert calib.detect_chessboard(gray, (8, 6)) is None


def test_detection_argument_errors():
    gray = calib.imread_gray(IMAGES / "left3.jpg")
    with pytest.raises(TypeError, match="image: expected a uint8 array"):
        calib.detect_chessboard(gray.astype(np.float32), (9, 6))
    with pytest.raises(ValueError, match="image: expected shape"):
        calib.detect_chessboard(np.zeros((4, 5, 6, 7), np.uint8), (9, 6))
    with pytest.raises(ValueError, match="image: expected shape"):
        calib.detect_chessboard(np.zeros((40, 50, 2), np.uint8), (9, 6))
    with pytest.raises(TypeError, match="pattern_size"):
        calib.detect_chessboard(gray, "9x6")
    with pytest.raises(ValueError, match=r"pattern_size \(2, 6\): invalid board"):
        calib.detect_chessboard(gray, (2, 6))
    with pytest.raises(TypeError, match="dtype"):
        calib.detect_chessboard(gray, (9, 6), dtype=np.int32)
    with pytest.raises(TypeError, match="^dtype: "):
        calib.detect_chessboard(gray, (9, 6), dtype="no-such-dtype")
    with pytest.raises(TypeError, match=r"^pattern_size: .*got \(9\.0, 6\.0\)"):
        calib.detect_chessboard(gray, (9.0, 6.0))
    with pytest.raises(TypeError, match="^pattern_size: "):
        calib.detect_chessboard(gray, (9, 6, 1))
    with pytest.raises(OSError, match="nope.png"):
        calib.imread_gray(DATA / "nope.png")
    with pytest.raises(calib.CalibrationError, match="unsupported image format"):
        calib.imread_gray(DATA / "README.md")
    assert calib.detect_chessboard(np.zeros((5, 5), np.uint8), (9, 6)) is None


def test_board_points():
    p = calib.board_points((9, 6), 24.23)
    assert p.shape == (54, 3) and p.dtype == np.float64
    assert p[10].tolist() == [24.23, 24.23, 0.0]
    assert calib.board_points((9, 6), dtype=np.float32).dtype == np.float32


def distort_brown(n, k):
    """OpenCV's formula for k1 k2 p1 p2 (written independently of the Rust code)."""
    x, y = n[:, 0], n[:, 1]
    r2 = x * x + y * y
    radial = 1 + k[0] * r2 + k[1] * r2 * r2
    xd = x * radial + 2 * k[2] * x * y + k[3] * (r2 + 2 * x * x)
    yd = y * radial + k[2] * (r2 + 2 * y * y) + 2 * k[3] * x * y
    return np.stack([xd, yd], axis=1)


def test_undistort_points_inverts_the_model():
    K = np.array([[500.0, 0, 320], [0, 505.0, 180], [0, 0, 1]])
    dist = np.array([-0.3, 0.1, 0.001, -0.002])
    rng = np.random.default_rng(1)
    n = rng.uniform(-0.5, 0.5, size=(100, 2))
    d = distort_brown(n, dist)
    pixels = d * [K[0, 0], K[1, 1]] + [K[0, 2], K[1, 2]]
    out = calib.undistort_points(pixels.reshape(-1, 1, 2), K, dist)
    assert out.shape == (100, 1, 2)
    assert np.abs(out[:, 0, :] - n).max() < 1e-12
    flat = calib.undistort_points(pixels.astype(np.float32), K, dist.reshape(1, 4))
    assert flat.shape == (100, 2) and np.abs(flat - n).max() < 1e-5
    # P maps back to pixels of an ideal camera; R rotates the rays first.
    back = calib.undistort_points(pixels, K, dist, P=K)
    assert np.abs(back - (n * [K[0, 0], K[1, 1]] + [K[0, 2], K[1, 2]])).max() < 1e-9
    same = calib.undistort_points(pixels, K, dist, R=np.eye(3), P=np.hstack([K, np.zeros((3, 1))]))
    assert np.abs(same - back).max() < 1e-12


def test_undistort_points_of_a_calibration_and_errors():
    obj, img, size = single_arrays("sourishg1/left.json")
    for model in ["brown-conrady5", "rational8", "kannala-brandt4"]:
        r = calib.calibrate_camera(obj, img, size, model=model)
        out = calib.undistort_points(img[0], r.K, r.dist, model=model)
        assert out.shape == (54, 2) and np.isfinite(out).all()
    with pytest.raises(ValueError, match="dist: 6 coefficients match no pinhole model"):
        calib.undistort_points(img[0], np.eye(3), np.zeros(6))
    with pytest.raises(ValueError, match="points: expected an array of shape"):
        calib.undistort_points(img[0][:, :1], np.eye(3), np.zeros(4))
    with pytest.raises(ValueError, match="P: expected a 3x3 or 3x4"):
        calib.undistort_points(img[0], np.eye(3), np.zeros(4), P=np.eye(4))
    # Pixels the model cannot invert give NaN, the others their value.
    out = calib.undistort_points(np.array([[np.nan, 1.0], [2.0, 3.0]]), np.eye(3), np.zeros(4))
    assert np.isnan(out[0]).all() and out[1].tolist() == [2.0, 3.0]


def test_models_table():
    assert calib.MODELS["brown-conrady4"] == ["k1", "k2", "p1", "p2"]
    assert set(calib.MODELS) == {"brown-conrady4", "brown-conrady5", "rational8", "thin-prism12", "kannala-brandt4"}


def test_pattern_size_as_cv2_accepts_it():
    # cv2.findChessboardCorners takes patternSize as a tuple, a list or an array of two ints.
    gray = calib.imread_gray(IMAGES / "left3.jpg")
    expected = calib.detect_chessboard(gray, (9, 6))
    assert expected is not None
    for size in ([9, 6], np.array([9, 6]), (np.int64(9), np.int32(6)), np.array([9, 6], np.uint8)):
        assert np.array_equal(calib.detect_chessboard(gray, size), expected), repr(size)
        assert np.array_equal(calib.board_points(size, 2.0), calib.board_points((9, 6), 2.0))
