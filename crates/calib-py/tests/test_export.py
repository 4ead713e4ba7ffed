"""stereo_rectify, write_calibration and read_calibration: bit for bit with `calib rectify` and
`calib export` on the bundled sourishg1 data, round trips through every format, and clear
exceptions."""

import json
import subprocess

import numpy as np
import pytest

import calib
from conftest import CALIB, DATA, ROOT, single_arrays
from test_stereo_rig import stereo_arrays


@pytest.fixture(scope="module")
def stereo():
    """The sourishg1 pair calibrated by the bindings (every point, as `calib stereo
    --no-outlier-rejection`), and its image size."""
    obj, left, right, size = stereo_arrays("sourishg1/stereo.json")
    return calib.stereo_calibrate(obj, left, right, size), size


@pytest.fixture(scope="module")
def single():
    obj, img, size = single_arrays("sourishg1/left.json")
    return calib.calibrate_camera(obj, img, size)


def run_calib(*args):
    if CALIB is None:
        pytest.skip("no calib binary: set CALIB_BIN or run cargo build --release -p calib-cli")
    subprocess.run([str(CALIB), *map(str, args), "-q"], check=True, cwd=ROOT)


def rectify_args(result, size):
    return result.K1, result.D1, result.K2, result.D2, size, result.R, result.T


def test_stereo_rectify_bit_for_bit_with_the_calib_command(stereo, tmp_path):
    result, size = stereo
    source = tmp_path / "stereo.json"
    source.write_text(result.to_json())
    for alpha in [-1.0, 0.0, 0.5, 1.0]:
        out = tmp_path / f"rect{alpha}.json"
        run_calib("rectify", source, "--alpha", alpha, "-o", out)
        expected = json.loads(out.read_text())
        R1, R2, P1, P2, Q, roi1, roi2 = calib.stereo_rectify(*rectify_args(result, size), alpha)
        for name, got in zip(["R1", "R2", "P1", "P2", "Q"], [R1, R2, P1, P2, Q]):
            assert np.array_equal(got, np.array(expected[name])), (alpha, name)
            assert got.dtype == np.float64
        assert (R1.shape, P1.shape, P2.shape, Q.shape) == ((3, 3), (3, 4), (3, 4), (4, 4))
        assert list(roi1) == expected["roi1"] and list(roi2) == expected["roi2"]
        assert all(isinstance(v, int) for v in roi1 + roi2)
    # alpha=None is OpenCV's default (-1), also the default of the argument (as in cv2).
    default = calib.stereo_rectify(*rectify_args(result, size))
    none = calib.stereo_rectify(*rectify_args(result, size), alpha=None)
    minus_one = calib.stereo_rectify(*rectify_args(result, size), -1)
    for a, b, c in zip(default[:5], none[:5], minus_one[:5]):
        assert np.array_equal(a, b) and np.array_equal(a, c)


def test_stereo_rectify_geometry_and_argument_forms(stereo):
    result, size = stereo
    R1, R2, P1, P2, Q, _, _ = calib.stereo_rectify(*rectify_args(result, size), 0)
    # Rotations; both rectified cameras share K'; the baseline lies along x.
    for R in (R1, R2):
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.array_equal(P1[:, :3], P2[:, :3]) and P2[1, 3] == 0 and P2[2, 3] == 0
    baseline = np.linalg.norm(result.T)
    assert abs(P2[0, 3]) == pytest.approx(P1[0, 0] * baseline, rel=1e-12)
    # A rotation vector for R, lists, float32 and (N,) / (N, 1) vectors are accepted.
    rvec = _rodrigues(result.R)
    alt = calib.stereo_rectify(result.K1.tolist(), result.D1.ravel(), result.K2.astype(np.float32),
                               result.D2.reshape(-1, 1), list(size), rvec, result.T.ravel(), 0)
    assert np.allclose(alt[0], R1, atol=1e-6) and np.allclose(alt[2], P1, rtol=1e-4)
    # No distortion: None or an empty vector.
    a = calib.stereo_rectify(result.K1, None, result.K2, [], size, result.R, result.T)
    b = calib.stereo_rectify(result.K1, np.zeros(4), result.K2, np.zeros((1, 4)), size,
                             result.R, result.T)
    for x, y in zip(a[:5], b[:5]):
        assert np.array_equal(x, y)


def _rodrigues(R):
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return axis / (2 * np.sin(angle)) * angle


