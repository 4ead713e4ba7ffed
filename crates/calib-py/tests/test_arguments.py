"""Arguments as cv2 users pass them, and the messages when they are wrong: OpenCV's five
coefficients without model=, cv2's positional order, the argument named in every message."""

import numpy as np
import pytest

import calib
from conftest import single_arrays
from test_stereo_rig import stereo_arrays


@pytest.fixture(scope="module")
def left():
    return single_arrays("sourishg1/left.json")


def test_coefficient_count_decides_the_model_without_model(left):
    obj, img, size = left
    five = calib.calibrate_camera(obj, img, size, model="brown-conrady5")
    # cv2 returns (1, 5) coefficients, even with CALIB_FIX_K3: given back without model=.
    again = calib.calibrate_camera(obj, img, size, K=five.K, dist=five.dist)
    assert again.model == "brown-conrady5" and again.dist.shape == (1, 5)
    assert again.rms == pytest.approx(five.rms, rel=1e-9)
    zeros = calib.calibrate_camera(obj, img, size, dist=np.zeros((1, 5)), fix="k3")
    assert zeros.model == "brown-conrady5" and zeros.dist[0, 4] == 0.0
    assert calib.calibrate_camera(obj, img, size, dist=np.zeros(8)).model == "rational8"
    assert calib.calibrate_camera(obj, img, size, dist=np.zeros(4)).model == "brown-conrady4"
    with pytest.raises(ValueError, match=r"^dist: 14 coefficients match no pinhole model .*give model="):
        calib.calibrate_camera(obj, img, size, dist=np.zeros(14))
    # A named model whose count disagrees: the message names the model the count means.
    with pytest.raises(ValueError, match=r"^dist: model rational8 has 8 coefficients .* got 5; 5 coefficients are brown-conrady5's .*model='brown-conrady5'"):
        calib.calibrate_camera(obj, img, size, model="rational8", dist=np.zeros(5))


def test_stereo_coefficients_decide_each_model_and_cv2_order_is_named():
    obj, l, r, size = stereo_arrays("sourishg1/stereo.json")
    obj, l, r = obj[:12], l[:12], r[:12]
    five = calib.stereo_calibrate(obj, l, r, size, model="brown-conrady5")
    again = calib.stereo_calibrate(obj, l, r, size, five.K1, five.D1, five.K2, five.D2)
    assert again.models == ("brown-conrady5", "brown-conrady5")
    mixed = calib.stereo_calibrate(obj, l, r, size, D1=np.zeros(5), D2=np.zeros(8))
    assert mixed.models == ("brown-conrady5", "rational8")
    with pytest.raises(ValueError, match=r"^D2: model2 brown-conrady4 has 4 .* got 5; 5 coefficients are brown-conrady5's"):
        calib.stereo_calibrate(obj, l, r, size, D2=np.zeros(5), model2="brown-conrady4")
    # cv2.stereoCalibrate(obj, img1, img2, K1, D1, K2, D2, image_size): K1 lands on image_size.
    with pytest.raises(ValueError, match=r"^image_size: .*cv2\.stereoCalibrate's order.*stereo_calibrate\(object_points, image_points1, image_points2, image_size, K1=None"):
        calib.stereo_calibrate(obj, l, r, five.K1, five.D1, five.K2, five.D2, size)


def test_rig_known_coefficients_decide_the_model():
    obj, l, r, size = stereo_arrays("sourishg1/stereo.json")
    obj, l, r = obj[:12], l[:12], r[:12]
    single = calib.calibrate_camera(obj, l, size, model="brown-conrady5")
    rig = calib.calibrate_rig([size, size], obj, [[a, b] for a, b in zip(l, r)],
                              known={0: (single.K, single.dist)})
    assert rig.models[0] == "brown-conrady5" and rig.models[1] == "brown-conrady4"
    assert np.array_equal(rig.Ks[0], single.K)


