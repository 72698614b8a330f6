"""Typed use of the package, run by pytest and checked by mypy against the stubs
(gpu_amcs/_gpu_amcs.pyi; `.ci/run` runs `mypy --strict` on this file): what a type-checked
caller writes must pass, and a wrong argument type must be caught (the `type: ignore` lines
below are errors mypy has to find; `warn_unused_ignores` makes a stub that lets them through
fail)."""

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

import gpu_amcs
from gpu_amcs import Model, RunResult


def test_typed_calls() -> None:
    model: Model = Model.preset("tx60")
    q: NDArray[np.float64] = np.zeros((2, model.joints))
    one: NDArray[np.float64] = model.fk(q[0])  # one configuration: 3 coordinates
    assert one.shape == (3,)
    X = model.draws(20, seed=1)
    w: NDArray[np.float64] = model.max_error(X, q, backend="cpu")
    assert w.shape == (20,)
    res: RunResult = gpu_amcs.mcs(model, q_deg=q, draws=2000, thresholds=0.2, backend="cpu")
    estimate: float = res.estimate
    low, high = res.coverage_interval
    assert low <= estimate <= high
    doc = res.to_dict()
    assert doc["result"]["reliability"][0]["threshold"] == 0.2
    names: list[str] = gpu_amcs.presets()
    assert "tx60" in names


if TYPE_CHECKING:
    # Never run: mypy must report each of these (an unused ignore is an error).
    def _caught_by_the_stubs(model: Model) -> None:
        gpu_amcs.mcs(draws="many")  # type: ignore[arg-type]
        gpu_amcs.amcs(model, delta=0.01, no_such_keyword=1)  # type: ignore[call-arg]
        gpu_amcs.tail(model, backend="tpu")  # type: ignore[arg-type]
        model.fk([0.0] * 6, True)  # type: ignore[call-arg]
        x: str = model.joints  # type: ignore[assignment]
