"""Shared helpers: the command-line binary to compare against and JSON comparison without
timing fields. The independent NumPy forward kinematics is gpu_amcs.numpy_fk."""

import os
import pathlib
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


def cli_binary():
    """The built ``gpu-amcs`` binary: $GPU_AMCS_BIN, else <target>/release/gpu-amcs."""
    env = os.environ.get("GPU_AMCS_BIN")
    if env:
        return pathlib.Path(env)
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    return target / "release" / "gpu-amcs"


@pytest.fixture(scope="session")
def cli():
    """Runs the command line; returns the CompletedProcess. Missing binary: a failure in CI
    (where `cargo test --release` built it), a skip elsewhere."""
    exe = cli_binary()
    if not exe.exists():
        msg = f"{exe} not built (cargo build --release, or set GPU_AMCS_BIN)"
        if os.environ.get("CI"):
            pytest.fail(msg)
        pytest.skip(msg)

    def run(*args):
        return subprocess.run(
            [str(exe), *map(str, args)], capture_output=True, text=True, timeout=600
        )

    return run


def without_timing(doc):
    """The JSON document with its timing fields (`seconds`) removed, recursively."""
    if isinstance(doc, dict):
        return {k: without_timing(v) for k, v in doc.items() if k != "seconds"}
    if isinstance(doc, list):
        return [without_timing(v) for v in doc]
    return doc
