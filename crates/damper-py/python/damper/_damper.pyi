"""Type stub of the native module ``damper._damper`` (checked by ``mypy.stubtest``)."""

from typing import Any, List, Optional, Sequence, Tuple, final

import numpy as np
import numpy.typing as npt

__all__ = [
    "ArgumentError",
    "DamperError",
    "DamperWarning",
    "MergeError",
    "ModelError",
    "NotAvailable",
    "NumericalError",
    "OptimizationError",
    "ResourceError",
    "ScenarioError",
    "SimulationError",
    "SingularPosition",
    "StructureParts",
    "UnknownName",
    "WorkLimitError",
    "check",
    "figures",
    "frf",
    "linearize",
    "model_eval",
    "model_generate",
    "model_info",
    "optimize",
    "random",
    "read_scenario",
    "simulate",
    "structure_from_matrices",
    "sweep_grid",
    "sweep_merge",
    "sweep_points",
    "sweep_shard",
]

_Sets = Sequence[Tuple[str, Any]]
_Columns = List[Tuple[str, Optional[str], Any]]
_Shapes = List[Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], List[str]]]

class ScenarioError(ValueError):
    file: Optional[str]
    line: Optional[int]
    column: Optional[int]
    entity: Optional[str]
    message: Optional[str]

class ModelError(ValueError):
    file: Optional[str]
    line: Optional[int]
    column: Optional[int]
    entity: Optional[str]
    message: Optional[str]

class DamperError(Exception): ...

class DamperWarning(UserWarning):
    file: Optional[str]
    entity: Optional[str]

class SingularPosition(DamperError):
    time: float
    distance: float
    reach: Optional[float]
    mechanism: str
    file: str

class ArgumentError(DamperError, ValueError):
    argument: str
    option: str
    message: str

class UnknownName(DamperError, ValueError):
    what: str
    name: str
    nearest: List[str]
    file: Optional[str]
    message: str

class NotAvailable(DamperError):
    file: Optional[str]
    message: str

class NumericalError(DamperError):
    file: Optional[str]
    message: str

class OptimizationError(DamperError):
    file: str
    evaluations: Optional[int]
    least_infeasible: Optional[str]
    message: str

class MergeError(DamperError):
    path: str
    message: str

class ResourceError(DamperError):
    message: str

class WorkLimitError(DamperError):
    message: str

class SimulationError(DamperError):
    file: str
    time: Optional[float]
    message: str

def read_scenario(path: str) -> str: ...
def check(text: str, file: str, base: str, sets: _Sets) -> str: ...
def simulate(
    text: str, file: str, base: str, sets: _Sets, allow_long: bool
) -> Tuple[Any, _Columns, List[Tuple[str, _Columns]], Optional[_Columns]]: ...
def linearize(
    text: str,
    file: str,
    base: str,
    sets: _Sets,
    modes: int,
    method: str,
    matrices: bool,
    allow_long: bool,
) -> Tuple[
    Any,
    _Shapes,
    Optional[_Shapes],
    Optional[_Shapes],
    Optional[
        Tuple[
            npt.NDArray[np.float64],
            npt.NDArray[np.float64],
            npt.NDArray[np.float64],
        ]
    ],
]: ...
def frf(
    text: str,
    file: str,
    base: str,
    sets: _Sets,
    output: str,
    f_from: float,
    f_to: float,
    points: int,
    log: bool,
    excitation: Optional[str],
    force: Optional[float],
    nonlinear: Optional[int],
    steps_per_period: int,
    tolerance: float,
    max_periods: int,
    allow_long: bool,
) -> Tuple[_Columns, Optional[_Columns], List[str]]: ...
def sweep_grid(
    text: str,
    file: str,
    base: str,
    sets: _Sets,
    axes: Sequence[Tuple[str, Any]],
    time_domain: bool,
    threads: Optional[int],
    allow_long: bool,
) -> _Columns: ...
def sweep_shard(
    text: str,
    file: str,
    base: str,
    sets: _Sets,
    axes: Sequence[Tuple[str, Any]],
    shard: int,
    shards: int,
    time_domain: bool,
    threads: Optional[int],
    allow_long: bool,
) -> str: ...
def sweep_merge(parts: Sequence[str], allow_long: bool) -> _Columns: ...
def sweep_points(axes: Sequence[Tuple[str, Any]], allow_long: bool) -> Tuple[List[str], List[List[Any]]]: ...
def optimize(
    text: str,
    file: str,
    base: str,
    sets: _Sets,
    vary: Sequence[str],
    objective: str,
    maximize: bool,
    constraints: Sequence[str],
    grid: int,
    allow_long: bool,
) -> Tuple[Any, _Columns]: ...
def figures(text: str, file: str, base: str, sets: _Sets) -> Any: ...
def random(
    text: str,
    file: str,
    base: str,
    sets: _Sets,
    outputs: Sequence[str],
    method: str,
    modes: int,
    allow_long: bool,
) -> Any: ...
@final
class StructureParts:
    @property
    def equations(self) -> int: ...
    @property
    def nodes(self) -> int: ...
    @property
    def nonzeros(self) -> Tuple[int, int]: ...
    @property
    def table(self) -> str: ...
    @property
    def name(self) -> str: ...

_Coo = Tuple[int, npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float64]]

def structure_from_matrices(
    name: str,
    m: _Coo,
    k: _Coo,
    c: Optional[_Coo],
    nodes: List[List[str]],
    dofs: List[List[str]],
    ratios: Optional[List[Tuple[int, float]]],
    modes: Optional[int],
) -> StructureParts: ...
def model_info(path: str) -> Tuple[str, List[str], List[Tuple[str, float, bool, bool]]]: ...
def model_eval(
    path: str, q: Sequence[float], qd: Sequence[float], t: float, backend: str, params: Sequence[str]
) -> Any: ...
def model_generate(path: str, struct_name: Optional[str]) -> Tuple[str, List[Tuple[str, List[int]]]]: ...
