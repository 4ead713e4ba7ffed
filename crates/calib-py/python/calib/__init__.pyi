"""Type stubs of the package `calib` (the extension module calib._calib). See docs/python.md."""

from collections.abc import Iterable, Iterator, Mapping, Sequence
from os import PathLike
from typing import Any, Literal, Optional, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str

ModelName = Literal[
    "brown-conrady4",
    "brown-conrady5",
    "rational8",
    "thin-prism12",
    "kannala-brandt4",
    "plumb_bob",
    "rational_polynomial",
    "equidistant",
    "fisheye",
]
"""Lens model names (the last four are other tools' names for brown-conrady5, rational8 and
kannala-brandt4)."""

FixName = str
"""A name for ``fix``: "principal_point", "focal_length", "aspect_ratio", "tangential", or a
coefficient of the model ("k1", "k2", "p1", "p2", "k3", ... as in ``MODELS``)."""

Points = npt.ArrayLike
"""An (N, 2) / (N, 3) array of float32 or float64, or cv2's (N, 1, 2) / (N, 1, 3). Integers
are converted and longdouble is rounded to float64; float16 (11 significant bits: pixels above
2048 rounded to whole pixels) raises TypeError, as in cv2."""

ImageSize = Sequence[int]
"""(width, height) in pixels."""

Rotation = Literal["euler", "euler-xyz", "axis-angle", "rodrigues", "so3"]
Loss = Optional[Literal["huber", "cauchy"]]

MODELS: dict[str, list[str]]
"""Every lens model and the names of its coefficients, in OpenCV's order."""

class CalibrationError(Exception):
    """A calibration (or detection, or a file's content) failed; the message is the Rust crate's
    (its command-line hints in Python's words: model='rational8' for --model rational8),
    naming the view (pair, frame, camera) and point (or file and key) at fault. A file that
    cannot be opened raises OSError (FileNotFoundError, PermissionError, IsADirectoryError, ...)
    instead, as open() does."""

class CalibrationWarning(UserWarning):
    """Something in a result that deserves attention. The calibration functions emit one with
    warnings.warn per entry of the result's ``warnings`` (which holds instances of this class);
    ``str()`` is ``"[code] message"``."""

    code: str
    """Stable code, e.g. "poorly-determined", "outliers-rejected", "duplicate-views"."""
    message: str
    """What happened and what to do."""

class CameraCalibration:
    """Result of :func:`calibrate_camera`; unpacks as ``rms, K, dist, rvecs, tvecs``."""

    @property
    def rms(self) -> float:
        """RMS reprojection error of the used points, pixels."""
    @property
    def K(self) -> npt.NDArray[np.float64]:
        """Camera matrix, (3, 3)."""
    @property
    def dist(self) -> npt.NDArray[np.float64]:
        """Distortion coefficients in OpenCV's order, (1, N)."""
    @property
    def rvecs(self) -> list[npt.NDArray[np.float64]]:
        """Rodrigues rotation (board to camera) of each used view, (3, 1) each."""
    @property
    def tvecs(self) -> list[npt.NDArray[np.float64]]:
        """Translation (board to camera) of each used view, (3, 1) each."""
    @property
    def std(self) -> npt.NDArray[np.float64]:
        """Standard deviations of ``param_names``, (4 + N,); zero for fixed parameters."""
    @property
    def bootstrap_std(self) -> Optional[npt.NDArray[np.float64]]:
        """The view bootstrap's standard deviations in ``std``'s order, or None without
        ``bootstrap=N``."""
    @property
    def param_names(self) -> list[str]:
        """fx, fy, cx, cy and the model's coefficient names."""
    @property
    def fixed_parameters(self) -> list[str]: ...
    @property
    def pose_std(self) -> npt.NDArray[np.float64]:
        """Standard deviations of each used view's pose parameters (``rotation``
        parameterization, then translation), (views, 6)."""
    @property
    def per_view_rms(self) -> npt.NDArray[np.float64]:
        """RMS of each used view, pixels, (views,)."""
    @property
    def view_indices(self) -> list[int]:
        """Input index of each used view (rvecs, tvecs, per_view_rms follow it)."""
    @property
    def skipped_views(self) -> list[tuple[int, str]]:
        """(input index, reason) of views left out by ``skip_bad_views``."""
    @property
    def rejected_points(self) -> list[list[int]]:
        """Per used view, the indices of points rejected as outliers."""
    @property
    def rms_all_points(self) -> float: ...
    @property
    def num_points(self) -> int: ...
    @property
    def model(self) -> str: ...
    @property
    def image_size(self) -> tuple[int, int]: ...
    @property
    def rotation(self) -> str: ...
    @property
    def validity(self) -> dict[str, Any]:
        """Where the lens model is one-to-one: valid_radius_px (None: no fold found),
        image_radius_px, coverage (None: no fold found), covers_image."""
    @property
    def warnings(self) -> list[CalibrationWarning]: ...
    @property
    def report(self) -> dict[str, Any]:
        """The Levenberg-Marquardt report (termination, converged, iterations, costs, times)."""
    @property
    def elapsed(self) -> float:
        """Wall time of the calibration, seconds."""
    def summary(self) -> str:
        """Every parameter with +- 3 sigma, the RMS, the worst views, the warnings."""
    def to_json(self) -> str:
        """The calib-single-result JSON of docs/formats.md (what ``calib single -o`` writes)."""
    @staticmethod
    def from_json(text: str) -> CameraCalibration:
        """The result again from its ``to_json()`` text (pickling and ``copy`` go through it)."""
    def __len__(self) -> int: ...
    @overload
    def __getitem__(self, index: int) -> Any: ...
    @overload
    def __getitem__(self, index: slice) -> tuple[Any, ...]: ...
    def __iter__(self) -> Iterator[Any]: ...

