"""Result objects as Python values: pickling and copying (through the JSON form), from_json,
read_calibration of to_json() text, tuple slicing."""

import copy
import pickle

import numpy as np
import pytest

import calib
from conftest import single_arrays
from test_stereo_rig import stereo_arrays


def same_attributes(a, b):
    names = [n for n in dir(a) if not n.startswith("_") and not callable(getattr(a, n))]
    assert names
    for n in names:
        x, y = getattr(a, n), getattr(b, n)
        if n == "warnings":
            assert [(w.code, w.message) for w in x] == [(w.code, w.message) for w in y]
        else:
            assert repr(x) == repr(y), n
    assert a.to_json() == b.to_json()
    assert a.summary() == b.summary()


@pytest.fixture(scope="module")
def results():
    obj, img, size = single_arrays("sourishg1/left.json")
    single = calib.calibrate_camera(obj, img, size, model="brown-conrady5", reject_outliers=True)
    o, l, r, s = stereo_arrays("sourishg1/stereo.json")
    o, l, r = o[:10], l[:10], r[:10]
    stereo = calib.stereo_calibrate(o, l, r, s)
    rig = calib.calibrate_rig([s, s], o, [[a, b] for a, b in zip(l, r)], names=["left", "right"])
    return single, stereo, rig


def test_results_pickle_and_copy_exactly(results):
    for result in results:
        for again in [pickle.loads(pickle.dumps(result)), copy.copy(result), copy.deepcopy(result)]:
            assert type(again) is type(result)
            same_attributes(result, again)
        again = type(result).from_json(result.to_json())
        same_attributes(result, again)
        rms, *rest = again
        assert rms == result.rms


def test_from_json_refuses_other_text(results):
    single, stereo, _ = results
    with pytest.raises(ValueError, match="^text: not JSON"):
        calib.CameraCalibration.from_json("nope")
    with pytest.raises(ValueError, match="^text: "):
        calib.CameraCalibration.from_json(stereo.to_json())


def test_read_calibration_takes_to_json_text(results, tmp_path):
    single, stereo, rig = results
    d = calib.read_calibration(single.to_json())
    assert d["kind"] == "single" and np.array_equal(d["K"], single.K)
    assert np.array_equal(d["dist"], single.dist)
    s = calib.read_calibration(stereo.to_json())
    assert s["kind"] == "stereo" and np.array_equal(s["R"], stereo.R)
    assert calib.read_calibration(rig.to_json())["kind"] == "rig"
    # A file still reads as a file, and a long path is not echoed whole.
    path = tmp_path / "single.json"
    path.write_text(single.to_json())
    assert np.array_equal(calib.read_calibration(path)["K"], single.K)
    assert np.array_equal(calib.read_calibration(str(path))["K"], single.K)
    with pytest.raises((calib.CalibrationError, OSError)) as e:
        calib.read_calibration("x" * 50000)
    assert len(str(e.value)) < 400
    with pytest.raises(calib.CalibrationError, match="<text>"):
        calib.read_calibration('{"format": "something-else/1"}')


def test_results_slice_like_tuples(results):
    single, stereo, rig = results
    rms, K, dist = single[:3]
    assert rms == single.rms and np.array_equal(K, single.K) and np.array_equal(dist, single.dist)
    assert len(stereo[1:5]) == 4 and np.array_equal(stereo[-4:][0], stereo.R)
    assert isinstance(rig[::2], tuple) and len(rig[::2]) == 3
    assert single[np.int64(1)] is not None
    with pytest.raises(TypeError, match="indices must be integers or slices, not str"):
        single["K"]
    with pytest.raises(IndexError):
        single[5]
