"""The package's surface: the type stubs cover every public name and attribute, and every
function and result class has a docstring."""

import ast
import pathlib

import calib

STUB = pathlib.Path(calib.__file__).with_name("__init__.pyi")


def stub_names():
    tree = ast.parse(STUB.read_text())
    top, members = set(), {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            top.add(node.name)
        elif isinstance(node, (ast.AnnAssign, ast.Assign)):
            targets = [node.target] if isinstance(node, ast.AnnAssign) else node.targets
            top.update(t.id for t in targets if isinstance(t, ast.Name))
        if isinstance(node, ast.ClassDef):
            members[node.name] = {n.name for n in node.body if isinstance(n, ast.FunctionDef)}
    return top, members


def test_stubs_cover_the_module():
    top, members = stub_names()
    assert set(calib.__all__) <= top
    for cls in [calib.CameraCalibration, calib.StereoCalibration, calib.RigCalibration,
                calib.CalibrationWarning, calib.ModelComparison, calib.ModelRow]:
        public = {a for a in dir(cls) if not a.startswith("_")} - set(dir(UserWarning))
        assert public <= members[cls.__name__], public - members[cls.__name__]
    assert STUB.with_name("py.typed").exists()


def test_docstrings_and_version():
    for name in ["calibrate_camera", "compare_models", "stereo_calibrate", "calibrate_rig",
                 "detect_chessboard",
                 "undistort_points", "imread_gray", "board_points", "stereo_rectify",
                 "write_calibration", "read_calibration"]:
        f = getattr(calib, name)
        assert f.__doc__ and len(f.__doc__) > 100, name
        assert f.__text_signature__, name
        # Every default shows its value (pyo3 writes `...` for some it cannot spell).
        assert "..." not in f.__text_signature__, (name, f.__text_signature__)
    assert calib.CameraCalibration.__doc__ and calib.CalibrationError.__doc__
    assert calib.__version__.count(".") == 2
    assert calib.CalibrationError.__module__ == "calib"


def test_calibrate_camera_docstring_covers_every_argument_and_convention():
    import inspect

    doc = calib.calibrate_camera.__doc__
    for name in inspect.signature(calib.calibrate_camera).parameters:
        assert f"``{name}``" in doc, name
    for words in ["(0, 0)", "board-to-camera", "pixels", "CalibrationWarning"]:
        assert words in doc, words
