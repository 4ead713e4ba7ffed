"""project_points against cv2.projectPoints and cv2.fisheye.projectPoints (skipped without
opencv-python), on cameras calibrated from the bundled data, and its argument errors."""

import numpy as np
import pytest

import calib
from conftest import single_arrays

PINHOLE = ["brown-conrady4", "brown-conrady5", "rational8", "thin-prism12"]


@pytest.fixture(scope="module")
def data():
    return single_arrays("sourishg1/left.json")


@pytest.fixture(scope="module")
def cameras(data):
    obj, img, size = data
    return {m: calib.calibrate_camera(obj, img, size, model=m) for m in PINHOLE + ["kannala-brandt4"]}


def _check_shapes(obj, rvec, tvec, K, dist, model, expected):
    for shaped in (obj, obj.reshape(-1, 1, 3), obj.reshape(1, -1, 3)):
        got = calib.project_points(shaped, rvec, tvec, K, dist, model)
        assert got.shape == (len(obj), 2) and got.dtype == np.float64
        np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("model", PINHOLE)
def test_pinhole_models_equal_cv2_project_points(data, cameras, model):
    cv2 = pytest.importorskip("cv2")
    obj, _, _ = data
    _, K, dist, rvecs, tvecs = cameras[model]
    assert dist.size == {"brown-conrady4": 4, "brown-conrady5": 5, "rational8": 8, "thin-prism12": 12}[model]
    for v in (0, len(obj) // 2, len(obj) - 1):
        expected = cv2.projectPoints(obj[v], rvecs[v], tvecs[v], K, dist)[0][:, 0, :]
        # model=None infers the model from the count; naming it gives the same pixels.
        _check_shapes(obj[v], rvecs[v], tvecs[v], K, dist, None, expected)
        _check_shapes(obj[v], rvecs[v], tvecs[v], K, dist, model, expected)


def test_fisheye_equals_cv2_fisheye_project_points(data, cameras):
    cv2 = pytest.importorskip("cv2")
    obj, _, _ = data
    _, K, dist, rvecs, tvecs = cameras["kannala-brandt4"]
    for v in (0, len(obj) // 2, len(obj) - 1):
        expected = cv2.fisheye.projectPoints(obj[v].reshape(1, -1, 3), rvecs[v], tvecs[v], K, dist)[0][0]
        _check_shapes(obj[v], rvecs[v], tvecs[v], K, dist, "kannala-brandt4", expected)


def test_reprojection_matches_the_calibration_and_dist_none(data, cameras):
    obj, img, _ = data
    rms, K, dist, rvecs, tvecs = cameras["brown-conrady5"]
    residuals = np.concatenate(
        [calib.project_points(o, r, t, K, dist) - i for o, i, r, t in zip(obj, img, rvecs, tvecs)]
    )
    assert np.sqrt(np.mean(np.sum(residuals**2, axis=1))) == pytest.approx(rms, rel=1e-9)
    # No coefficients: plain pinhole, pixel = K (x/z, y/z) with the origin at the first pixel's centre.
    R = np.eye(3)
    t = np.array([0.1, -0.2, 2.0])
    p = np.array([[0.3, 0.4, 1.0], [0.0, 0.0, 0.0]])
    c = p + t
    want = np.stack([K[0, 0] * c[:, 0] / c[:, 2] + K[0, 2], K[1, 1] * c[:, 1] / c[:, 2] + K[1, 2]], axis=1)
    for d in (None, [], np.zeros(5)):
        np.testing.assert_allclose(calib.project_points(p, np.zeros(3), t, K, d), want, rtol=0, atol=1e-9)
    # A rotation matrix is accepted for rvec, as by the package's other functions.
    np.testing.assert_allclose(calib.project_points(p, R, t, K), want, rtol=0, atol=1e-9)


def test_unprojectable_points_name_their_index():
    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    pts = np.array([[0.0, 0, 1], [0.1, 0, 1], [0.0, 0, -1]])
    with pytest.raises(ValueError, match=r"^object_points\[2\]: .*brown-conrady4.*not in front of the camera"):
        calib.project_points(pts, np.zeros(3), np.zeros(3), K, np.zeros(4))
    # On the optical axis behind a fisheye camera: no direction.
    with pytest.raises(ValueError, match=r"^object_points\[2\]: .*kannala-brandt4"):
        calib.project_points(pts, np.zeros(3), np.zeros(3), K, np.zeros(4), "kannala-brandt4")
    # rational8 with k4 = -1: the denominator 1 + k4 r^2 vanishes at r = 1 (a pole).
    pole = np.array([[0.0, 0, 1], [1.0, 0, 1]])
    with pytest.raises(ValueError, match=r"^object_points\[1\]: .*rational8.*pole"):
        calib.project_points(pole, np.zeros(3), np.zeros(3), K, [0, 0, 0, 0, 0, -1.0, 0, 0])


def test_bad_arguments_are_named():
    K = np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])
    pts = np.array([[0.0, 0, 1], [0.1, 0.2, 1]])
    r = t = np.zeros(3)
    cases = [
        ((pts[:, :2], r, t, K), {}, r"^object_points: expected an array of shape \(N, 3\)"),
        ((pts.reshape(1, 2, 1, 3), r, t, K), {}, r"^object_points: "),
        # The values as Python prints them, not as quoted strings.
        ((np.array([[0.0, 0, 1], [np.nan, 0, 1]]), r, t, K), {},
         r"^object_points\[1\]: the values must be finite, got \[nan, 0\.0, 1\.0\]$"),
        ((pts, np.zeros(4), t, K), {}, r"^rvec"),
        ((pts, [0, np.inf, 0], t, K), {}, r"^rvec: the values must be finite"),
        ((pts, np.eye(3) * 2, t, K), {}, r"^rvec: not a rotation matrix"),
        ((pts, r, np.zeros(2), K), {}, r"^tvec: expected 3 values"),
        ((pts, r, [0, 0, np.nan], K), {}, r"^tvec: the values must be finite"),
        ((pts, r, t, np.eye(2)), {}, r"^K: expected a 3x3 array"),
        ((pts, r, t, np.diag([-1.0, 500, 1])), {}, r"^K: the focal lengths must be finite and positive"),
        ((pts, r, t, np.array([[500.0, 0, np.nan], [0, 500, 240], [0, 0, 1]])), {}, r"^K: the principal point must be finite"),
        ((pts, r, t, K, np.zeros(6)), {}, r"^dist: 6 coefficients match no pinhole model"),
        ((pts, r, t, K, [0, 0, np.nan, 0]), {}, r"^dist: the values must be finite"),
        ((pts, r, t, K, np.zeros(5)), {"model": "rational8"}, r"^dist: model rational8 has 8 coefficients"),
        ((pts, r, t, K, np.zeros(4)), {"model": "thin-prism12"}, r"^dist: model thin-prism12 has 12"),
        ((pts, r, t, K), {"model": "pinhole-ish"}, r"^model: "),
    ]
    for args, kwargs, message in cases:
        with pytest.raises(ValueError, match=message):
            calib.project_points(*args, **kwargs)
    with pytest.raises(TypeError, match=r"^model: expected a model name"):
        calib.project_points(pts, r, t, K, None, 5)