def test_stereo_rectify_errors(stereo):
    result, size = stereo
    K1, D1, K2, D2, size, R, T = rectify_args(result, size)
    with pytest.raises(ValueError, match="K1: expected a 3x3 array, got shape \\(3, 4\\)"):
        calib.stereo_rectify(np.zeros((3, 4)), D1, K2, D2, size, R, T)
    with pytest.raises(ValueError, match="D2: 6 coefficients match no pinhole model"):
        calib.stereo_rectify(K1, D1, K2, np.zeros(6), size, R, T)
    with pytest.raises(ValueError, match="D1: expected a vector"):
        calib.stereo_rectify(K1, np.zeros((2, 4)), K2, D2, size, R, T)
    # The known names once (the message listed them twice).
    with pytest.raises(ValueError, match=r"model: unknown camera model 'pinhole' \(known: [^()]*\)$"):
        calib.stereo_rectify(K1, D1, K2, D2, size, R, T, model="pinhole")
    with pytest.raises(ValueError, match="D1: .*kannala-brandt4"):
        calib.stereo_rectify(K1, np.zeros(5), K2, D2, size, R, T, model="kannala-brandt4")
    with pytest.raises(ValueError, match="image_size: expected \\(width, height\\)"):
        calib.stereo_rectify(K1, D1, K2, D2, (640,), R, T)
    with pytest.raises(ValueError, match="^R: not a rotation matrix"):
        calib.stereo_rectify(K1, D1, K2, D2, size, np.ones((3, 3)), T)
    with pytest.raises(ValueError, match="^T: expected 3 values, got 2"):
        calib.stereo_rectify(K1, D1, K2, D2, size, R, T[:2])
    with pytest.raises(TypeError, match="K2: expected a float32 or float64 array"):
        calib.stereo_rectify(K1, D1, np.array([["a"] * 3] * 3), D2, size, R, T)
    with pytest.raises(ValueError, match="alpha: expected 0 to 1"):
        calib.stereo_rectify(K1, D1, K2, D2, size, R, T, 1.5)
    with pytest.raises(calib.CalibrationError, match="baseline must be finite and non-zero"):
        calib.stereo_rectify(K1, D1, K2, D2, size, R, np.zeros(3))


def same_camera(a, b, k="K", d="dist"):
    assert np.array_equal(a[k], b[k]) and np.array_equal(a[d], b[d])


@pytest.mark.parametrize("fmt", ["opencv", "ros", "kalibr"])
def test_single_camera_round_trip(single, tmp_path, fmt):
    path = tmp_path / f"camera-{fmt}.yaml"
    written = calib.write_calibration(path, single, fmt)
    assert written == [str(path)]
    back = calib.read_calibration(path)
    assert back["kind"] == "single" and back["model"] == "brown-conrady4"
    assert back["image_size"] == single.image_size
    assert back["K"].shape == (3, 3) and back["dist"].shape == (1, 4)
    same_camera(back, {"K": single.K, "dist": single.dist})
    # The dict goes back in: the same file again.
    again = tmp_path / f"again-{fmt}.yaml"
    calib.write_calibration(again, back, fmt)
    assert again.read_text() == path.read_text()


@pytest.mark.parametrize("fmt", ["opencv", "kalibr"])
def test_stereo_round_trip(stereo, tmp_path, fmt):
    result, size = stereo
    path = tmp_path / f"rig-{fmt}.yaml"
    assert calib.write_calibration(str(path), result, format=fmt) == [str(path)]
    back = calib.read_calibration(str(path))
    assert back["kind"] == "stereo" and back["image_size"] == back["image_size2"] == size
    assert back["models"] == result.models
    for k, d, kk, dd in [("K1", "D1", result.K1, result.D1), ("K2", "D2", result.K2, result.D2)]:
        same_camera(back, {k: kk, d: dd}, k, d)
    assert back["R"].shape == (3, 3) and back["T"].shape == (3, 1)
    assert np.allclose(back["R"], result.R, atol=1e-15) and np.allclose(back["T"], result.T, rtol=1e-15)
    again = tmp_path / f"again-{fmt}.yaml"
    calib.write_calibration(again, back, fmt)
    assert calib.read_calibration(again).keys() == back.keys()


def test_ros_stereo_writes_one_file_per_camera(stereo, tmp_path):
    result, _ = stereo
    written = calib.write_calibration(tmp_path / "ros.yaml", result, "ros", alpha=None)
    assert written == [str(tmp_path / "ros-left.yaml"), str(tmp_path / "ros-right.yaml")]
    left, right = (calib.read_calibration(p) for p in written)
    assert left["kind"] == right["kind"] == "single"
    same_camera(left, {"K": result.K1, "dist": result.D1})
    same_camera(right, {"K": result.K2, "dist": result.D2})


