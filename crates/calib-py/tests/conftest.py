"""Shared helpers of the Python tests: the bundled data, and the `calib` command whose JSON
results the bindings must reproduce bit for bit.

The command is found through the environment variable CALIB_BIN (CI sets it to the binary
`cargo test --workspace` built); otherwise target/{release,debug}/calib under CARGO_TARGET_DIR or
the repository is used if present, and the comparisons are skipped if none exists (build it with
`cargo build --release -p calib-cli`).
"""

import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[3]
DATA = ROOT / "data"


def load(name):
    """A bundled observation file, e.g. "sourishg1/left.json", as a dict."""
    with open(DATA / name) as f:
        return json.load(f)


def single_arrays(name, dtype=np.float64):
    """(object_points, image_points, image_size) of a single-camera file, float64 by default
    (Python's float parsing is correctly rounded, like the Rust reader: the same doubles)."""
    d = load(name)
    obj = [np.array(v["object_points"], dtype=dtype) for v in d["views"]]
    img = [np.array(v["image_points"], dtype=dtype) for v in d["views"]]
    return obj, img, tuple(d["image_size"])


def _find_calib():
    env = os.environ.get("CALIB_BIN")
    if env:
        path = pathlib.Path(env)
        if not path.is_file():
            raise RuntimeError(f"CALIB_BIN={env} does not exist")
        return path
    dirs = []
    if os.environ.get("CARGO_TARGET_DIR"):
        dirs.append(pathlib.Path(os.environ["CARGO_TARGET_DIR"]))
    dirs.append(ROOT / "target")
    for d in dirs:
        for profile in ("release", "debug"):
            p = d / profile / "calib"
            if p.is_file():
                return p
    return None


CALIB = _find_calib()


@pytest.fixture
def calib_cli(tmp_path):
    """Runs `calib ARGS... -o FILE` and returns the JSON it wrote."""
    if CALIB is None:
        pytest.skip("no calib binary: set CALIB_BIN or run cargo build --release -p calib-cli")

    def run(*args):
        out = tmp_path / "result.json"
        subprocess.run(
            [str(CALIB), *map(str, args), "-q", "-o", str(out)],
            check=True,
            cwd=ROOT,
        )
        with open(out) as f:
            return json.load(f)

    return run


# Keys that differ between two runs of the same calibration (wall times) or that name the input
# (the command names views after the image files, the bindings "view 0", ...).
VOLATILE = {
    "elapsed_seconds",
    "elapsed_seconds_all",
    "stage_seconds",
    "evaluate_time",
    "solve_time",
    "total_time",
    "evaluate_seconds",
    "solve_seconds",
    "total_seconds",
    "image",
    "left_image",
    "right_image",
    "name",
}


def strip(value):
    """A JSON value without the volatile keys, for exact comparison."""
    if isinstance(value, dict):
        return {k: strip(v) for k, v in value.items() if k not in VOLATILE}
    if isinstance(value, list):
        return [strip(v) for v in value]
    return value
