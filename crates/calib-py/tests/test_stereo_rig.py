"""stereo_calibrate and calibrate_rig: bit for bit with `calib stereo` / `calib rig` on the
bundled pairs, cv2-shaped results, and clear exceptions."""

import json

import numpy as np
import pytest

import calib
from conftest import DATA, load, strip


def stereo_arrays(name):
    d = load(name)
    obj = [np.array(p["object_points"]) for p in d["pairs"]]
    left = [np.array(p["left_points"]) for p in d["pairs"]]
    right = [np.array(p["right_points"]) for p in d["pairs"]]
    return obj, left, right, tuple(d["image_size"])


@pytest.mark.parametrize("name", ["sourishg1/stereo.json", "sourishg2/stereo.json"])
def test_stereo_bit_for_bit_with_the_calib_command(calib_cli, name):
    obj, left, right, size = stereo_arrays(name)
    result = calib.stereo_calibrate(obj, left, right, size)
    expected = calib_cli("stereo", DATA / name, "--no-outlier-rejection")
    rms, K1, D1, K2, D2, R, T, E, F = result
    assert rms == expected["rms"]
    assert K1[0, 0] == expected["left"]["fx"] and K2[1, 2] == expected["right"]["cy"]
    assert np.array_equal(R, np.array(expected["R"]))
    assert np.array_equal(T, np.array(expected["T"]).reshape(3, 1))
    assert np.array_equal(E, np.array(expected["E"])) and np.array_equal(F, np.array(expected["F"]))
    assert list(result.rig_std) == expected["rig_std"]
    assert strip(json.loads(result.to_json())) == strip(expected)
    assert D1.shape == D2.shape == (1, 4)
    assert result.std1.shape == result.std2.shape == (8,)
    assert result.per_view_rms.shape == (len(obj), 2)
    assert len(result.rvecs) == len(obj) and result.rvecs[0].shape == (3, 1)
    assert result.baseline == pytest.approx(np.linalg.norm(T))
    stored = json.loads(result.to_json())
    for v, camera in zip(result.validity, ["left", "right"]):
        assert v["valid_radius_px"] == stored[camera]["validity"]["valid_radius_px"]
        assert v["covers_image"] == stored[camera]["validity"]["covers_image"]


def test_stereo_bootstrap_is_the_commands(calib_cli):
    """bootstrap=N: the same resamples and refits as `calib stereo --bootstrap N` (seeded), so
    the same file and the same bootstrap sigmas; without it they are None. Bad counts name the
    argument."""
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    result = calib.stereo_calibrate(obj, left, right, size, bootstrap=10)
    expected = calib_cli("stereo", DATA / "sourishg1/stereo.json", "--no-outlier-rejection",
                         "--bootstrap", "10")
    assert strip(json.loads(result.to_json())) == strip(expected)
    b = expected["bootstrap"]
    assert result.bootstrap_std1.shape == result.std1.shape
    assert list(result.bootstrap_std1[:4]) == [b["left"]["std"][p] for p in ["fx", "fy", "cx", "cy"]]
    assert list(result.bootstrap_std2[4:]) == b["right"]["std"]["dist_coeffs"]
    assert list(result.bootstrap_rig_std) == b["rig_std"]
    assert result.bootstrap_baseline_std == b["baseline_std"]
    plain = calib.stereo_calibrate(obj, left, right, size)
    assert plain.bootstrap_std1 is None and plain.bootstrap_rig_std is None
    assert plain.bootstrap_baseline_std is None
    with pytest.raises(ValueError, match="bootstrap: expected 10 to 10000, got 5"):
        calib.stereo_calibrate(obj, left, right, size, bootstrap=5)


def test_stereo_options_and_guesses(calib_cli):
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    first = calib.stereo_calibrate(obj, left, right, size)
    held = calib.stereo_calibrate(obj, left, right, size, first.K1, first.D1, first.K2, first.D2,
                                  fix_intrinsics=True)
    assert np.array_equal(held.K1, first.K1) and np.array_equal(held.D2, first.D2)
    assert held.std1[0] == 0.0
    expected = calib_cli("stereo", DATA / "sourishg1/stereo.json", "--model", "brown-conrady5",
                         "--right-model", "kannala-brandt4", "--fix", "k3")
    mixed = calib.stereo_calibrate(obj, left, right, size, model="brown-conrady5", fix="k3",
                                   model2="kannala-brandt4", reject_outliers=True)
    assert mixed.models == ("brown-conrady5", "kannala-brandt4")
    assert strip(json.loads(mixed.to_json())) == strip(expected)
    # One fix list without fix2 holds each name in the camera whose model has it, as the CLI.
    expected = calib_cli("stereo", DATA / "sourishg1/stereo.json", "--right-model",
                         "kannala-brandt4", "--fix", "k4")
    held = calib.stereo_calibrate(obj, left, right, size, fix="k4", model2="kannala-brandt4",
                                  reject_outliers=True)
    assert strip(json.loads(held.to_json())) == strip(expected)
    with pytest.raises(ValueError, match="neither model"):
        calib.stereo_calibrate(obj, left, right, size, fix="s1", model2="kannala-brandt4")