def test_bad_guesses_name_the_argument(left):
    obj, img, size = left
    K = np.array([[500.0, 0, 320], [0, 500, 180], [0, 0, 1]])
    for bad in [np.nan, -500.0, 0.0]:
        Kb = K.copy()
        Kb[0, 0] = bad
        with pytest.raises(ValueError, match=r"^K: the focal lengths must be finite and positive, got fx = "):
            calib.calibrate_camera(obj, img, size, K=Kb)
    Kb = K.copy()
    Kb[1, 2] = np.inf
    with pytest.raises(ValueError, match=r"^K: the principal point must be finite"):
        calib.calibrate_camera(obj, img, size, K=Kb)
    with pytest.raises(ValueError, match=r"^dist: the values must be finite, got nan at index 0"):
        calib.calibrate_camera(obj, img, size, dist=[np.nan, 0, 0, 0])
    with pytest.raises(ValueError, match=r"^K2: the focal lengths"):
        o, l, r, s = stereo_arrays("sourishg1/stereo.json")
        calib.stereo_calibrate(o, l, r, s, K2=K * [[-1, 1, 1], [1, 1, 1], [1, 1, 1]])


def test_invalid_camera_matrix_is_named_as_k_not_dist():
    pts = np.array([[320.0, 180.0]])
    K = np.array([[-500.0, 0, 320], [0, 500, 180], [0, 0, 1]])
    with pytest.raises(ValueError, match=r"^K: the focal lengths"):
        calib.undistort_points(pts, K, np.zeros(4))
    good = np.abs(K)
    R, T = np.eye(3), np.array([-0.1, 0, 0])
    with pytest.raises(ValueError, match=r"^K1: the focal lengths"):
        calib.stereo_rectify(K, np.zeros(4), good, np.zeros(4), (640, 360), R, T)
    with pytest.raises(ValueError, match=r"^calibration\['K'\]: the focal lengths"):
        calib.write_calibration("/nonexistent/x.yaml", {"K": K, "dist": np.zeros(4), "image_size": (640, 360)})
    with pytest.raises(ValueError, match=r"^calibration\['K2'\]: the focal lengths"):
        calib.write_calibration("/nonexistent/x.yaml", {"K1": good, "D1": np.zeros(4), "K2": K, "D2": None,
                                                        "R": R, "T": T, "image_size": (640, 360)})


@pytest.mark.parametrize("kw, name", [
    (dict(model=5), "model"), (dict(max_iterations="10"), "max_iterations"),
    (dict(reject_outliers=1), "reject_outliers"), (dict(loss=3), "loss"),
    (dict(threads=2.0), "threads"), (dict(compute_std="no"), "compute_std"),
    (dict(loss_scale="1"), "loss_scale"),
])
def test_option_type_errors_name_the_argument_in_the_message(left, kw, name):
    obj, img, size = left
    with pytest.raises(TypeError, match=f"^{name}: expected "):
        calib.calibrate_camera(obj, img, size, **kw)


def test_option_type_errors_of_the_other_functions():
    obj, l, r, size = stereo_arrays("sourishg1/stereo.json")
    with pytest.raises(TypeError, match="^fix_intrinsics: expected True or False, got str"):
        calib.stereo_calibrate(obj, l, r, size, fix_intrinsics="yes")
    with pytest.raises(TypeError, match="^rig_init: expected "):
        calib.stereo_calibrate(obj, l, r, size, rig_init=1)
    with pytest.raises(TypeError, match="^min_views: expected an int"):
        calib.calibrate_rig([size, size], obj, [[a, b] for a, b in zip(l, r)], min_views="3")
    with pytest.raises(TypeError, match="^raise_on_failure: expected True or False"):
        calib.detect_chessboard(np.zeros((10, 10), np.uint8), (9, 6), raise_on_failure="no")
    with pytest.raises(TypeError, match="^format: expected "):
        calib.write_calibration("x.yaml", {}, 3)
    with pytest.raises(TypeError, match="^model: expected "):
        calib.undistort_points(l[0], np.eye(3), np.zeros(4), model=4)


