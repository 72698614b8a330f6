"""Shared helpers: the command-line binary to compare against and JSON comparison without
timing fields. The independent NumPy forward kinematics is gpu_amcs.numpy_fk."""

import os
import pathlib
import subprocess

import pytest

import gpu_amcs

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


def is_timing(key):
    """Whether a JSON key is a wall-clock time (`seconds`, `ik_seconds`, …)."""
    return key == "seconds" or key.endswith("_seconds")


def without_timing(doc):
    """The JSON document with its timing fields (`seconds`, `*_seconds`) removed, recursively."""
    if isinstance(doc, dict):
        return {k: without_timing(v) for k, v in doc.items() if not is_timing(k)}
    if isinstance(doc, list):
        return [without_timing(v) for v in doc]
    return doc


def with_tool_sigma(model, tool_sigma, covariance=None):
    """``model`` with the model file's ``tool_sigma`` (mm) set, and optionally a
    ``[covariance]`` matrix (file units; 30 × 30 or 33 × 33), through the model file text, so
    the model is exactly what ``gpu-amcs --model`` reads from that text."""
    text = model.to_toml()
    lines = text.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("tool = ["))
    lines.insert(at + 1, "tool_sigma = [" + ", ".join(repr(float(s)) for s in tool_sigma) + "]")
    if covariance is not None:
        lines.append("[covariance]")
        lines.append("matrix = [")
        lines += ["  [" + ", ".join(repr(float(v)) for v in row) + "]," for row in covariance]
        lines.append("]")
    return gpu_amcs.Model.from_toml("\n".join(lines) + "\n", "tool-sigma model")
