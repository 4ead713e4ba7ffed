"""Paths that cannot be read or written raise the OSError subclass Python's open() raises for
them (FileNotFoundError, IsADirectoryError, NotADirectoryError, PermissionError), with errno,
filename and open()'s message; a file that can be read but holds the wrong content stays a
CalibrationError."""

import errno
import os

import numpy as np
import pytest

import calib
from conftest import DATA

SINGLE = {
    "K": np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
    "dist": np.zeros(4),
    "image_size": (640, 480),
}


def open_error(path, mode="r"):
    """The exception open(path, mode) raises."""
    with pytest.raises(OSError) as e:
        open(path, mode)
    return e.value


def check_like_open(call, path, mode="r"):
    """`call()` raises what open(path, mode) raises: the same class, errno, filename and text."""
    expected = open_error(path, mode)
    with pytest.raises(OSError) as e:
        call()
    assert type(e.value) is type(expected), (e.value, expected)
    assert (e.value.errno, e.value.filename) == (expected.errno, expected.filename)
    assert str(e.value) == str(expected)
    assert not isinstance(e.value, calib.CalibrationError)
    return e.value


def test_reading_a_missing_path_is_file_not_found(tmp_path):
    missing = tmp_path / "missing.yaml"
    e = check_like_open(lambda: calib.read_calibration(missing), missing)
    assert isinstance(e, FileNotFoundError) and e.errno == errno.ENOENT
    assert str(missing) in str(e)
    check_like_open(lambda: calib.read_calibration(str(missing)), missing)
    check_like_open(lambda: calib.read_calibration(tmp_path / "no" / "x.yaml"), tmp_path / "no" / "x.yaml")
    e = check_like_open(lambda: calib.imread_gray(tmp_path / "nope.png"), tmp_path / "nope.png")
    assert isinstance(e, FileNotFoundError)


def test_reading_a_folder_or_through_a_file_is_like_open(tmp_path):
    folder = tmp_path / "folder.yaml"
    folder.mkdir()
    assert isinstance(check_like_open(lambda: calib.read_calibration(folder), folder), IsADirectoryError)
    assert isinstance(check_like_open(lambda: calib.imread_gray(folder), folder), IsADirectoryError)
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    inside = plain / "x.yaml"
    assert isinstance(check_like_open(lambda: calib.read_calibration(inside), inside), NotADirectoryError)
    assert isinstance(check_like_open(lambda: calib.imread_gray(inside), inside), NotADirectoryError)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads every file")
def test_reading_an_unreadable_file_is_permission_error(tmp_path):
    for name in ("locked.yaml", "locked.png"):
        locked = tmp_path / name
        locked.write_bytes((DATA / "sourishg1/images/left01.jpg").read_bytes())
        locked.chmod(0)
        call = calib.read_calibration if name.endswith(".yaml") else calib.imread_gray
        assert isinstance(check_like_open(lambda: call(locked), locked), PermissionError)


def test_writing_where_no_file_can_be_is_like_open(tmp_path):
    target = tmp_path / "no" / "camera.yaml"
    e = check_like_open(lambda: calib.write_calibration(target, SINGLE), target, "w")
    assert isinstance(e, FileNotFoundError)
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    e = check_like_open(lambda: calib.write_calibration(plain / "x.yaml", SINGLE), plain / "x.yaml", "w")
    assert isinstance(e, NotADirectoryError)


def test_writing_over_a_folder_or_a_read_only_file(tmp_path):
    # calib refuses these itself (also as root, who could replace a read-only file): the
    # subclass open() would raise, the path as filename, and calib's reason.
    folder = tmp_path / "out.yaml"
    folder.mkdir()
    with pytest.raises(IsADirectoryError, match="that is a folder; give a file name") as e:
        calib.write_calibration(folder, SINGLE)
    assert e.value.errno == errno.EISDIR and e.value.filename == str(folder)
    read_only = tmp_path / "read-only.yaml"
    read_only.write_text("")
    read_only.chmod(0o444)
    with pytest.raises(PermissionError, match="the file is read-only") as e:
        calib.write_calibration(read_only, SINGLE)
    assert e.value.errno == errno.EACCES and e.value.filename == str(read_only)
    assert str(read_only) in str(e.value)
    assert read_only.read_text() == ""


def test_wrong_content_stays_a_calibration_error(tmp_path):
    utf16 = tmp_path / "utf16.yaml"
    utf16.write_bytes("%YAML:1.0\n".encode("utf-16"))
    with pytest.raises(calib.CalibrationError, match="UTF-16") as e:
        calib.read_calibration(utf16)
    assert not isinstance(e.value, OSError)
    other = tmp_path / "other.yaml"
    other.write_text("fruit: apple\n")
    with pytest.raises(calib.CalibrationError, match="not a calibration file"):
        calib.read_calibration(other)
    with pytest.raises(calib.CalibrationError, match="unsupported image format"):
        calib.imread_gray(DATA / "README.md")


def test_a_long_text_taken_as_a_path_is_not_echoed_whole():
    # 50000 characters on one line: a path to the reader, too long for the system.
    with pytest.raises(OSError) as e:
        calib.read_calibration("x" * 50000)
    assert e.value.errno == errno.ENAMETOOLONG
    assert len(str(e.value)) < 400 and "(50000 characters)" in str(e.value)