def test_image_size_message_does_not_echo_a_big_argument(left):
    obj, img, size = left
    with pytest.raises(ValueError) as e:
        calib.calibrate_camera(obj, img, np.zeros((100, 100)))
    assert "an array of shape (100, 100)" in str(e.value) and len(str(e.value)) < 200
    with pytest.raises(ValueError) as e:
        calib.calibrate_camera(obj, img, ["x" * 10000])
    assert len(str(e.value)) < 200


def test_undistort_points_dist_none_and_r_checked():
    K = np.array([[500.0, 0, 320], [0, 505.0, 180], [0, 0, 1]])
    pts = np.array([[100.0, 50.0], [400.0, 300.0]])
    ideal = (pts - [320, 180]) / [500, 505]
    # dist=None (or left out) means no distortion, as cv2 and stereo_rectify.
    assert np.allclose(calib.undistort_points(pts, K, None), ideal, atol=1e-15)
    assert np.allclose(calib.undistort_points(pts, K), ideal, atol=1e-15)
    assert np.allclose(calib.undistort_points(pts, K, []), ideal, atol=1e-15)
    # R must be a rotation; a rotation vector is accepted as in stereo_rectify.
    for bad in [np.zeros((3, 3)), 2 * np.eye(3), np.diag([1.0, 1.0, -1.0])]:
        with pytest.raises(ValueError, match="^R: not a rotation matrix"):
            calib.undistort_points(pts, K, None, R=bad)
    with pytest.raises(ValueError, match="^R"):
        calib.undistort_points(pts, K, None, R=np.zeros(2))
    w = np.array([0.01, -0.02, 0.03])
    theta = np.linalg.norm(w)
    k = w / theta
    Kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    Rm = np.eye(3) + np.sin(theta) * Kx + (1 - np.cos(theta)) * Kx @ Kx
    by_vector = calib.undistort_points(pts, K, None, R=w.reshape(3, 1))
    by_matrix = calib.undistort_points(pts, K, None, R=Rm)
    assert np.allclose(by_vector, by_matrix, atol=1e-12)
    assert np.isfinite(by_matrix).all()