def test_stereo_errors():
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    with pytest.raises(ValueError, match="object_points has 29 views but image_points2 has 28"):
        calib.stereo_calibrate(obj, left, right[:-1], size)
    bad = [r.copy() for r in right]
    bad[4][0, 0] = np.inf
    with pytest.raises(calib.CalibrationError, match="pair 4, right view"):
        calib.stereo_calibrate(obj, left, bad, size)
    with pytest.raises(calib.CalibrationError, match="same image"):
        calib.stereo_calibrate(obj, left, left, size)
    with pytest.raises(ValueError, match="R, T: give both"):
        calib.stereo_calibrate(obj, left, right, size, R=np.eye(3))
    with pytest.raises(ValueError, match="^R: not a rotation"):
        calib.stereo_calibrate(obj, left, right, size, R=np.ones((3, 3)), T=np.zeros(3))
    with pytest.raises(ValueError, match="rig_init"):
        calib.stereo_calibrate(obj, left, right, size, rig_init="mean")


def rig_file(name):
    """The stereo pairs as a two-camera rig file (what `calib rig` reads)."""
    d = load(name)
    return {
        "cameras": [{"name": "left", "image_size": d["image_size"]},
                    {"name": "right", "image_size": d["image_size"]}],
        "frames": [{"object_points": p["object_points"],
                    "observations": [{"camera": 0, "image_points": p["left_points"]},
                                     {"camera": 1, "image_points": p["right_points"]}]}
                   for p in d["pairs"]],
    }


def test_rig_bit_for_bit_with_the_calib_command(calib_cli, tmp_path):
    path = tmp_path / "rig.json"
    path.write_text(json.dumps(rig_file("sourishg1/stereo.json")))
    expected = calib_cli("rig", path, "--no-outlier-rejection")
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    result = calib.calibrate_rig([size, size], obj, [{0: l, 1: r} for l, r in zip(left, right)],
                                 names=["left", "right"])
    assert strip(json.loads(result.to_json())) == strip(expected)
    rms, Ks, dists, Rs, Ts = result
    assert rms == expected["rms"] and len(Ks) == 2
    assert np.array_equal(Rs[0], np.eye(3)) and np.array_equal(Ts[0], np.zeros((3, 1)))
    assert np.array_equal(Rs[1], np.array(expected["cameras"][1]["R"]))
    # The list form, names as keys, and float32 (N, 1, 2) pixels give the same numbers.
    as_list = calib.calibrate_rig([size, size], obj, [[l, r] for l, r in zip(left, right)],
                                  names=["left", "right"])
    by_name = calib.calibrate_rig([size, size], obj, [{"left": l, "right": r} for l, r in zip(left, right)],
                                  names=["left", "right"])
    assert as_list.rms == by_name.rms == rms
    # The image sizes as a (cameras, 2) array, one row per camera.
    sizes = calib.calibrate_rig(np.array([size, size]), obj, [[l, r] for l, r in zip(left, right)],
                                names=["left", "right"])
    assert sizes.rms == rms
    assert result.frame_indices == list(range(len(obj)))
    assert set(result.per_view_rms[0]) == {0, 1}
    assert result.tree_parent == [None, 0]
    assert [v["valid_radius_px"] for v in result.validity] == [
        c["validity"]["valid_radius_px"] for c in expected["cameras"]
    ]
    assert result.std[1].shape == (8,) and result.transform_std[0].tolist() == [0.0] * 6


def test_rig_holds_coefficients_per_camera(calib_cli, tmp_path):
    # fix={camera: names} is `calib rig --fix NAME=...`: the same numbers bit for bit.
    path = tmp_path / "rig.json"
    path.write_text(json.dumps(rig_file("sourishg1/stereo.json")))
    expected = calib_cli("rig", path, "--no-outlier-rejection", "--fix", "right=k2")
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    frames = [{0: l, 1: r} for l, r in zip(left, right)]
    result = calib.calibrate_rig([size, size], obj, frames, names=["left", "right"],
                                 fix={"right": ["k2"]})
    assert strip(json.loads(result.to_json())) == strip(expected)
    dists = result.dists
    assert np.ravel(dists[1])[1] == 0.0 and np.ravel(dists[0])[1] != 0.0
    with pytest.raises(ValueError, match=r"fix\['right'\]: the brown-conrady4 model has no coefficient 'k5'"):
        calib.calibrate_rig([size, size], obj, frames, names=["left", "right"], fix={1: "k5"})
    with pytest.raises(ValueError, match=r"fix\['left'\]: 'principal_point' holds it in every camera"):
        calib.calibrate_rig([size, size], obj, frames, names=["left", "right"],
                            fix={"left": ["principal_point"]})
    with pytest.raises(ValueError, match="fix: no camera named 'middle'"):
        calib.calibrate_rig([size, size], obj, frames, names=["left", "right"], fix={"middle": "k2"})


