"""compare_models: the numbers, the recommendation and the table of `calib single
--compare-models`, and clear exceptions for bad input."""

import copy
import json
import pickle
import subprocess

import numpy as np
import pytest

import calib
from conftest import CALIB, DATA, ROOT, single_arrays

LEFT = "sourishg1/left.json"


def test_same_comparison_and_table_as_the_calib_command(tmp_path):
    if CALIB is None:
        pytest.skip("no calib binary: set CALIB_BIN or run cargo build --release -p calib-cli")
    obj, img, size = single_arrays(LEFT)
    # The command rejects outliers by default; the package only when asked.
    c = calib.compare_models(obj, img, size, reject_outliers=True)
    out = tmp_path / "comparison.json"
    printed = subprocess.run(
        [str(CALIB), "single", str(DATA / LEFT), "--compare-models", "-o", str(out)],
        check=True, cwd=ROOT, capture_output=True, text=True,
    ).stdout
    with open(out) as f:
        expected = json.load(f)
    # Every number of the command's file, exactly (Python's float parsing is correctly rounded).
    assert json.loads(c.to_json()) == expected
    assert [r.model for r in c.rows] == [r["model"] for r in expected["rows"]] == [
        "brown-conrady4", "brown-conrady5", "kannala-brandt4", "rational8", "thin-prism12"]
    for row, want in zip(c.rows, expected["rows"]):
        assert row.rms == want["rms"]
        assert row.cross_validated_rms == want["cross_validated_rms"]
        assert row.parameters == want["parameters"]
        assert row.valid_over_image == want["valid_over_image"]
        assert [w.code for w in row.warnings] == [w["code"] for w in want["warnings"]]
        assert row.error == want["error"]
        # The paired test's inputs and result (29 views, each held out once).
        assert row.held_out == [tuple(v.values()) for v in want["held_out"]]
        assert sorted(v[0] for v in row.held_out) == list(range(29))
        assert row.excess_over_reference == want["excess_over_reference"]
        assert row.excess_std_error == want["excess_std_error"]
    assert c.reference == expected["reference"] == "brown-conrady4"
    assert c.recommended == expected["recommended"] == "brown-conrady4"
    assert c.best_fit == expected["best_fit"]
    assert c.gap_to_best_fit == expected["gap_to_best_fit"]
    assert c.held_fixed == expected["held_fixed"] == []
    # The bundled boards stay away from the image corners: equally fitting models disagree there.
    d = c.uncovered_disagreement
    assert d == expected["uncovered_disagreement"]
    assert d["pixels"] > 1.0 and d["model"] != c.recommended and d["place"].endswith(("corner", "edge"))
    # The table is the command's (the same Rust function), recommendation included.
    assert str(c) == c.table()
    assert c.table() in printed
    assert "recommended: brown-conrady4" in c.table()


def test_models_and_fix_by_name():
    obj, img, size = single_arrays(LEFT)
    c = calib.compare_models(obj, img, size, models=["brown-conrady5", "kannala-brandt4"],
                             fix=["K3", "principal_point"])
    assert [r.model for r in c.rows] == ["brown-conrady5", "kannala-brandt4"]
    # k3 held in both models (each its own k3) and the principal point: 9 - 1 - 2 and
    # 8 - 1 - 2; the count is of the estimated camera parameters, as the command's table.
    assert [r.parameters for r in c.rows] == [6, 5]
    assert c.held_fixed == ["k3"]
    assert "held at zero in every model that has them: k3" in str(c)
    assert all(r.cross_validated_rms is not None for r in c.rows)
    assert c.recommended in {"brown-conrady5", "kannala-brandt4"}
    # Pickling and copying keep every number (through the JSON form), and the command's file
    # reads back the same way.
    for again in [pickle.loads(pickle.dumps(c)), copy.copy(c), copy.deepcopy(c),
                  calib.ModelComparison.from_json(c.to_json())]:
        assert again.to_json() == c.to_json()
        assert again.table() == c.table()
        assert [r.rms for r in again.rows] == [r.rms for r in c.rows]
    with pytest.raises(ValueError, match="not a model comparison"):
        calib.ModelComparison.from_json('{"rows": 3}')
    # A comma-separated string is a list of names.
    assert [r.model for r in calib.compare_models(obj, img, size, models="brown-conrady4").rows] == [
        "brown-conrady4"]


def test_bad_input_names_the_problem():
    obj, img, size = single_arrays(LEFT)
    with pytest.raises(ValueError, match=r"models\[1\].*pinhole"):
        calib.compare_models(obj, img, size, models=["brown-conrady4", "pinhole"])
    with pytest.raises(ValueError, match="models: no model"):
        calib.compare_models(obj, img, size, models=[])
    with pytest.raises(ValueError, match=r"models\[1\]: brown-conrady5 is compared already"):
        calib.compare_models(obj, img, size, models=["brown-conrady5", "plumb_bob"])
    with pytest.raises(TypeError, match=r"models\[0\]: expected a model name"):
        calib.compare_models(obj, img, size, models=[4])
    with pytest.raises(ValueError, match="fix: no compared model has a coefficient 'k5'"):
        calib.compare_models(obj, img, size, models=["brown-conrady5", "kannala-brandt4"], fix="k5")
    with pytest.raises(ValueError, match="fix: 'tangential'"):
        calib.compare_models(obj, img, size, models=["kannala-brandt4"], fix="tangential")
    # One view (or three) would be ranked by RMS alone, which favours the most terms: refused.
    with pytest.raises(ValueError, match="object_points: 1 view; comparing models needs at least 4"):
        calib.compare_models(obj[:1], img[:1], size)
    with pytest.raises(ValueError, match="3 views"):
        calib.compare_models(obj[:3], img[:3], size)
    # Data no model can be fitted to: the crate's reason, naming the view as given.
    bad = [i.copy() for i in img]
    bad[3][5, 1] = np.nan
    names = [f"left{i + 1}.jpg" for i in range(len(obj))]
    with pytest.raises(calib.CalibrationError,
                       match=r"no model could be fitted: view 3 \('left4.jpg'\), point 5"):
        calib.compare_models(obj, bad, size, names=names)
    with pytest.raises(TypeError, match="reject_outliers"):
        calib.compare_models(obj, img, size, reject_outliers="yes")


def test_the_gil_is_released_while_comparing():
    import threading

    obj, img, size = single_arrays(LEFT)
    count = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1

    t = threading.Thread(target=spin)
    t.start()
    try:
        before = count[0]
        calib.compare_models(obj, img, size, models=["brown-conrady4"], threads=1)
        during = count[0] - before
    finally:
        stop.set()
        t.join()
    # With the GIL held for the whole call the other thread could not have counted at all.
    assert during > 1000, during


def test_rows_pickle_and_copy_like_the_comparison():
    # ModelComparison pickles; its rows are values too (multiprocessing returns them, deepcopy
    # copies them), through the same JSON form.
    obj, img, size = single_arrays("sourishg1/left.json")
    c = calib.compare_models(obj[:6], img[:6], size, models=["brown-conrady4", "rational8"])
    for row in c.rows:
        for again in [pickle.loads(pickle.dumps(row)), copy.copy(row), copy.deepcopy(row)]:
            assert type(again) is calib.ModelRow and repr(again) == repr(row)
            for name in ["model", "parameters", "rms", "cross_validated_rms", "valid_over_image", "error"]:
                assert getattr(again, name) == getattr(row, name), name
            assert [(w.code, w.message) for w in again.warnings] == [(w.code, w.message) for w in row.warnings]
