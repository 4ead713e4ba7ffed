"""Camera calibration from NumPy arrays, shaped like OpenCV's functions.

Single cameras (:func:`calibrate_camera`; lens models compared with :func:`compare_models`),
stereo pairs (:func:`stereo_calibrate`), rigs of N cameras (:func:`calibrate_rig`), chessboard
detection (:func:`detect_chessboard`), undistortion (:func:`undistort_points`), projection
(:func:`project_points`), stereo rectification (:func:`stereo_rectify`) and the OpenCV, ROS and Kalibr files (:func:`write_calibration`, :func:`read_calibration`). The work
is done by the project's Rust crates (the extension module ``calib._calib``) with the GIL
released; failures raise :class:`CalibrationError` with the Rust message (a file that cannot be
opened raises the ``OSError`` subclass ``open()`` raises, e.g. ``FileNotFoundError``). See
docs/python.md.

    rms, K, dist, rvecs, tvecs = calib.calibrate_camera(object_points, image_points, (w, h))
"""

from ._calib import (
    MODELS,
    CalibrationError,
    CalibrationWarning,
    CameraCalibration,
    ModelComparison,
    ModelRow,
    RigCalibration,
    StereoCalibration,
    __version__,
    board_points,
    calibrate_camera,
    calibrate_rig,
    compare_models,
    detect_chessboard,
    imread_gray,
    project_points,
    read_calibration,
    stereo_calibrate,
    stereo_rectify,
    undistort_points,
    write_calibration,
)

__all__ = [
    "MODELS",
    "CalibrationError",
    "CalibrationWarning",
    "CameraCalibration",
    "ModelComparison",
    "ModelRow",
    "RigCalibration",
    "StereoCalibration",
    "__version__",
    "board_points",
    "calibrate_camera",
    "calibrate_rig",
    "compare_models",
    "detect_chessboard",
    "imread_gray",
    "project_points",
    "read_calibration",
    "stereo_calibrate",
    "stereo_rectify",
    "undistort_points",
    "write_calibration",
]
