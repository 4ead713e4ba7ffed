"""calibrate_camera: the same numbers as the Rust pipeline (the `calib single` command) bit for
bit, cv2-shaped inputs and outputs, and clear exceptions for bad arguments."""

import json
import threading

import numpy as np
import pytest

import calib
from conftest import DATA, load, single_arrays, strip


def rodrigues(r):
    """The rotation vector written in the result files (same formula as the Rust side is not
    needed: the files carry `rotation_vector`)."""
    return np.array(r["rotation_vector"]).reshape(3, 1)


def check_against_file(result, expected):
    """Every number of the command's result file, compared exactly."""
    cam = expected["camera"]
    K = result.K
    assert K[0, 0] == cam["fx"] and K[1, 1] == cam["fy"]
    assert K[0, 2] == cam["cx"] and K[1, 2] == cam["cy"]
    assert K[0, 1] == 0.0 and K[2, 2] == 1.0
    names = calib.MODELS[expected["distortion_model"]]
    assert list(result.dist[0]) == [cam["distortion"][n] for n in names]
    assert result.rms == expected["rms"]
    assert list(result.per_view_rms) == [v["rms"] for v in expected["views"]]
    for rvec, tvec, view in zip(result.rvecs, result.tvecs, expected["views"]):
        assert rvec.shape == (3, 1) and tvec.shape == (3, 1)
        assert np.array_equal(rvec, rodrigues(view))
        assert np.array_equal(tvec, np.array(view["translation"]).reshape(3, 1))
    # And the whole result file, timings and view names aside.
    assert strip(json.loads(result.to_json())) == strip(expected)


@pytest.mark.parametrize("name", ["sourishg1/left.json", "sourishg1/right.json", "sourishg2/left.json"])
def test_bit_for_bit_with_the_calib_command(calib_cli, name):
    obj, img, size = single_arrays(name)
    result = calib.calibrate_camera(obj, img, size)
    expected = calib_cli("single", DATA / name, "--no-outlier-rejection")
    check_against_file(result, expected)
    assert result.view_indices == list(range(len(obj)))
    assert result.num_points == sum(len(o) for o in obj)


def test_options_reach_the_pipeline_like_the_command_line(calib_cli):
    obj, img, size = single_arrays("sourishg1/left.json")
    result = calib.calibrate_camera(
        obj, img, size, model="brown-conrady5", fix=["k3", "aspect_ratio"], reject_outliers=True
    )
    expected = calib_cli(
        "single", DATA / "sourishg1/left.json", "--model", "brown-conrady5", "--fix", "k3",
        "--fix-aspect-ratio",
    )
    check_against_file(result, expected)
    assert "k3" in result.fixed_parameters
    assert result.std[result.param_names.index("k3")] == 0.0


def test_fisheye_model(calib_cli):
    obj, img, size = single_arrays("sourishg1/left.json")
    result = calib.calibrate_camera(obj, img, size, model="kannala-brandt4")
    expected = calib_cli("single", DATA / "sourishg1/left.json", "--model", "kannala-brandt4",
                         "--no-outlier-rejection")
    check_against_file(result, expected)
    assert result.dist.shape == (1, 4) and result.model == "kannala-brandt4"


def test_float32_and_cv2_shapes_are_the_float64_values():
    obj32, img32, size = single_arrays("sourishg1/left.json", np.float32)
    a = calib.calibrate_camera([o.reshape(-1, 1, 3) for o in obj32], [i.reshape(-1, 1, 2) for i in img32], size)
    b = calib.calibrate_camera([o.astype(np.float64) for o in obj32], [i.astype(np.float64) for i in img32], size)
    assert a.rms == b.rms and np.array_equal(a.K, b.K) and np.array_equal(a.dist, b.dist)
    # Non-contiguous views and (1, N, 2) rows too.
    c = calib.calibrate_camera(
        [np.asfortranarray(o) for o in obj32], [i[np.newaxis, :, :] for i in img32], np.array(size)
    )
    assert c.rms == a.rms