def test_rig_partial_views_and_missing_cameras():
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    frames = []
    for k, (l, r) in enumerate(zip(left, right)):
        if k % 5 == 4:
            frames.append([l, None])            # only the left camera saw this one
        elif k % 5 == 3:
            frames.append({0: l, 1: (obj[k][:40], r[:40])})  # a partial right view
        else:
            frames.append({0: l, 1: r})
    result = calib.calibrate_rig([size, size], obj, frames)
    assert result.names == ["cam0", "cam1"]
    assert [set(v) for v in result.per_view_rms[4:5]] == [{0}]
    assert result.rms < 1.0


def test_rig_errors():
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    frames = [{0: l, 1: r} for l, r in zip(left, right)]
    with pytest.raises(ValueError, match=r"image_points\[0\]: camera 2 does not exist"):
        calib.calibrate_rig([size, size], obj, [{2: left[0]}] + frames[1:])
    with pytest.raises(ValueError, match="no camera named 'middle'"):
        calib.calibrate_rig([size, size], obj, frames, reference="middle")
    with pytest.raises(ValueError, match=r"image_points\[1\]: 3 entries for 2 cameras"):
        calib.calibrate_rig([size, size], obj, frames[:1] + [[left[1], None, None]] + frames[2:])
    with pytest.raises(ValueError, match=r"image_points\[0\]\[1\]: expected an array of shape"):
        calib.calibrate_rig([size, size], obj, [{0: left[0], 1: right[0][:, :1]}] + frames[1:])
    with pytest.raises(calib.CalibrationError, match="camera 'cam1' has 53 image points for 54 board points"):
        calib.calibrate_rig([size, size], obj, [{0: left[0], 1: right[0][:-1]}] + frames[1:])
    # A third camera in two frames only (its corners shifted: the same corners as cam1's would be
    # refused as one image given for two cameras, below).
    with pytest.raises(calib.CalibrationError, match="saw the board in 2 frames"):
        calib.calibrate_rig([size, size, size], obj, frames[:2] + [{0: l, 1: r, 2: r + 7.0}
                                                                   for l, r in zip(left[2:4], right[2:4])] + frames[4:],
                            )
    with pytest.raises(calib.CalibrationError, match="frame 2: cameras 'cam1' and 'cam2' have the same corners"):
        calib.calibrate_rig([size, size, size], obj, frames[:2] + [{0: l, 1: r, 2: r}
                                                                   for l, r in zip(left[2:4], right[2:4])] + frames[4:],
                            )
    with pytest.raises(ValueError, match="models: 1 models for 2 cameras"):
        calib.calibrate_rig([size, size], obj, frames, models=["brown-conrady4"])
    with pytest.raises(ValueError, match=r"image_sizes\[1\]"):
        calib.calibrate_rig([size, (0, 3)], obj, frames)
    with pytest.raises(TypeError, match=r"^image_sizes: expected a list of \(width, height\), one per camera"):
        calib.calibrate_rig(np.array(size), obj, frames)
    with pytest.raises(ValueError, match="both named 'a'"):
        calib.calibrate_rig([size, size], obj, frames, names=["a", "a"])
    with pytest.raises(ValueError, match="'tangential' holds p1, p2"):
        calib.calibrate_rig([size, size], obj, frames, models="kannala-brandt4",
                            fix="tangential")


def test_rig_fix_names_per_camera_model(calib_cli, tmp_path):
    # As calib rig --fix: each coefficient in every camera whose model has it.
    path = tmp_path / "rig.json"
    path.write_text(json.dumps(rig_file("sourishg1/stereo.json")))
    expected = calib_cli("rig", path, "--no-outlier-rejection", "--model",
                         "right=kannala-brandt4", "--fix", "k4")
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    result = calib.calibrate_rig([size, size], obj, [{0: l, 1: r} for l, r in zip(left, right)],
                                 names=["left", "right"],
                                 models=["brown-conrady4", "kannala-brandt4"], fix="k4")
    assert strip(json.loads(result.to_json())) == strip(expected)
    assert expected["cameras"][1]["fixed_parameters"] == ["k4"]
    with pytest.raises(ValueError, match="no camera's model has a coefficient 's1'"):
        calib.calibrate_rig([size, size], obj, [{0: l, 1: r} for l, r in zip(left, right)],
                            models=["brown-conrady4", "kannala-brandt4"], fix="s1")


def test_duplicate_pair_warning_reads_in_the_singular():
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    obj, left, right = obj[:10], left[:10], right[:10]
    one = calib.stereo_calibrate(obj + obj[:1], left + left[:1], right + right[:1], size)
    [w] = [w for w in one.warnings if w.code == "duplicate-views"]
    assert w.message.startswith("1 pair repeats an earlier pair "), w.message
    two = calib.stereo_calibrate(obj + obj[:2], left + left[:2], right + right[:2], size)
    [w] = [w for w in two.warnings if w.code == "duplicate-views"]
    assert w.message.startswith("2 pairs repeat an earlier pair "), w.message
