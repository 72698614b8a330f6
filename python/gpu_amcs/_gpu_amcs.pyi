# Type stubs of the extension module gpu_amcs._gpu_amcs (python/src/*.rs), re-exported by the
# package gpu_amcs. Checked against the built module by `python -m mypy.stubtest` in .ci/run;
# keep the names, keyword kinds and defaults as the Rust signatures give them.

import os
from typing import Any, Literal, Sequence, final

import numpy as np
from numpy.typing import ArrayLike, NDArray

_Path = str | os.PathLike[str]
# A number or a 1-D sequence/array of numbers (mm): one threshold or several.
_Thresholds = float | Sequence[float] | ArrayLike
# A size in bytes, or a string such as "500M" or "2GiB".
_MemoryLimit = int | str
_Backend = Literal["auto", "cpu", "gpu"]
_Reference = Literal["calibrated", "nominal"]
_Frame = Literal["measurement", "base"]
_Triple = Sequence[float] | ArrayLike

__all__ = [
    "__version__", "N_PARAMS", "N_UNCERTAIN", "Model", "RunResult", "CompareResult", "mcs", "amcs", "compare",
    "SensitivityResult", "TailResult", "MapResult",
    "sensitivity", "tail", "PlanResult", "plan", "map", "IdentifyResult", "identify",
    "ValidationResult", "validate", "adapters", "presets",
]

__version__: str
N_PARAMS: int
N_UNCERTAIN: int