def test_unpacks_like_cv2_and_accepts_cv2s_positional_nones():
    obj, img, size = single_arrays("sourishg1/right.json")
    result = calib.calibrate_camera(obj, img, size, None, None)
    rms, K, dist, rvecs, tvecs = result
    assert rms == result.rms and K.shape == (3, 3) and dist.shape == (1, 4)
    assert len(rvecs) == len(tvecs) == len(obj)
    assert len(result) == 5 and result[0] == rms and np.array_equal(result[-4], K)
    with pytest.raises(IndexError):
        result[5]
    assert result.std.shape == (8,) and result.param_names[:4] == ["fx", "fy", "cx", "cy"]
    assert result.pose_std.shape == (len(obj), 6)
    assert result.per_view_rms.shape == (len(obj),)
    assert isinstance(result.report, dict) and result.report["converged"]
    assert "RMS reprojection error" in result.summary()
    assert "CameraCalibration(" in repr(result)
    for w in result.warnings:
        assert isinstance(w, calib.CalibrationWarning) and w.code and w.message


def test_intrinsic_guess_and_fixed_focal_length():
    obj, img, size = single_arrays("sourishg1/left.json")
    first = calib.calibrate_camera(obj, img, size)
    K = first.K.copy()
    K[0, 0] += 20.0
    K[1, 1] += 20.0
    held = calib.calibrate_camera(obj, img, size, K=K, fix="focal_length")
    assert held.K[0, 0] == K[0, 0] and held.K[1, 1] == K[1, 1]
    assert held.rms > first.rms


def test_reject_outliers_finds_a_planted_outlier():
    obj, img, size = single_arrays("sourishg1/left.json")
    img = [i.copy() for i in img]
    img[4][7] += 25.0
    plain = calib.calibrate_camera(obj, img, size)
    robust = calib.calibrate_camera(obj, img, size, reject_outliers=True)
    assert robust.rejected_points[4] == [7]
    assert robust.num_points == plain.num_points - 1
    assert robust.rms < plain.rms
    assert any(w.code == "outliers-rejected" for w in robust.warnings)


def test_calibration_errors_carry_the_rust_message():
    obj, img, size = single_arrays("sourishg1/left.json")
    img = [i.copy() for i in img]
    img[3][5, 1] = np.nan
    with pytest.raises(calib.CalibrationError, match=r"view 3.*point 5"):
        calib.calibrate_camera(obj, img, size)
    with pytest.raises(calib.CalibrationError, match="no usable views"):
        calib.calibrate_camera([], [], size)
    obj, img, size = single_arrays("sourishg1/left.json")
    with pytest.raises(calib.CalibrationError, match="view 2: 54 object points but 53 image points"):
        calib.calibrate_camera(obj, img[:2] + [img[2][:-1]] + img[3:], size)
    assert issubclass(calib.CalibrationError, Exception)