@pytest.mark.parametrize("fmt", ["opencv", "ros", "kalibr"])
def test_files_equal_those_of_calib_export(stereo, single, tmp_path, fmt):
    for name, result in [("stereo", stereo[0]), ("single", single)]:
        source = tmp_path / f"{name}.json"
        source.write_text(result.to_json())
        cli = tmp_path / f"cli-{name}.yaml"
        run_calib("export", source, "--format", fmt, "-o", cli)
        ours = calib.write_calibration(tmp_path / f"py-{name}.yaml", result, fmt)
        theirs = calib.write_calibration(tmp_path / f"json-{name}.yaml",
                                         calib.read_calibration(source), fmt)
        cli_files = [cli] if len(ours) == 1 else [tmp_path / f"cli-{name}-{s}.yaml"
                                                  for s in ("left", "right")]
        for a, b, c in zip(ours, theirs, cli_files):
            text = c.read_text()
            assert open(a).read() == text and open(b).read() == text
        # read_calibration reads what calib export wrote.
        read = calib.read_calibration(cli_files[0])
        if name == "single" or fmt == "ros":
            same_camera(read, {"K": result.K if name == "single" else result.K1,
                               "dist": result.dist if name == "single" else result.D1})
        else:
            same_camera(read, {"K1": result.K1, "D1": result.D1}, "K1", "D1")
            same_camera(read, {"K2": result.K2, "D2": result.D2}, "K2", "D2")


def test_read_calibration_of_result_json(stereo, tmp_path):
    result, _ = stereo
    path = tmp_path / "stereo.json"
    path.write_text(result.to_json())
    d = calib.read_calibration(path)
    assert np.array_equal(d["R"], result.R) and np.array_equal(d["T"], result.T)
    same_camera(d, {"K1": result.K1, "D1": result.D1}, "K1", "D1")


def test_export_options_and_errors(stereo, single, tmp_path):
    result, _ = stereo
    # translation_scale reaches the file (mm to m).
    calib.write_calibration(tmp_path / "m.yaml", result, "kalibr", translation_scale=0.001)
    scaled = calib.read_calibration(tmp_path / "m.yaml")
    assert np.allclose(scaled["T"], result.T * 0.001, rtol=1e-12)
    with pytest.raises(ValueError, match="format: unknown format 'matlab'"):
        calib.write_calibration(tmp_path / "x.yaml", single, "matlab")
    with pytest.raises(ValueError, match="alpha"):
        calib.write_calibration(tmp_path / "x.yaml", single, alpha=3)
    with pytest.raises(ValueError, match="translation scale"):
        calib.write_calibration(tmp_path / "x.yaml", single, translation_scale=0)
    with pytest.raises(TypeError, match="expected a CameraCalibration, a StereoCalibration, a RigCalibration or a dict"):
        calib.write_calibration(tmp_path / "x.yaml", [1, 2, 3])
    with pytest.raises(ValueError, match="the dict has no key 'dist'"):
        calib.write_calibration(tmp_path / "x.yaml", {"K": single.K, "image_size": (640, 360)})
    with pytest.raises(ValueError, match="the dict has no key 'D1'"):
        calib.write_calibration(tmp_path / "x.yaml", {"K1": single.K, "image_size": (640, 360)})
    rational = {"K": single.K, "dist": np.zeros(8), "image_size": (640, 360)}
    with pytest.raises(calib.CalibrationError, match="kalibr format has no equivalent of the rational8"):
        calib.write_calibration(tmp_path / "x.yaml", rational, "kalibr")
    assert not (tmp_path / "x.yaml").exists()
    with pytest.raises(FileNotFoundError, match="nowhere.yaml"):
        calib.read_calibration(tmp_path / "nowhere.yaml")
    (tmp_path / "other.yaml").write_text("fruit: apple\n")
    with pytest.raises(calib.CalibrationError, match="not a calibration file"):
        calib.read_calibration(tmp_path / "other.yaml")
    obs = DATA / "sourishg1/left.json"
    with pytest.raises(calib.CalibrationError):
        calib.read_calibration(obs)