@final
class Model:
    @staticmethod
    def preset(name: str) -> Model: ...
    @staticmethod
    def from_file(path: _Path) -> Model: ...
    @staticmethod
    def from_toml(text: str, origin: str = "<string>") -> Model: ...
    @staticmethod
    def from_urdf(
        path: _Path,
        base: str | None = None,
        tip: str | None = None,
        name: str | None = None,
        packages: dict[str, _Path] | None = None,
        xacro_args: dict[str, str] | None = None,
        hold_joints: dict[str, float] | None = None,
    ) -> Model: ...
    def to_toml(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def joints(self) -> int: ...
    @property
    def param_names(self) -> list[str]: ...
    @property
    def params(self) -> NDArray[np.float64]: ...
    @property
    def sigma(self) -> NDArray[np.float64]: ...
    @property
    def covariance(self) -> NDArray[np.float64] | None: ...
    @property
    def covariance_blocks(self) -> list[str] | None: ...
    @property
    def discrepancy(self) -> dict[str, Any] | None: ...
    @property
    def discrepancy_sides_unknown(self) -> dict[str, Any] | None: ...
    @property
    def free(self) -> list[int]: ...
    @property
    def tool(self) -> NDArray[np.float64]: ...
    @property
    def limits(self) -> NDArray[np.float64]: ...
    def fk(self, q_deg: ArrayLike, *, compensation: bool = True) -> NDArray[np.float64]: ...
    def max_error(
        self,
        params: ArrayLike,
        q_deg: ArrayLike,
        *,
        reference: _Reference = "calibrated",
        nominal: Model | None = None,
        per_point: bool = False,
        backend: _Backend = "auto",
        columns: Sequence[int | str] | None = None,
        offsets: bool = False,
        memory_limit: _MemoryLimit | None = None,
    ) -> NDArray[np.float64]: ...
    def draws(
        self, n: int, *, seed: int = 2025, first: int = 0, memory_limit: _MemoryLimit | None = None
    ) -> NDArray[np.float64]: ...
    def salib_problem(self, inputs: Sequence[int | str] | None = None) -> dict[str, Any]: ...
    def openturns_function(
        self, q_deg: ArrayLike, columns: Sequence[int | str] | None = None, **kwargs: Any
    ) -> Any: ...

class _Report:
    """The output methods every result class shares (not a runtime class)."""

    def to_json(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    def to_csv(self, table: str | None = None) -> str: ...
    def to_pandas(self, table: str | None = None) -> Any: ...
    def to_svg(self, figure: str | None = None) -> str: ...
    def files(self) -> dict[str, str]: ...

@final
class RunResult(_Report):
    @property
    def values(self) -> NDArray[np.float64]: ...
    @property
    def estimate(self) -> float: ...
    @property
    def std_uncertainty(self) -> float: ...
    @property
    def coverage_interval(self) -> tuple[float, float]: ...
    @property
    def draws(self) -> int: ...
    @property
    def converged(self) -> bool: ...
    @property
    def notes(self) -> list[str]: ...
    def to_text(self) -> str: ...

@final
class CompareResult(_Report):
    def to_markdown(self) -> str: ...
    @property
    def mcs_draws(self) -> int: ...
    @property
    def amcs(self) -> list[tuple[float, int, float]]: ...
    @property
    def notes(self) -> list[str]: ...
    def to_text(self) -> str: ...

@final
class SensitivityResult(_Report):
    @property
    def first_order(self) -> list[tuple[str, float]]: ...
    @property
    def total(self) -> list[tuple[str, float]]: ...
    @property
    def notes(self) -> list[str]: ...
    def to_text(self) -> str: ...

@final
class TailResult(_Report):
    @property
    def thresholds(self) -> list[float]: ...
    @property
    def p_f(self) -> list[float]: ...
    @property
    def beta(self) -> list[float | None]: ...
    @property
    def evaluations(self) -> int: ...
    @property
    def notes(self) -> list[str]: ...
    def to_text(self) -> str: ...

@final
class MapResult(_Report):
    @property
    def reached(self) -> int: ...
    @property
    def cells(self) -> int: ...
    @property
    def reliability(self) -> list[tuple[float, float]]: ...
    @property
    def notes(self) -> list[str]: ...
    def to_text(self) -> str: ...

@final
class PlanResult(_Report):
    def design_csv(self) -> str: ...
    @property
    def design(self) -> list[list[float]]: ...
    @property
    def reliability(self) -> list[tuple[float, float]]: ...
    def program(self, language: str, name: str = "calibration", settle: float = 2.0) -> str: ...
    @property
    def notes(self) -> list[str]: ...
    def to_text(self) -> str: ...

@final
class IdentifyResult(_Report):
    @property
    def model(self) -> Model: ...
    @property
    def models(self) -> list[Model]: ...
    @property
    def warnings(self) -> list[str]: ...
    def to_text(self, verbose: bool = False) -> str: ...
    def to_toml(self) -> str: ...

@final
class ValidationResult:
    def to_text(self) -> str: ...
    def to_json(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    @property
    def term_model(self) -> Model | None: ...
    @property
    def frame(self) -> str: ...

def mcs(
    model: Model | None = None,
    *,
    draws: int = 1000000,
    coverage: float = 0.95,
    interval: Literal["shortest", "symmetric"] = "shortest",
    thresholds: _Thresholds | None = ...,
    per_point: bool = False,
    preset: str | None = None,
    points: int = 50,
    q_deg: ArrayLike | None = None,
    points_file: _Path | None = None,
    points_seed: int = 1,
    box_center: _Triple | None = None,
    box_size: _Triple | None = None,
    seed: int = 2025,
    reference: _Reference = "calibrated",
    nominal: Model | None = None,
    backend: _Backend = "auto",
    adapter: str | None = None,
    memory_limit: _MemoryLimit | None = None,
    frame: _Frame = "measurement",
    discrepancy: bool = True,
    payload_kg: float | None = None,
    payload_sigma_kg: float = 0.0,
    payload_com: tuple[float, float, float] | None = None,
    sides: ArrayLike | None = None,
) -> RunResult: ...
def amcs(
    model: Model | None = None,
    *,
    delta: float | None = None,
    ndig: int | None = None,
    batch: int = 10000,
    max_draws: int = 10000000,
    coverage: float = 0.95,
    interval: Literal["shortest", "symmetric"] = "shortest",
    thresholds: _Thresholds | None = ...,
    per_point: bool = False,
    preset: str | None = None,
    points: int = 50,
    q_deg: ArrayLike | None = None,
    points_file: _Path | None = None,
    points_seed: int = 1,
    box_center: _Triple | None = None,
    box_size: _Triple | None = None,
    seed: int = 2025,
    reference: _Reference = "calibrated",
    nominal: Model | None = None,
    backend: _Backend = "auto",
    adapter: str | None = None,
    memory_limit: _MemoryLimit | None = None,
    frame: _Frame = "measurement",
    discrepancy: bool = True,
    payload_kg: float | None = None,
    payload_sigma_kg: float = 0.0,
    payload_com: tuple[float, float, float] | None = None,
    sides: ArrayLike | None = None,
) -> RunResult: ...
def compare(
    model: Model | None = None,
    *,
    draws: int = 1000000,
    deltas: _Thresholds | None = ...,
    batch: int = 10000,
    coverage: float = 0.95,
    preset: str | None = None,
    points: int = 50,
    q_deg: ArrayLike | None = None,
    points_file: _Path | None = None,
    points_seed: int = 1,
    box_center: _Triple | None = None,
    box_size: _Triple | None = None,
    seed: int = 2025,
    reference: _Reference = "calibrated",
    nominal: Model | None = None,
    backend: _Backend = "auto",
    adapter: str | None = None,
    memory_limit: _MemoryLimit | None = None,
    frame: _Frame = "measurement",
    discrepancy: bool = True,
    payload_kg: float | None = None,
    payload_sigma_kg: float = 0.0,
    payload_com: tuple[float, float, float] | None = None,
    sides: ArrayLike | None = None,
) -> CompareResult: ...
def sensitivity(
    model: Model | None = None,
    *,
    draws: int = 8192,
    bootstrap: int = 300,
    bootstrap_seed: int = 1,
    thresholds: _Thresholds | None = ...,
    preset: str | None = None,
    points: int = 50,
    q_deg: ArrayLike | None = None,
    points_file: _Path | None = None,
    points_seed: int = 1,
    box_center: _Triple | None = None,
    box_size: _Triple | None = None,
    seed: int = 2025,
    reference: _Reference = "calibrated",
    nominal: Model | None = None,
    backend: _Backend = "auto",
    adapter: str | None = None,
    memory_limit: _MemoryLimit | None = None,
    frame: _Frame = "measurement",
    discrepancy: bool = True,
    payload_kg: float | None = None,
    payload_sigma_kg: float = 0.0,
    payload_com: tuple[float, float, float] | None = None,
    sides: ArrayLike | None = None,
) -> SensitivityResult: ...
def tail(
    model: Model | None = None,
    *,
    threshold: _Thresholds | None = None,
    cov: float = 0.1,
    method: Literal["subset", "mc"] = "subset",
    max_evaluations: int = 5000000,
    samples_per_level: int = 1000,
    p0: float = 0.1,
    preset: str | None = None,
    points: int = 50,
    q_deg: ArrayLike | None = None,
    points_file: _Path | None = None,
    points_seed: int = 1,
    box_center: _Triple | None = None,
    box_size: _Triple | None = None,
    seed: int = 2025,
    reference: _Reference = "calibrated",
    nominal: Model | None = None,
    backend: _Backend = "auto",
    adapter: str | None = None,
    memory_limit: _MemoryLimit | None = None,
    frame: _Frame = "measurement",
    discrepancy: bool = True,
    payload_kg: float | None = None,
    payload_sigma_kg: float = 0.0,
    payload_com: tuple[float, float, float] | None = None,
    sides: ArrayLike | None = None,
) -> TailResult: ...
def map(
    model: Model | None = None,
    *,
    preset: str | None = None,
    box_center: _Triple | None = None,
    box_size: _Triple | None = None,
    plane: Literal["xy", "xz", "yz"] | None = None,
    at: float | None = None,
    cells: Sequence[int] | None = None,
    orientation: _Triple | None = None,
    free_orientation: bool = False,
    reference_q: Sequence[float] | ArrayLike | None = None,
    ik_seeds: int = 0,
    draws: int = 10000,
    thresholds: _Thresholds | None = ...,
    seed: int = 2025,
    backend: _Backend = "auto",
    adapter: str | None = None,
    memory_limit: _MemoryLimit | None = None,
) -> MapResult: ...
def plan(
    model: Model | None = None,
    *,
    poses: int = 30,
    tracker_sigma: float = 0.01,
    tracker_at: _Triple | None = None,
    tracker_range: float = 20000.0,
    max_incidence: float = 60.0,
    target: _Triple | None = None,
    threshold: _Thresholds | None = ...,
    candidates: int = 2000,
    draws: int = 100000,
    floor: float | None = None,
    keep_out: Sequence[Sequence[float]] = ...,
    self_collision: bool = True,
    link_radius: float | None = None,
    approach: Literal["positive", "negative"] | None = None,
    preset: str | None = None,
    points: int = 50,
    q_deg: ArrayLike | None = None,
    points_file: _Path | None = None,
    points_seed: int = 1,
    box_center: _Triple | None = None,
    box_size: _Triple | None = None,
    seed: int = 2025,
    reference: _Reference = "calibrated",
    nominal: Model | None = None,
    backend: _Backend = "auto",
    adapter: str | None = None,
    memory_limit: _MemoryLimit | None = None,
    frame: _Frame = "measurement",
    discrepancy: bool = True,
    payload_kg: float | None = None,
    payload_sigma_kg: float = 0.0,
    payload_com: tuple[float, float, float] | None = None,
    sides: ArrayLike | None = None,
) -> PlanResult: ...
def identify(
    data: _Path,
    *,
    nominal: Model | _Path | None = None,
    preset: str = "tx60",
    base_known: bool = False,
    fix: Sequence[str] | None = None,
    tracker_sigma: float | None = None,
    tracker_mpe: Sequence[float] | None = None,
    tracker_at: _Triple | None = None,
    uncertainty: Literal["linearised", "linearized", "montecarlo", "monte-carlo", "monte_carlo"] = "linearised",
    mc_draws: int = 200,
    seed: int = 1,
    fit: Literal["commanded", "point-cloud", "point_cloud"] = "commanded",
    no_prior: bool = False,
    no_refine: bool = False,
    covariance: bool = False,
    strict: bool = False,
    no_compensation: bool = False,
    beyond_geometry: bool | str | None = None,
    harmonic_orders: Sequence[int] | None = None,
    columns: str | None = None,
    delimiter: str | None = None,
) -> IdentifyResult: ...
def validate(
    model: Model | _Path,
    measured: _Path,
    *,
    nominal: bool | Model | _Path | None = None,
    preset: str | None = None,
    frame: _Frame | None = None,
    check_draws: int = 20000,
    seed: int = 2025,
    term: bool = False,
) -> ValidationResult: ...
def adapters() -> list[str]: ...
def presets() -> list[str]: ...