def test_bad_arguments_name_the_argument_and_index():
    obj, img, size = single_arrays("sourishg1/left.json")
    with pytest.raises(ValueError, match="'tangential' holds p1, p2, which kannala-brandt4 does not have"):
        calib.calibrate_camera(obj, img, size, model="kannala-brandt4", fix="tangential")
    bad = img[:6] + [img[6][:, :1]] + img[7:]
    with pytest.raises(ValueError, match=r"image_points\[6\]: expected an array of shape \(N, 2\)"):
        calib.calibrate_camera(obj, bad, size)
    bad = obj[:2] + [obj[2][:, :2]] + obj[3:]
    with pytest.raises(ValueError, match=r"object_points\[2\].*got shape \(54, 2\)"):
        calib.calibrate_camera(bad, img, size)
    bad = img[:1] + [img[1].astype(np.complex128)] + img[2:]
    with pytest.raises(TypeError, match=r"image_points\[1\]: expected a float32 or float64 array, got dtype complex128"):
        calib.calibrate_camera(obj, bad, size)
    bad = img[:1] + [np.array([["a", "b"]] * 54)] + img[2:]
    with pytest.raises(TypeError, match=r"image_points\[1\]"):
        calib.calibrate_camera(obj, bad, size)
    with pytest.raises(ValueError, match="object_points has 29 views but image_points has 28"):
        calib.calibrate_camera(obj, img[:-1], size)
    with pytest.raises(TypeError, match="object_points: expected a list of arrays.*wrap it in a list"):
        calib.calibrate_camera(obj[0], img[0], size)
    with pytest.raises(TypeError, match="image_points: expected a list of arrays"):
        calib.calibrate_camera(obj, 3.5, size)
    for s in [(640,), (640, 0), (640.5, 360), "640x360", (-1, 360), None]:
        with pytest.raises(ValueError, match="image_size: expected \\(width, height\\)"):
            calib.calibrate_camera(obj, img, s)
    with pytest.raises(ValueError, match="model: unknown"):
        calib.calibrate_camera(obj, img, size, model="pinhole-magic")
    with pytest.raises(ValueError, match="fix: unknown coefficient 'k9'"):
        calib.calibrate_camera(obj, img, size, fix=["k9"])
    with pytest.raises(TypeError, match="fix: expected strings"):
        calib.calibrate_camera(obj, img, size, fix=[3])
    with pytest.raises(ValueError, match="K: expected a 3x3 array"):
        calib.calibrate_camera(obj, img, size, K=np.eye(2))
    with pytest.raises(ValueError, match=r"dist: model brown-conrady4 has 4 coefficients \(k1, k2, p1, p2\), got 5; 5 coefficients are brown-conrady5's"):
        calib.calibrate_camera(obj, img, size, model="brown-conrady4", dist=np.zeros(5))
    with pytest.raises(ValueError, match="outlier_threshold"):
        calib.calibrate_camera(obj, img, size, reject_outliers=True, outlier_threshold=1.0)
    with pytest.raises(ValueError, match="loss: unknown loss"):
        calib.calibrate_camera(obj, img, size, loss="tukey")
    with pytest.raises(ValueError, match="names: 2 names for 29 views"):
        calib.calibrate_camera(obj, img, size, names=["a", "b"])


def test_the_gil_is_released_while_calibrating():
    obj, img, size = single_arrays("sourishg1/left.json")
    # A larger problem (the views four times) so that the call lasts a while.
    obj, img = obj * 4, img * 4
    count = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1

    t = threading.Thread(target=spin)
    t.start()
    try:
        before = count[0]
        result = calib.calibrate_camera(obj, img, size, threads=1)
        during = count[0] - before
    finally:
        stop.set()
        t.join()
    # With the GIL held for the whole call the other thread could not have counted at all.
    assert during > 1000, (during, result.elapsed)


def test_skip_bad_views_lists_them():
    obj, img, size = single_arrays("sourishg1/left.json")
    obj = list(obj)
    obj[2] = obj[2][:3]
    img = list(img)
    img[2] = img[2][:3]
    result = calib.calibrate_camera(obj, img, size, skip_bad_views=True)
    assert result.view_indices == [i for i in range(29) if i != 2]
    assert result.skipped_views[0][0] == 2 and "3" in result.skipped_views[0][1]
    assert len(result.rvecs) == 28


def test_duplicate_views_are_kept_unless_asked():
    # (sourishg1: sourishg2's non-square pixels take calib-core's slower focal search start.)
    obj, img, size = single_arrays("sourishg1/right.json")
    kept = calib.calibrate_camera(obj + obj[:1], img + img[:1], size)
    assert len(kept.rvecs) == len(obj) + 1
    dropped = calib.calibrate_camera(obj + obj[:1], img + img[:1], size, drop_duplicate_views=True)
    assert len(dropped.rvecs) == len(obj)
    assert any(w.code == "duplicate-views" for w in dropped.warnings)


def test_bundled_files_exist():
    assert load("sourishg1/left.json")["image_size"] == [640, 360]


def test_validity_is_the_result_files_and_backs_the_warning():
    obj, img, size = single_arrays("sourishg1/left.json")
    plain = calib.calibrate_camera(obj, img, size)
    assert plain.validity["covers_image"] and plain.validity["coverage"] > 1.05
    assert not any(w.code == "model-invalid" for w in plain.warnings)
    # rational8 on these views folds inside the image (docs/after-calibration.md: 347 px).
    wide = calib.calibrate_camera(obj, img, size, model="rational8")
    v = wide.validity
    stored = json.loads(wide.to_json())["camera"]["validity"]
    assert v["valid_radius_px"] == stored["valid_radius_px"]
    assert v["image_radius_px"] == stored["image_radius_px"]
    assert not v["covers_image"] and v["valid_radius_px"] < v["image_radius_px"]
    assert any(w.code == "model-invalid" for w in wide.warnings)