def test_stereo_rectify_fisheye_bit_for_bit(tmp_path):
    """A fisheye (Kannala-Brandt) rig through an OpenCV file: calib rectify on the file written by
    write_calibration gives stereo_rectify's numbers."""
    K = np.array([[300.0, 0, 320.5], [0, 301.0, 180.25], [0, 0, 1]])
    rig = {"K1": K, "D1": [0.01, -0.004, 0.001, -0.0002], "K2": K * [[1.01], [1.0], [1]],
           "D2": [0.02, -0.003, 0.0, 0.0001], "R": _rotation([0.01, -0.02, 0.005]),
           "T": [-60.0, 0.5, 1.0], "image_size": (640, 360),
           "models": ("kannala-brandt4", "kannala-brandt4")}
    path = tmp_path / "fisheye.yaml"
    calib.write_calibration(path, rig, "opencv")
    back = calib.read_calibration(path)
    assert back["models"] == rig["models"]
    out = tmp_path / "rect-kb.json"
    run_calib("rectify", path, "--alpha", 0.5, "-o", out)
    expected = json.loads(out.read_text())
    got = calib.stereo_rectify(back["K1"], back["D1"], back["K2"], back["D2"], back["image_size"],
                               back["R"], back["T"], 0.5, model="kannala-brandt4")
    for name, a in zip(["R1", "R2", "P1", "P2", "Q"], got[:5]):
        assert np.array_equal(a, np.array(expected[name])), name
    assert list(got[5]) == expected["roi1"] and list(got[6]) == expected["roi2"]
    # Without model=, four coefficients are read as Brown-Conrady: other numbers.
    plain = calib.stereo_rectify(back["K1"], back["D1"], back["K2"], back["D2"], (640, 360),
                                 back["R"], back["T"], 0.5)
    assert not np.array_equal(plain[2], got[2])


def _rotation(rvec):
    rvec = np.asarray(rvec, dtype=float)
    theta = np.linalg.norm(rvec)
    k = rvec / theta
    S = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(theta) * S + (1 - np.cos(theta)) * S @ S


def test_rig_results_are_written_in_every_format_and_read_back(tmp_path):
    """A rig of three cameras (from `calib synth rig`) calibrated by the bindings: OpenCV's rig
    layout gives back the rig exactly (and is byte-identical to `calib export` of the same
    result), Kalibr's chain gives it back to rounding, ROS writes one file per camera, and the
    dict read_calibration returns writes the same file again."""
    if CALIB is None:
        pytest.skip("no calib binary: set CALIB_BIN or run cargo build --release -p calib-cli")
    obs = tmp_path / "rig.json"
    subprocess.run([str(CALIB), "synth", "rig", "--cameras", "3", "--views", "24", "-o", str(obs)],
                   check=True, cwd=ROOT)
    d = json.loads(obs.read_text())
    names = [c["name"] for c in d["cameras"]]
    sizes = [tuple(c["image_size"]) for c in d["cameras"]]
    obj = [np.array(f["object_points"]) for f in d["frames"]]
    frames = [{o["camera"]: np.array(o["image_points"]) for o in f["observations"]}
              for f in d["frames"]]
    result = calib.calibrate_rig(sizes, obj, frames, names=names)
    rms, Ks, dists, Rs, Ts = result

    written = calib.write_calibration(tmp_path / "rig.yaml", result, "opencv")
    back = calib.read_calibration(written[0])
    assert back["kind"] == "rig" and back["names"] == names and back["reference"] == 0
    assert back["image_sizes"] == sizes
    for i in range(3):
        assert np.array_equal(back["Ks"][i], Ks[i]) and np.array_equal(back["dists"][i], dists[i])
        assert np.array_equal(back["Rs"][i], Rs[i]) and np.array_equal(back["Ts"][i], Ts[i])
    result_json = tmp_path / "result.json"
    result_json.write_text(result.to_json())
    run_calib("export", result_json, "--format", "opencv", "-o", tmp_path / "cli.yaml")
    assert (tmp_path / "cli.yaml").read_bytes() == (tmp_path / "rig.yaml").read_bytes()
    again = calib.write_calibration(tmp_path / "again.yaml", back, "opencv")
    assert open(again[0], "rb").read() == (tmp_path / "rig.yaml").read_bytes()

    chain = calib.read_calibration(calib.write_calibration(tmp_path / "chain.yaml", result, "kalibr")[0])
    assert chain["kind"] == "rig" and chain["names"] == ["cam0", "cam1", "cam2"]
    for i in range(3):
        assert np.array_equal(chain["Ks"][i], Ks[i])
        assert np.allclose(chain["Rs"][i], Rs[i], rtol=0, atol=1e-14)
        assert np.allclose(chain["Ts"][i], Ts[i], rtol=1e-13, atol=1e-10)

    ros = calib.write_calibration(tmp_path / "ros.yaml", result, "ros")
    assert ros == [str(tmp_path / f"ros-{n}.yaml") for n in names]
    for path, K in zip(ros, Ks):
        assert np.array_equal(calib.read_calibration(path)["K"], K)

    with pytest.raises(ValueError, match="expected 3 items"):
        calib.write_calibration(tmp_path / "bad.yaml", dict(back, Ks=back["Ks"][:2]), "opencv")