def test_names_appear_in_error_messages(left):
    obj, img, size = left
    names = [f"left{i + 1}.jpg" for i in range(len(obj))]
    bad = [x.copy() for x in img]
    bad[3][5, 0] = np.nan
    with pytest.raises(calib.CalibrationError, match=r"^view 3 \('left4\.jpg'\), point 5: non-finite"):
        calib.calibrate_camera(obj, bad, size, names=names)
    with pytest.raises(calib.CalibrationError, match=r"^view 3, point 5: non-finite"):
        calib.calibrate_camera(obj, bad, size)
    # A view that misses the board as a whole (an 8x6 board's points for its first 48
    # corners): named by the engine, once.
    wrong = [x.copy() for x in obj]
    step = np.linalg.norm(obj[3][1] - obj[3][0])
    wrong[3] = np.array([[step * (i % 8), step * (i // 8), 0.0] for i in range(48)])
    short = [x.copy() for x in img]
    short[3] = short[3][:48]
    with pytest.raises(calib.CalibrationError, match=r"^view 3 \(left4\.jpg\): \d+ of 48 points are outliers") as e:
        calib.calibrate_camera(wrong, short, size, names=names, reject_outliers=True)
    assert str(e.value).count("left4") == 1, str(e.value)
    o, l, r, s = stereo_arrays("sourishg1/stereo.json")
    r = [x.copy() for x in r]
    r[4][0, 0] = np.inf
    with pytest.raises(calib.CalibrationError, match=r"^pair 4 \('p4'\), right view"):
        calib.stereo_calibrate(o, l, r, s, names=[f"p{i}" for i in range(len(o))])


def test_one_view_in_cv2_shape_without_the_list_is_named(left):
    # (N, 1, 3) / (N, 1, 2) without the outer list would be N views of one point each (cv2 reads
    # it so and fails in view 0); the message names the argument and says what to do.
    obj, img, size = left
    with pytest.raises(TypeError, match=r"^object_points: .*shape \(54, 1, 3\), which would be 54 views of one point each.*wrap it in a list"):
        calib.calibrate_camera(obj[0].reshape(-1, 1, 3), img[0].reshape(-1, 1, 2), size)
    with pytest.raises(TypeError, match=r"^image_points: .*shape \(54, 1, 2\).*wrap it in a list"):
        calib.calibrate_camera([obj[0]], img[0].reshape(-1, 1, 2), size)
    o, l, r, s = stereo_arrays("sourishg1/stereo.json")
    with pytest.raises(TypeError, match=r"^image_points2: .*wrap it in a list"):
        calib.stereo_calibrate(o[:1], l[:1], r[0].reshape(-1, 1, 2), s)
    # (1, N, D) is one view, and a stack of views (M, N, D) is M views, as before.
    one = calib.calibrate_camera(obj[0].reshape(1, -1, 3), img[0].reshape(1, -1, 2), size)
    assert one.rms == calib.calibrate_camera(obj[:1], img[:1], size).rms
    stacked = calib.calibrate_camera(np.stack(obj[:6]), np.stack(img[:6]), size)
    assert stacked.rms == calib.calibrate_camera(obj[:6], img[:6], size).rms


def test_ints_beyond_64_bits_are_out_of_range_value_errors(left):
    # As a smaller out-of-range value (threads=10**6), not pyo3's OverflowError.
    obj, img, size = left
    for kw in [dict(threads=2**63), dict(max_iterations=-2**64), dict(loss_scale=10**400)]:
        name = next(iter(kw))
        with pytest.raises(ValueError, match=f"^{name}: .*out of range"):
            calib.calibrate_camera(obj, img, size, **kw)


def test_float16_is_refused_and_longdouble_is_taken_as_float64(left):
    """float16 keeps 11 significant bits, so pixel coordinates above 2048 are rounded to whole
    pixels (and above 1024 to half pixels): corners in it are a mistake, which cv2 refuses too
    (calibrateCamera wants Point2f / Point3f, projectPoints and undistortPoints CV_32F or
    CV_64F). longdouble is converted to float64, losing nothing a calibration can see."""
    obj, img, size = left
    half = lambda views: [v.astype(np.float16) for v in views]
    with pytest.raises(TypeError, match=r"^image_points\[0\]: float16 .*pass float32 or float64"):
        calib.calibrate_camera(obj, half(img), size)
    with pytest.raises(TypeError, match=r"^object_points\[0\]: float16 "):
        calib.calibrate_camera(half(obj), img, size)
    K = np.array([[500.0, 0, 320], [0, 500, 180], [0, 0, 1]])
    with pytest.raises(TypeError, match=r"^points: float16 "):
        calib.undistort_points(img[0].astype(np.float16), K)
    with pytest.raises(TypeError, match=r"^object_points: float16 "):
        calib.project_points(obj[0].astype(np.float16), np.zeros(3), [0, 0, 500], K)
    with pytest.raises(TypeError, match=r"^K: float16 "):
        calib.undistort_points(img[0], K.astype(np.float16))
    with pytest.raises(TypeError, match=r"^image_points1\[0\]: float16 "):
        calib.stereo_calibrate(obj, half(img), img, size)
    long = lambda views: [v.astype(np.longdouble) for v in views]
    a = calib.calibrate_camera(obj, img, size)
    b = calib.calibrate_camera(long(obj), long(img), size, K=None)
    assert b.rms == a.rms and np.array_equal(b.K, a.K) and np.array_equal(b.dist, a.dist)
    assert np.array_equal(calib.undistort_points(img[0].astype(np.longdouble), K),
                          calib.undistort_points(img[0], K))