def test_coefficient_names_in_any_case_and_counts_out_of_range():
    obj, img, size = single_arrays("sourishg1/left.json")
    upper = calib.calibrate_camera(obj, img, size, model="brown-conrady5", fix="K3")
    lower = calib.calibrate_camera(obj, img, size, model="brown-conrady5", fix="k3")
    assert upper.fixed_parameters == lower.fixed_parameters == ["k3"]
    assert np.array_equal(upper.K, lower.K)
    for kwargs, name in [({"max_iterations": -1}, "max_iterations"), ({"max_iterations": 0}, "max_iterations"),
                         ({"threads": -2}, "threads")]:
        with pytest.raises(ValueError, match=name):
            calib.calibrate_camera(obj, img, size, **kwargs)


def test_warnings_reach_pythons_warnings_module():
    import pickle
    import warnings

    assert issubclass(calib.CalibrationWarning, UserWarning)
    obj, img, size = single_arrays("sourishg1/left.json")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = calib.calibrate_camera(obj[:6], img[:6], size, model="rational8")
    codes = [w.code for w in result.warnings]
    assert "poorly-determined" in codes
    ours = [c for c in caught if issubclass(c.category, calib.CalibrationWarning)]
    # One warnings.warn per entry of .warnings, attributed to this line (the user's call).
    assert [c.message.code for c in ours] == codes
    assert all(c.filename == __file__ for c in ours)
    w = result.warnings[codes.index("poorly-determined")]
    assert isinstance(w, calib.CalibrationWarning) and isinstance(w, Warning)
    assert str(w) == f"[{w.code}] {w.message}" and w.message in str(ours[codes.index(w.code)].message)
    copy = pickle.loads(pickle.dumps(w))
    assert (copy.code, copy.message) == (w.code, w.message)
    # The usual filters work: ignored, or raised.
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("ignore", calib.CalibrationWarning)
        calib.calibrate_camera(obj[:6], img[:6], size, model="rational8")
    assert not caught
    with warnings.catch_warnings():
        warnings.simplefilter("error", calib.CalibrationWarning)
        with pytest.raises(calib.CalibrationWarning, match=r"^\[poorly-determined\]"):
            calib.calibrate_camera(obj[:6], img[:6], size, model="rational8")
    # One code filtered out, the others still raise: the bundled webcam boards stay away from
    # the image corners, and poor-coverage is that calibration's only warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error", calib.CalibrationWarning)
        warnings.filterwarnings("ignore", r"\[poor-coverage\]", calib.CalibrationWarning)
        result = calib.calibrate_camera(obj, img, size)
    assert [w.code for w in result.warnings] == ["poor-coverage"]


def test_bootstrap_is_the_commands(calib_cli):
    """bootstrap=N: the same resamples and refits as `calib single --bootstrap N` (seeded), so
    the same file and the same `bootstrap_std`; without it `bootstrap_std` is None. Bad counts
    name the argument."""
    obj, img, size = single_arrays("sourishg1/left.json")
    result = calib.calibrate_camera(obj, img, size, model="rational8", bootstrap=12)
    expected = calib_cli("single", DATA / "sourishg1/left.json", "--model", "rational8",
                         "--no-outlier-rejection", "--bootstrap", "12")
    assert strip(json.loads(result.to_json())) == strip(expected)
    assert result.bootstrap_std.shape == result.std.shape
    std = expected["bootstrap"]["std"]
    assert list(result.bootstrap_std[:4]) == [std["fx"], std["fy"], std["cx"], std["cy"]]
    assert calib.calibrate_camera(obj, img, size).bootstrap_std is None
    with pytest.raises(ValueError, match="bootstrap: expected 10 to 10000, got 5"):
        calib.calibrate_camera(obj, img, size, bootstrap=5)
    with pytest.raises(TypeError, match="bootstrap: expected an int or None"):
        calib.calibrate_camera(obj, img, size, bootstrap="100")