class StereoCalibration:
    """Result of :func:`stereo_calibrate`; unpacks as ``rms, K1, D1, K2, D2, R, T, E, F``."""

    @property
    def rms(self) -> float: ...
    @property
    def K1(self) -> npt.NDArray[np.float64]: ...
    @property
    def D1(self) -> npt.NDArray[np.float64]: ...
    @property
    def K2(self) -> npt.NDArray[np.float64]: ...
    @property
    def D2(self) -> npt.NDArray[np.float64]: ...
    @property
    def R(self) -> npt.NDArray[np.float64]:
        """Rotation from camera 1 to camera 2 (``X2 = R X1 + T``), (3, 3)."""
    @property
    def T(self) -> npt.NDArray[np.float64]:
        """Translation from camera 1 to camera 2, (3, 1)."""
    @property
    def E(self) -> npt.NDArray[np.float64]: ...
    @property
    def F(self) -> npt.NDArray[np.float64]: ...
    @property
    def std1(self) -> npt.NDArray[np.float64]:
        """Standard deviations of camera 1's fx, fy, cx, cy and coefficients."""
    @property
    def std2(self) -> npt.NDArray[np.float64]: ...
    @property
    def rig_params(self) -> npt.NDArray[np.float64]:
        """[rotation (``rotation`` parameterization), T], (6,)."""
    @property
    def rig_std(self) -> npt.NDArray[np.float64]:
        """Standard deviations of ``rig_params``, (6,)."""
    @property
    def bootstrap_std1(self) -> Optional[npt.NDArray[np.float64]]:
        """The pair bootstrap's standard deviations of camera 1 in ``std1``'s order, or None
        without ``bootstrap=N``."""
    @property
    def bootstrap_std2(self) -> Optional[npt.NDArray[np.float64]]:
        """The pair bootstrap's standard deviations of camera 2 in ``std2``'s order, or None."""
    @property
    def bootstrap_rig_std(self) -> Optional[npt.NDArray[np.float64]]:
        """The pair bootstrap's standard deviations of ``rig_params`` (``rig_std``'s order and
        units), or None."""
    @property
    def bootstrap_baseline_std(self) -> Optional[float]:
        """The pair bootstrap's standard deviation of the baseline (board units), or None."""
    @property
    def baseline(self) -> float: ...
    @property
    def rotation(self) -> str: ...
    @property
    def rvecs(self) -> list[npt.NDArray[np.float64]]:
        """Board-to-camera-1 rotations (Rodrigues) of the used pairs."""
    @property
    def tvecs(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def per_view_rms(self) -> npt.NDArray[np.float64]:
        """RMS of each used pair's two views, (pairs, 2)."""
    @property
    def pair_indices(self) -> list[int]: ...
    @property
    def skipped_pairs(self) -> list[tuple[int, str]]: ...
    @property
    def models(self) -> tuple[str, str]: ...
    @property
    def validity(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """(left, right), each as CameraCalibration.validity."""
    @property
    def num_rejected(self) -> int: ...
    @property
    def warnings(self) -> list[CalibrationWarning]: ...
    @property
    def report(self) -> dict[str, Any]: ...
    @property
    def elapsed(self) -> float: ...
    def summary(self) -> str: ...
    def to_json(self) -> str:
        """The calib-stereo-result JSON (what ``calib stereo -o`` writes)."""
    @staticmethod
    def from_json(text: str) -> StereoCalibration:
        """The result again from its ``to_json()`` text (pickling and ``copy`` go through it)."""
    def __len__(self) -> int: ...
    @overload
    def __getitem__(self, index: int) -> Any: ...
    @overload
    def __getitem__(self, index: slice) -> tuple[Any, ...]: ...
    def __iter__(self) -> Iterator[Any]: ...

class RigCalibration:
    """Result of :func:`calibrate_rig`; unpacks as ``rms, Ks, dists, Rs, Ts`` with
    ``X_cam = R X_ref + T``."""

    @property
    def rms(self) -> float: ...
    @property
    def names(self) -> list[str]: ...
    @property
    def models(self) -> list[str]: ...
    @property
    def validity(self) -> list[dict[str, Any]]:
        """One dict per camera, as CameraCalibration.validity."""
    @property
    def reference(self) -> int: ...
    @property
    def Ks(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def dists(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def Rs(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def Ts(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def std(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def transform_std(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def camera_rms(self) -> list[float]: ...
    @property
    def rvecs(self) -> list[npt.NDArray[np.float64]]:
        """Board-to-reference-camera rotations (Rodrigues) of the used frames."""
    @property
    def tvecs(self) -> list[npt.NDArray[np.float64]]: ...
    @property
    def frame_indices(self) -> list[int]: ...
    @property
    def per_view_rms(self) -> list[dict[int, float]]:
        """Per used frame, {camera index: RMS}."""
    @property
    def tree_parent(self) -> list[Optional[int]]: ...
    @property
    def rotation(self) -> str: ...
    @property
    def num_rejected(self) -> int: ...
    @property
    def warnings(self) -> list[CalibrationWarning]: ...
    @property
    def report(self) -> dict[str, Any]: ...
    @property
    def elapsed(self) -> float: ...
    def summary(self) -> str: ...
    def to_json(self) -> str:
        """The calib-rig-result JSON (what ``calib rig -o`` writes)."""
    @staticmethod
    def from_json(text: str) -> RigCalibration:
        """The result again from its ``to_json()`` text (pickling and ``copy`` go through it)."""
    def __len__(self) -> int: ...
    @overload
    def __getitem__(self, index: int) -> Any: ...
    @overload
    def __getitem__(self, index: slice) -> tuple[Any, ...]: ...
    def __iter__(self) -> Iterator[Any]: ...

class ModelRow:
    """One model's row of a :class:`ModelComparison`."""

    @property
    def model(self) -> str: ...
    @property
    def parameters(self) -> int:
        """Camera parameters (fx, fy, cx, cy and the coefficients) the calibration estimates:
        those held (``fix``, a held principal point, focal length or aspect ratio, zero
        tangential terms) are not counted, as in the command's table."""
    @property
    def rms(self) -> Optional[float]:
        """RMS on all views, pixels (None if the calibration failed)."""
    @property
    def cross_validated_rms(self) -> Optional[float]:
        """Fitted on the even-numbered views, evaluated on the odd-numbered ones and the other
        way round, pixels (None with fewer than 4 views)."""
    @property
    def valid_over_image(self) -> bool: ...
    @property
    def warnings(self) -> list[CalibrationWarning]:
        """The warnings of the fit on all views (not emitted with warnings.warn)."""
    @property
    def error(self) -> Optional[str]:
        """Why the calibration failed, None if it did not."""
    @property
    def held_out(self) -> list[tuple[int, float, int]]:
        """Per view (input index, sum of squared held-out errors in px^2, points); empty
        without cross-validation."""
    @property
    def excess_over_reference(self) -> Optional[float]:
        """Mean log ratio of this model's per-view held-out squared errors to the reference's
        (0.036: 3.7% larger)."""
    @property
    def excess_std_error(self) -> Optional[float]:
        """Standard error of excess_over_reference from the per-view spread."""

class ModelComparison:
    """Result of :func:`compare_models`; ``str()`` is the table ``calib single
    --compare-models`` prints."""

    @property
    def rows(self) -> list[ModelRow]: ...
    @property
    def recommended(self) -> Optional[str]:
        """Fewest parameters among the valid models as good as the best valid one (cross-validated
        RMS within 2% and not systematically worse by the paired test; when the best valid one
        is not as good as best_fit, among those folding within 5% beyond the border)."""
    @property
    def best_fit(self) -> Optional[str]:
        """Lowest cross-validated RMS of all fitted models, valid or not."""
    @property
    def gap_to_best_fit(self) -> Optional[float]:
        """recommended's cross-validated RMS above best_fit's, as a fraction."""
    @property
    def reference(self) -> Optional[str]:
        """The model the rows' excess_over_reference are measured against."""
    @property
    def held_fixed(self) -> list[str]: ...
    @property
    def uncovered_disagreement(self) -> Optional[dict[str, Any]]:
        """Where no board corner was seen: the largest distance (``pixels``) between the
        recommended model's pixel of a ray and another equally fitting ``model``'s, at
        ``place``; None when corners reached every image corner and edge."""
    def table(self) -> str: ...
    def to_json(self) -> str:
        """What ``calib single --compare-models -o FILE`` writes."""
    @staticmethod
    def from_json(text: str) -> ModelComparison:
        """The comparison again from its ``to_json()`` text (pickling and ``copy`` go through it)."""

def calibrate_camera(
    object_points: Iterable[Points],
    image_points: Iterable[Points],
    image_size: ImageSize,
    model: Optional[ModelName] = None,
    fix: Union[None, FixName, Iterable[FixName]] = None,
    *,
    K: Optional[npt.ArrayLike] = None,
    dist: Optional[npt.ArrayLike] = None,
    reject_outliers: bool = False,
    outlier_threshold: float = 5.0,
    loss: Loss = None,
    loss_scale: float = 1.0,
    rotation: Optional[Rotation] = None,
    skip_bad_views: bool = False,
    drop_duplicate_views: bool = False,
    compute_std: bool = True,
    max_iterations: int = 500,
    threads: int = 0,
    names: Optional[Sequence[str]] = None,
    bootstrap: Optional[int] = None,
) -> CameraCalibration:
    """Calibrates one camera, like cv2.calibrateCamera (every point fitted unless
    ``reject_outliers``); ``bootstrap=N`` adds view-bootstrap sigmas (``bootstrap_std``).
    Raises CalibrationError, ValueError, TypeError."""

def compare_models(
    object_points: Iterable[Points],
    image_points: Iterable[Points],
    image_size: ImageSize,
    models: Union[None, ModelName, Iterable[ModelName]] = None,
    fix: Union[None, FixName, Iterable[FixName]] = None,
    *,
    K: Optional[npt.ArrayLike] = None,
    reject_outliers: bool = False,
    outlier_threshold: float = 5.0,
    loss: Loss = None,
    loss_scale: float = 1.0,
    rotation: Optional[Rotation] = None,
    skip_bad_views: bool = False,
    drop_duplicate_views: bool = False,
    max_iterations: int = 500,
    threads: int = 0,
    names: Optional[Sequence[str]] = None,
) -> ModelComparison:
    """Fits each lens model (default: the five of ``calib single --compare-models``),
    cross-validates it and recommends one; ``fix`` coefficient names are held in every model
    that has them. Needs 4 views or more. Raises CalibrationError (no model could be fitted),
    ValueError, TypeError."""

def stereo_calibrate(
    object_points: Iterable[Points],
    image_points1: Iterable[Points],
    image_points2: Iterable[Points],
    image_size: ImageSize,
    K1: Optional[npt.ArrayLike] = None,
    D1: Optional[npt.ArrayLike] = None,
    K2: Optional[npt.ArrayLike] = None,
    D2: Optional[npt.ArrayLike] = None,
    *,
    model: Optional[ModelName] = None,
    model2: Optional[ModelName] = None,
    fix: Union[None, FixName, Iterable[FixName]] = None,
    fix2: Union[None, FixName, Iterable[FixName]] = None,
    image_size2: Optional[ImageSize] = None,
    fix_intrinsics: bool = False,
    fix_intrinsics1: bool = False,
    fix_intrinsics2: bool = False,
    same_focal_length: bool = False,
    R: Optional[npt.ArrayLike] = None,
    T: Optional[npt.ArrayLike] = None,
    rig_init: Literal["least-squares", "median"] = "least-squares",
    reject_outliers: bool = False,
    outlier_threshold: float = 5.0,
    loss: Loss = None,
    loss_scale: float = 1.0,
    rotation: Optional[Rotation] = None,
    skip_bad_pairs: bool = False,
    max_iterations: int = 500,
    threads: int = 0,
    names: Optional[Sequence[str]] = None,
    bootstrap: Optional[int] = None,
) -> StereoCalibration:
    """Calibrates a stereo pair (both cameras, the rig, every pair's pose), like
    cv2.stereoCalibrate without CALIB_FIX_INTRINSIC; ``bootstrap=N`` adds pair-bootstrap
    sigmas (``bootstrap_std1``, ``bootstrap_std2``, ``bootstrap_rig_std``,
    ``bootstrap_baseline_std``)."""

def calibrate_rig(
    image_sizes: Sequence[ImageSize],
    object_points: Sequence[Optional[Points]],
    image_points: Sequence[
        Union[
            Mapping[Union[int, str], Union[Points, tuple[Points, Points], None]],
            Sequence[Union[Points, tuple[Points, Points], None]],
        ]
    ],
    models: Union[None, ModelName, Sequence[Optional[ModelName]]] = None,
    *,
    names: Optional[Sequence[str]] = None,
    reference: Union[None, int, str] = None,
    known: Optional[Mapping[Union[int, str], tuple[npt.ArrayLike, npt.ArrayLike]]] = None,
    fix: Union[None, FixName, Iterable[FixName]] = None,
    min_views: int = 3,
    reject_outliers: bool = False,
    outlier_threshold: float = 5.0,
    loss: Loss = None,
    loss_scale: float = 1.0,
    rotation: Optional[Rotation] = None,
    skip_bad_views: bool = False,
    max_iterations: int = 500,
    threads: int = 0,
) -> RigCalibration:
    """Calibrates a rig of N cameras, each seeing the board in some frames."""

@overload
def detect_chessboard(
    image: npt.NDArray[np.uint8],
    pattern_size: Sequence[int],
    *,
    dtype: None = None,
    raise_on_failure: bool = False,
) -> Optional[npt.NDArray[np.float32]]: ...
@overload
def detect_chessboard(
    image: npt.NDArray[np.uint8],
    pattern_size: Sequence[int],
    *,
    dtype: npt.DTypeLike,
    raise_on_failure: bool = False,
) -> Optional[npt.NDArray[Any]]: ...
def imread_gray(path: Union[str, PathLike[str]]) -> npt.NDArray[np.uint8]:
    """A JPEG or PNG file as 8-bit grey (H, W), as the calib command reads it. OSError
    (FileNotFoundError, ...) as open() raises it when the file cannot be read;
    CalibrationError when it is no JPEG or PNG, or corrupt."""

def board_points(
    pattern_size: Sequence[int], square: float = 1.0, *, dtype: Optional[npt.DTypeLike] = None
) -> npt.NDArray[Any]:
    """(c * square, r * square, 0) row-major, (N, 3), in detect_chessboard's order."""

def undistort_points(
    points: Points,
    K: npt.ArrayLike,
    dist: Optional[npt.ArrayLike] = None,
    *,
    model: Optional[ModelName] = None,
    R: Optional[npt.ArrayLike] = None,
    P: Optional[npt.ArrayLike] = None,
) -> npt.NDArray[np.float64]:
    """Ideal normalized coordinates (or pixels of P) of distorted pixels, like
    cv2.undistortPoints (dist None: no distortion; R a rotation matrix or vector); NaN where the
    model cannot be inverted."""

def project_points(
    object_points: Points,
    rvec: npt.ArrayLike,
    tvec: npt.ArrayLike,
    K: npt.ArrayLike,
    dist: Optional[npt.ArrayLike] = None,
    model: Optional[ModelName] = None,
) -> npt.NDArray[np.float64]:
    """Pixels (N, 2) of world points seen from the pose (rvec, tvec), like cv2.projectPoints and
    cv2.fisheye.projectPoints (dist None: no distortion; model None: from the coefficient count);
    ValueError naming the index of a point the model cannot project."""

def stereo_rectify(
    K1: npt.ArrayLike,
    D1: Optional[npt.ArrayLike],
    K2: npt.ArrayLike,
    D2: Optional[npt.ArrayLike],
    image_size: ImageSize,
    R: npt.ArrayLike,
    T: npt.ArrayLike,
    alpha: Optional[float] = -1.0,
    *,
    model: Optional[ModelName] = None,
    model2: Optional[ModelName] = None,
) -> tuple[
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    npt.NDArray[np.float64],
    tuple[int, int, int, int],
    tuple[int, int, int, int],
]:
    """Bouguet's stereo rectification like cv2.stereoRectify (CALIB_ZERO_DISPARITY), for every
    lens model: ``R1, R2`` (3, 3), ``P1, P2`` (3, 4), ``Q`` (4, 4) and the valid regions
    ``roi1, roi2`` as (x, y, width, height). ``alpha`` -1 or None is OpenCV's default scaling,
    0 to 1 the free scaling. Bit for bit the numbers of ``calib rectify``."""

ExportFormat = Literal["opencv", "ros", "kalibr"]

CalibrationDict = dict[str, Any]
"""What read_calibration returns. One camera: ``kind="single"``, ``name``, ``model``,
``image_size``, ``K`` (3, 3), ``dist`` (1, N). A stereo rig: ``kind="stereo"``, ``names``,
``models``, ``image_size``, ``image_size2``, ``K1``, ``D1``, ``K2``, ``D2``, ``R`` (3, 3),
``T`` (3, 1). A rig of N cameras: ``kind="rig"``, lists ``names``, ``models``, ``image_sizes``,
``Ks``, ``dists``, ``Rs``, ``Ts`` (``X_cam = R X_ref + T``) and ``reference`` (index)."""

def write_calibration(
    path: Union[str, PathLike[str]],
    calibration: Union[CameraCalibration, StereoCalibration, RigCalibration, Mapping[str, Any]],
    format: ExportFormat = "opencv",
    *,
    alpha: Optional[float] = 0.0,
    translation_scale: float = 1.0,
) -> list[str]:
    """Writes a calibration as OpenCV FileStorage, ROS camera_info (a stereo rig: STEM-left.EXT
    and STEM-right.EXT; a rig: STEM-NAME.EXT per camera) or Kalibr camchain YAML, like
    ``calib export``; returns the files written. OSError (FileNotFoundError, PermissionError,
    IsADirectoryError, ...) as open(path, "w") raises it when a file cannot be written;
    CalibrationError when the format cannot hold the calibration. An OpenCV stereo file whose
    rectification cannot be computed is written without R1 ... Q, with a UserWarning."""

def read_calibration(path: Union[str, PathLike[str]]) -> CalibrationDict:
    """Reads an OpenCV, ROS or Kalibr YAML file, or a calib single / stereo / rig result JSON
    (the kind is recognized from the content), as a dict (see CalibrationDict). A str that
    starts with '{' (a result's to_json()) or spans several lines is read as the text itself.
    OSError (FileNotFoundError, PermissionError, IsADirectoryError, ...) as open() raises it
    when the file cannot be read; CalibrationError when its content is wrong."""