def test_float32_rotation_matrices_are_rotations(stereo, tmp_path):
    # A rotation rounded to float32 (cv2.FileStorage with dt: f, cv2's float32 outputs) is
    # orthonormal to about 1e-7 only; it is accepted as calib-export accepts it (to 1e-6),
    # wherever a rotation matrix is taken.
    result, size = stereo
    K1, D1, K2, D2, R, T = (getattr(result, k) for k in ("K1", "D1", "K2", "D2", "R", "T"))
    R32 = R.astype(np.float32)
    assert np.abs(R32.astype(np.float64).T @ R32 - np.eye(3)).max() > 1e-9
    expected = calib.stereo_rectify(K1, D1, K2, D2, size, R32.astype(np.float64), T)
    got = calib.stereo_rectify(K1, D1, K2, D2, size, R32, T)
    for a, b in zip(got, expected):
        assert np.array_equal(a, b)
    pts = np.array([[100.0, 50.0], [400.0, 300.0]])
    assert np.isfinite(calib.undistort_points(pts, K1, D1, R=R32)).all()
    board = np.array([[0.0, 0, 500], [10, 0, 500], [0, 10, 500]])
    assert calib.project_points(board, R32, T, K1, D1).shape == (3, 2)
    d = {"K1": K1, "D1": D1, "K2": K2, "D2": D2, "R": R32, "T": T, "image_size": size}
    assert calib.write_calibration(tmp_path / "s.yaml", d)
    # Still refused: a matrix that is not a rotation to 1e-6.
    with pytest.raises(ValueError, match="^R: not a rotation matrix"):
        calib.stereo_rectify(K1, D1, K2, D2, size, R * (1 + 1e-5), T)


def test_messages_name_python_arguments_not_command_line_flags(tmp_path):
    """The crates' hints are written for the `calib` command (`--model rational8`, `calib single
    --compare-models`); from Python they name the keyword argument and the function instead."""
    K = np.array([[500.0, 0, 320], [0, 500, 180], [0, 0, 1]])
    single = {"K": K, "dist": [0.1, 0.01, 0, 0, 0.001], "image_size": (640, 360)}
    cases = [
        (lambda: calib.write_calibration(tmp_path / "k.yaml", single, "kalibr"),
         "with k3 = 0.001 (Kalibr's radtan has k1 k2 r1 r2 only; calibrate with model='brown-conrady4')"),
        (lambda: calib.write_calibration(tmp_path / "k.yaml", dict(single, dist=np.zeros(8)), "kalibr"),
         "calibrate with model='brown-conrady4' or model='kannala-brandt4')"),
        (lambda: calib.write_calibration(tmp_path / "r.yaml", dict(single, dist=np.zeros(12)), "ros"),
         "calibrate with model='rational8' for ROS)"),
        (lambda: calib.stereo_rectify(K, [-1.0, 0, 0, 0], K, None, (640, 360), np.eye(3), [-60, 0, 0]),
         "recalibrate this camera with a model valid over the image, e.g. as calib.compare_models recommends)"),
        (lambda: calib.stereo_rectify(K, None, K, None, (640, 360), [0, 1.6, 0], [-60, 0, 0]),
         "(undistort each camera alone: undistort_points without R, or images with the command `calib undistort`)"),
    ]
    for call, python in cases:
        with pytest.raises(calib.CalibrationError) as e:
            call()
        message = str(e.value)
        assert message.endswith(python), message
        assert "--" not in message and "calib single" not in message, message


def test_a_stereo_pair_that_cannot_be_rectified_is_written_with_a_warning(stereo, tmp_path):
    """A stereo rig whose lens model folds inside the image (k1 = -2: not one-to-one beyond 0.41
    of the focal length) has no rectification: the OpenCV file holds M1 ... F without R1 ... Q
    and says why in a comment, and Python gets a UserWarning as `calib export` prints one; ROS
    (whose stereo files are the rectification) is refused."""
    result, size = stereo
    folding = calib.read_calibration(result.to_json())
    folding["D1"] = np.array([[-2.0, 0.0, 0.0, 0.0]])
    path = tmp_path / "folding.yaml"
    with pytest.warns(UserWarning, match="without the rectification"):
        calib.write_calibration(path, folding, "opencv")
    text = path.read_text()
    assert "\nF: " in text and "\nR1: " not in text and "# " in text
    back = calib.read_calibration(path)
    assert np.array_equal(back["D1"], folding["D1"])
    with pytest.raises(calib.CalibrationError, match="rectification"):
        calib.write_calibration(tmp_path / "folding-ros.yaml", folding, "ros")
