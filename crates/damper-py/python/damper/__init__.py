"""Design electromagnetic vibration dampers from Python.

The whole ``damper`` tool as a library: scenarios loaded by the tool's one loader (with the
command line's ``--set`` overrides), simulations whose time histories are numpy arrays (the
columns of the CSV the command writes, same names, same numbers), the summary as the
``summary.json`` object, the linearisation with its modes and reduced matrices, frequency
responses, sweeps, the optimiser, and mechanism models evaluated by the three backends.
Results are typed (``results``): tables of named columns with their units as metadata,
``to_pandas()``, notebook representations and matplotlib plots; they pickle, and a sweep
splits into shards (``Scenario.sweep_shard``, ``merge_sweep``) for a distributed engine.

Example::

    import damper
    sc = damper.Scenario.load("scenarios/damper.toml", set={"integrator.t_end": 1.0})
    run = sc.simulate()
    t, w = run["t"], run[run.columns[1]]      # by name; run.units["t"] == "s"
    print(run.summary["damping_ratio"])
    sweep = sc.sweep({"mechanism.half_angle_deg": "3:25:23"})
    sweep["linear.zeta1"], sweep.units["linear.zeta1"]

Errors: ``ScenarioError`` / ``ModelError`` (subclasses of ``ValueError``) carry ``file``,
``line``, ``column``, ``entity`` and ``message``; a run stopped at the singular (toggle)
position raises ``SingularPosition`` (``time``, ``distance``); other failures raise a
subclass of ``DamperError`` with the fields of its kind: ``ArgumentError`` (``argument``,
``option``) and ``UnknownName`` (``what``, ``name``, ``nearest``, ``file``), both also
``ValueError``; ``NotAvailable``, ``NumericalError`` (``file``), ``OptimizationError``
(``file``, ``evaluations``, ``least_infeasible``), ``MergeError`` (``path``),
``ResourceError``, ``WorkLimitError`` (``allow_long=True`` insists), ``SimulationError``
(``file``, ``time``); each carries ``message``. An argument of the wrong type raises
``TypeError``. A warning about a result
that is still computed (the command line's ``warning:`` lines, e.g. a frequency response whose
largest value is at an edge of the band) is issued with ``warnings.warn`` as a
``DamperWarning`` (a ``UserWarning``) carrying ``file`` and ``entity``. The exceptions pickle
with their attributes (``multiprocessing`` shows a worker's own exception). Long calls
release the GIL; Ctrl-C stops the call of the main thread (``KeyboardInterrupt``), calls of
other threads run to their end.
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Iterable, Iterator, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _damper
from ._damper import DamperError, DamperWarning, ModelError, ScenarioError, SingularPosition
from ._damper import (  # the typed failures, subclasses of DamperError
    ArgumentError,
    MergeError,
    NotAvailable,
    NumericalError,
    OptimizationError,
    ResourceError,
    SimulationError,
    UnknownName,
    WorkLimitError,
)
from .results import FrfResult, Optimum, RandomResult, Run, SweepResult, Table, _equal

__all__ = [
    "DamperError",
    "DamperWarning",
    "FrfResult",
    "Linearization",
    "Mode",
    "Model",
    "ModelError",
    "Optimum",
    "RandomResult",
    "Run",
    "Scenario",
    "Structure",
    "ScenarioError",
    "SingularPosition",
    "SweepPart",
    "SweepResult",
    "Table",
    "merge_sweep",
]
__all__ += [
    "ArgumentError",
    "MergeError",
    "NotAvailable",
    "NumericalError",
    "OptimizationError",
    "ResourceError",
    "SimulationError",
    "UnknownName",
    "WorkLimitError",
]

PathLike = Union[str, "os.PathLike[str]"]
SetValue = Union[bool, int, float, str, Sequence[Any]]


def _items(value: Any, what: str) -> List[Tuple[str, Any]]:
    """The ``(key, value)`` pairs of a mapping argument (``TypeError`` for anything else)."""
    if value is None:
        return []
    if not isinstance(value, Mapping):
        raise TypeError(f"{what} must be a mapping (a dict), not {type(value).__name__}")
    items = list(value.items())
    for key, _ in items:
        if not isinstance(key, str):
            raise TypeError(f"{what}: keys must be str, not {type(key).__name__} ({key!r})")
    return items


def _names(value: Any, what: str) -> List[str]:
    """A list of names: one ``str`` is one name (never its characters); else a sequence of
    ``str`` (``TypeError`` for anything else)."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, (bytes, bytearray)) or isinstance(value, Mapping) or not isinstance(value, Iterable):
        raise TypeError(f"{what} must be a str or a list of str, not {type(value).__name__}")
    names = list(value)
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"{what}: every name must be a str, not {type(name).__name__} ({name!r})")
    return names


def _floats(value: Any, what: str) -> List[float]:
    """A vector of real numbers (``TypeError`` for ``str``, ``bytes``, complex values)."""
    if isinstance(value, (str, bytes, bytearray)) or isinstance(value, Mapping) or not isinstance(value, Iterable):
        raise TypeError(f"{what} must be a sequence of real numbers, not {type(value).__name__}")
    out = []
    for x in value:
        if isinstance(x, (bool, np.bool_)) or not isinstance(x, (int, float, np.integer, np.floating)):
            raise TypeError(f"{what}: {x!r} is not a real number")
        out.append(float(x))
    return out


def _real(value: Any, what: str) -> float:
    """One real number (``TypeError`` for anything else, complex values included)."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{what} must be a real number, not {type(value).__name__} ({value!r})")
    return float(value)


class Mode:
    """One mode of the linearised system, as ``damper linearize --json`` reports it.

    ``beam_shape``: the beam's transverse deflection at every node, an ``(nodes, 3)`` array of
    ``[x (m), re, im]`` normalised to a largest entry 1; ``mechanism_shape``: an
    ``(coordinates, 2)`` array ``[re, im]`` of every mechanism coordinate, named in
    ``mechanism_coordinates`` (``"mechanism/coordinate"``).
    """

    def __init__(
        self,
        report: Dict[str, Any],
        beam_shape: "np.ndarray",
        mechanism_shape: "np.ndarray",
        mechanism_coordinates: List[str],
    ) -> None:
        self.index: int = report["index"]
        self.kind: str = report["kind"]
        self.eigenvalue: complex = complex(*report["eigenvalue"])
        self.natural_frequency_hz: float = report["natural_frequency_hz"]
        self.damped_frequency_hz: float = report["damped_frequency_hz"]
        self.damping_ratio: float = report["damping_ratio"]
        self.decay_rate: float = report["decay_rate"]
        self.backward_error: float = report["backward_error"]
        self.beam_shape: np.ndarray = beam_shape
        self.mechanism_shape: np.ndarray = mechanism_shape
        self.mechanism_coordinates: List[str] = mechanism_coordinates

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Mode):
            return NotImplemented
        return _equal(self.__dict__, other.__dict__)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return (
            f"Mode({self.index}, {self.kind}, f_n={self.natural_frequency_hz:.6g} Hz, "
            f"zeta={self.damping_ratio:.6g})"
        )


def _modes(reports: Optional[List[Dict[str, Any]]], shapes: Optional[List[Any]]) -> Optional[List[Mode]]:
    if reports is None or shapes is None:
        return None
    return [Mode(r, b, m, names) for r, (b, m, names) in zip(reports, shapes)]


class Linearization:
    """The scenario linearised about its static equilibrium (``damper linearize``).

    ``modes`` (generator connected), ``generator_disconnected``, ``bare_beam`` and
    ``bare_structure`` (``None`` where the scenario has no generator, no mechanism, or its
    host is not a beam, respectively an imported structure) are lists of ``Mode``;
    ``equilibrium`` and ``amplification`` are the report's objects; ``M_R``, ``C_R``, ``K_R``
    the reduced mass, damping and stiffness matrices as dense arrays when asked for
    (``Scenario.linearize(matrices=True)``), else ``None``; ``report`` the whole JSON object
    of ``damper linearize --json``.
    """

    def __init__(self, raw: Tuple[Any, ...]) -> None:
        report, with_gen, off, bare, dense = raw
        m, c, k = dense if dense is not None else (None, None, None)
        self.report: Dict[str, Any] = report
        self.modes: List[Mode] = _modes(report["modes"], with_gen) or []
        self.generator_disconnected: Optional[List[Mode]] = _modes(report.get("generator_disconnected"), off)
        self.bare_beam: Optional[List[Mode]] = _modes(report.get("bare_beam"), bare)
        self.bare_structure: Optional[List[Mode]] = _modes(report.get("bare_structure"), bare)
        self.equilibrium: Dict[str, Any] = report["equilibrium"]
        self.amplification: List[Dict[str, Any]] = report["amplification"]
        self.M_R: Optional[np.ndarray] = m
        self.C_R: Optional[np.ndarray] = c
        self.K_R: Optional[np.ndarray] = k

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Linearization):
            return NotImplemented
        return _equal(self.__dict__, other.__dict__)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        size = "" if self.M_R is None else f", {self.M_R.shape[0]} coordinates"
        return f"Linearization({len(self.modes)} modes{size})"


_Coo = Tuple[int, Any, Any, Any]


def _coo(a: Any, what: str) -> _Coo:
    """A square matrix (numpy array, nested lists, or anything with ``tocoo()``: scipy.sparse)
    as ``(n, rows, columns, values)``, 0-based int64 indices and float64 values."""
    if hasattr(a, "tocoo"):
        c = a.tocoo()
        shape = tuple(c.shape)
        rows, cols, vals = c.row, c.col, c.data
    else:
        arr = np.asarray(a)
        if arr.dtype.kind not in "biuf":
            raise TypeError(f"{what}: a real matrix is needed, not an array of {arr.dtype}")
        shape = arr.shape
        if arr.ndim != 2:
            raise ValueError(f"{what}: a square matrix is needed, not an array of shape {shape}")
        rows, cols = np.nonzero(arr)
        vals = arr[rows, cols]
    if len(shape) != 2 or shape[0] != shape[1] or shape[0] == 0:
        raise ValueError(f"{what}: a square matrix of at least one row is needed, not shape {shape}")
    if np.asarray(vals).dtype.kind not in "biuf":
        raise TypeError(f"{what}: a real matrix is needed, not values of {np.asarray(vals).dtype}")
    return (
        int(shape[0]),
        np.ascontiguousarray(rows, dtype=np.int64),
        np.ascontiguousarray(cols, dtype=np.int64),
        np.ascontiguousarray(vals, dtype=np.float64),
    )


def _cell(v: Any) -> str:
    """A table cell as the CSV readers see it: an integral number as an integer, a float
    in its shortest round-trip form, anything else as ``str``."""
    if isinstance(v, (bool, np.bool_)):
        return str(v)
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        f = float(v)
        return str(int(f)) if f.is_integer() and abs(f) < 2**53 else repr(f)
    return str(v)


def _rows(table: Any, what: str) -> List[List[str]]:
    """Rows of a table (a 2-D array or a sequence of sequences) as texts."""
    if isinstance(table, (str, bytes)) or not hasattr(table, "__iter__"):
        raise TypeError(f"{what}: rows are needed (a 2-D array or a list of lists), not {type(table).__name__}")
    out = []
    for r in table:
        if isinstance(r, (str, bytes)) or not hasattr(r, "__iter__"):
            raise TypeError(f"{what}: each row must be a sequence, not {type(r).__name__}")
        out.append([_cell(v) for v in r])
    return out


class Structure:
    """A structure from another finite-element program given in memory (no files): its
    mass and stiffness matrices (supports eliminated), where its nodes are and which
    equation is which node's DOF — what a ``[structure] kind = "matrices"`` table reads
    from files, checked by the same rules (``ScenarioError`` naming the argument and row).

    Use it in place of a scenario's ``[structure]``: ``Scenario.load(path,
    structure=s)`` or ``scenario.with_structure(s)``. It pickles (its arrays with it).
    """

    def __init__(self, state: Tuple[Any, ...]) -> None:
        self._state = state
        name, m, k, c, nodes, dofs, ratios, modes = state
        self._native = _damper.structure_from_matrices(name, m, k, c, nodes, dofs, ratios, modes)

    @classmethod
    def from_matrices(
        cls,
        M: Any,
        K: Any,
        nodes: Any,
        dofs: Any,
        damping: Any = None,
        reduction: Optional[Mapping[str, Any]] = None,
        name: str = "Structure.from_matrices",
    ) -> "Structure":
        """A structure from its matrices and tables.

        ``M``, ``K``: square symmetric matrices (numpy arrays or scipy.sparse, both
        triangles; symmetric to 1e-12 of the largest entry), rows and columns the
        equations; ``nodes``: rows ``[id, x, y]`` or ``[id, x, y, z]`` (a 2-D array or a
        list), or a mapping ``{id: (x, y[, z])}``; ``dofs``: rows ``[eq, node, dof]``
        (``eq`` the 0-based equation, ``dof`` one of ``ux uy uz rx ry rz``), every
        equation once; ``damping``: ``None`` (undamped), Rayleigh damping from two modal
        ratios ``{"ratios": [(1, 0.003), (2, 0.003)]}`` (1-based modes), or a damping
        matrix ``C`` like ``M``; ``reduction``: ``None`` (the full model runs) or
        ``{"kind": "craig_bampton", "modes": 30}``; ``name`` names it in messages.
        """
        if isinstance(nodes, Mapping):
            nodes = [[i, *xy] for i, xy in nodes.items()]
        ratios = None
        c = None
        if isinstance(damping, Mapping):
            if set(damping) != {"ratios"}:
                raise ValueError(f"damping: expected {{'ratios': [(mode, ratio), (mode, ratio)]}} or a matrix, not keys {sorted(damping)}")
            ratios = []
            for r in damping["ratios"]:
                if isinstance(r, Mapping):
                    r = (r.get("mode"), r.get("ratio"))
                mode, ratio = r
                if not isinstance(mode, (int, np.integer)) or isinstance(mode, bool):
                    raise TypeError(f"damping: a mode number must be an int, not {type(mode).__name__}")
                ratios.append((int(mode), _real(ratio, "damping ratio")))
        elif damping is not None:
            c = _coo(damping, f"{name}: C")
        modes = None
        if reduction is not None:
            if not isinstance(reduction, Mapping) or reduction.get("kind") != "craig_bampton" or set(reduction) != {"kind", "modes"}:
                raise ValueError("reduction: expected {'kind': 'craig_bampton', 'modes': N}")
            m = reduction["modes"]
            if not isinstance(m, (int, np.integer)) or isinstance(m, bool):
                raise TypeError(f"reduction: modes must be an int, not {type(m).__name__}")
            modes = int(m)
        state = (
            name,
            _coo(M, f"{name}: M"),
            _coo(K, f"{name}: K"),
            c,
            _rows(nodes, f"{name}: nodes"),
            _rows(dofs, f"{name}: dofs"),
            ratios,
            modes,
        )
        return cls(state)

    @property
    def equations(self) -> int:
        """Number of equations (rows of the matrices)."""
        return int(self._native.equations)

    @property
    def table(self) -> str:
        """The ``[structure]`` table it stands for, as TOML (``kind = "given"``)."""
        return str(self._native.table)

    def __reduce__(self) -> Tuple[Any, Tuple[Any, ...]]:
        return (Structure, (self._state,))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Structure):
            return NotImplemented
        return _equal(self._state, other._state)

    def __repr__(self) -> str:
        return f"Structure({self._state[0]!r}, {self.equations} equations, {len(self._state[4])} nodes)"


def _host(structure: Optional[Structure]) -> List[Tuple[str, Any]]:
    """The override that makes ``structure`` the host (none for ``None``)."""
    if structure is None:
        return []
    if not isinstance(structure, Structure):
        raise TypeError(f"structure must be a damper.Structure (Structure.from_matrices), not {type(structure).__name__}")
    return [("structure", structure)]


def _native_sets(sets: Sequence[Tuple[str, Any]]) -> List[Tuple[str, Any]]:
    """The overrides as the native module takes them (a ``Structure`` by its checked parts)."""
    return [(p, v._native if isinstance(v, Structure) else v) for p, v in sets]


class Scenario:
    """A scenario (``kind = "damper"``, ``"hybrid"`` or ``"mechanism"``) and its overrides.

    Loaded by the tool's one loader: every problem raises ``ScenarioError`` naming the file,
    line and column. ``set`` maps ``--set`` paths (``"mechanism.half_angle_deg"``,
    ``"beam.segment[0].elements"``) to values (``bool``, ``int`` or numpy integer, ``float``,
    a list, or a ``str`` read as the command line reads VALUE: a TOML value, a bare word a
    string; ``bytes``, complex numbers, lists nested deeper than 32 or containing
    themselves are refused). The mechanism model files are checked when the scenario is
    loaded; the scenario keeps its directory as an absolute path, so it works after
    ``os.chdir`` and pickled to another process.
    """

    def __init__(self, text: str, file: str, base_dir: PathLike, sets: Sequence[Tuple[str, Any]] = ()) -> None:
        if not isinstance(text, str):
            raise TypeError(f"the scenario text must be a str, not {type(text).__name__}")
        self._text = text
        self._file = file
        self._base = os.path.abspath(os.fspath(base_dir))
        self._sets: List[Tuple[str, Any]] = list(sets)
        self.kind: str = _damper.check(text, file, self._base, _native_sets(self._sets))

    @classmethod
    def load(
        cls, path: PathLike, set: Optional[Mapping[str, SetValue]] = None, structure: Optional[Structure] = None
    ) -> "Scenario":
        """Reads and checks the scenario file ``path`` (a regular file of at most 64 MiB)
        with the overrides ``set``; ``structure`` (``Structure.from_matrices``) replaces its
        host structure (``with_structure``) before the overrides."""
        file = os.fspath(path)
        if not isinstance(file, str):
            raise TypeError(f"path must be a str or os.PathLike[str], not {type(file).__name__}")
        sets = _host(structure) + _items(set, "set")
        text = _damper.read_scenario(file)
        base = os.path.dirname(file)
        return cls(text, file, base, sets)

    @classmethod
    def from_str(
        cls, text: str, kind: str = "toml", base_dir: PathLike = ".", name: str = "<string>",
        structure: Optional[Structure] = None,
    ) -> "Scenario":
        """A scenario from its text (``kind``: the format, ``"toml"``); relative paths in it
        (the mechanism model) are relative to ``base_dir``; messages name it ``name``;
        ``structure`` as in ``load``."""
        if kind != "toml":
            raise ValueError(f"kind {kind!r}: scenarios are TOML (kind='toml')")
        return cls(text, name, base_dir, _host(structure))

    def with_structure(self, structure: Structure) -> "Scenario":
        """A copy whose host structure is ``structure`` (given in memory): its ``[structure]``
        table, if any, is replaced by ``{ kind = "given" }`` with the structure's damping
        and reduction (later overrides may still set ``structure.reduction.modes``); a
        scenario with a ``[beam]`` is refused (one host structure)."""
        return Scenario(self._text, self._file, self._base, self._sets + _host(structure))

    @property
    def file(self) -> str:
        """The file name messages give."""
        return self._file

    @property
    def sets(self) -> List[Tuple[str, Any]]:
        """The overrides applied, in order."""
        return list(self._sets)

    def with_set(self, set: Mapping[str, SetValue]) -> "Scenario":
        """A copy with the overrides ``set`` applied after this scenario's own."""
        return Scenario(self._text, self._file, self._base, self._sets + _items(set, "set"))

    def _src(self) -> Tuple[str, str, str, List[Tuple[str, Any]]]:
        return (self._text, self._file, self._base, _native_sets(self._sets))

    def simulate(self, compare: Optional[Sequence[str]] = None, allow_long: bool = False) -> Run:
        """Runs the scenario as ``damper simulate`` does, in memory (no file written).

        ``compare``: the comparison runs (``"generator_disconnected"``, ``"bare_beam"`` on a
        beam, ``"bare_structure"`` on a structure),
        replacing the scenario's ``[output] compare``; ``None`` keeps the scenario's.
        """
        sc = self if compare is None else self.with_set({"output.compare": _names(compare, "compare")})
        summary, columns, comparisons, psd = _damper.simulate(*sc._src(), allow_long)
        runs = {
            key: Run(cols, summary.get("comparisons", {}).get(key, {}))
            for key, cols in comparisons
        }
        return Run(columns, summary, runs, psd)

    def linearize(
        self, modes: int = 5, method: str = "auto", matrices: bool = False, allow_long: bool = False
    ) -> Linearization:
        """The linearisation about the static equilibrium and ``modes`` modes of each variant
        (``method``: ``"auto"``, ``"dense"`` or ``"shift-invert"``). ``matrices=True`` also
        builds the dense reduced matrices ``M_R``, ``C_R``, ``K_R`` (``3 d^2`` numbers for
        ``d`` reduced coordinates; refused above 1 GiB unless ``allow_long``, and above the
        machine's memory always); the work is refused above the limits of
        ``damper linearize`` unless ``allow_long``."""
        return Linearization(_damper.linearize(*self._src(), modes, method, matrices, allow_long))

    def frf(
        self,
        output: Union[str, float],
        f_from: float,
        f_to: float,
        points: int = 400,
        log: bool = False,
        excitation: Optional[str] = None,
        force: Optional[float] = None,
        nonlinear: Optional[int] = None,
        steps_per_period: int = 200,
        tolerance: float = 1e-3,
        max_periods: int = 1000,
        allow_long: bool = False,
    ) -> FrfResult:
        """The frequency response (``damper frf``): a ``FrfResult``, the table of ``frf.csv``
        (``frf["f"]``, ``frf["|H| with generator"]`` with its unit in ``frf.units``, ...).
        ``output``: a beam abscissa (m) or ``"MECHANISM/COORDINATE"``.

        ``nonlinear=M`` (``--nonlinear M``) adds the nonlinear steady states from time-domain
        runs at ``M`` frequencies (``steps_per_period``, ``tolerance``, ``max_periods`` as the
        command's options) as ``result.nonlinear``: the table of ``frf_nonlinear.csv``, the numbers as float arrays (NaN where the CSV cell is
        empty), ``"periods"`` an int array, ``"settled"`` a bool array, ``"error"`` a list of
        ``str`` or ``None``. The runs release the GIL and Ctrl-C stops them
        (``KeyboardInterrupt``); above the command's limits they are refused
        (``DamperError``) unless ``allow_long``. The command's warnings (a largest ``|H|`` at
        an edge of the band) are issued as ``DamperWarning``."""
        if not isinstance(output, str):
            output = repr(_real(output, "output"))
        cols, nl, warnings = _damper.frf(
            *self._src(), output, _real(f_from, "f_from"), _real(f_to, "f_to"), points, log, excitation,
            None if force is None else _real(force, "force"),
            nonlinear, steps_per_period, _real(tolerance, "tolerance"), max_periods, allow_long,
        )
        return FrfResult(cols, nl, warnings)

    def sweep(
        self,
        axes: Mapping[str, Union[str, Sequence[Any]]],
        time_domain: bool = False,
        threads: Optional[int] = None,
        allow_long: bool = False,
    ) -> SweepResult:
        """A sweep (``damper sweep``) over the grid of ``axes`` (``{path: values}``, the values
        a list or a VALUES string such as ``"30:60:7"``): a ``SweepResult``, the table of
        ``sweep.csv`` — ``index``, each axis (a list of its values), each figure as an
        array (NaN where a point does not give it; ``units[figure]``), ``error`` (and
        ``time_domain_error``) as lists of ``str`` or ``None``."""
        return SweepResult(_damper.sweep_grid(*self._src(), _items(axes, "axes"), time_domain, threads, allow_long))

    def sweep_points(self, axes: Mapping[str, Union[str, Sequence[Any]]], allow_long: bool = False) -> List[Dict[str, Any]]:
        """The points of the grid of ``axes`` (as ``sweep`` takes them), in grid order (the
        last axis varying fastest): ``{path: value}`` each. Point ``i`` is shard ``i`` of
        ``len(points)`` (``sweep_shard``)."""
        paths, points = _damper.sweep_points(_items(axes, "axes"), allow_long)
        return [dict(zip(paths, p)) for p in points]

    def sweep_shard(
        self,
        axes: Mapping[str, Union[str, Sequence[Any]]],
        shard: int,
        shards: int,
        time_domain: bool = False,
        threads: Optional[int] = None,
        allow_long: bool = False,
    ) -> "SweepPart":
        """Shard ``shard`` of ``shards`` of the sweep over ``axes`` (``damper sweep --shard
        I/N``: the points with ``index % shards == shard``), as a ``SweepPart``; the parts
        of every shard, joined by ``merge_sweep``, give the table ``sweep`` returns and
        ``damper sweep`` writes, cell for cell."""
        return SweepPart(
            _damper.sweep_shard(*self._src(), _items(axes, "axes"), shard, shards, time_domain, threads, allow_long)
        )

    def optimize(
        self,
        vary: Mapping[str, Tuple[float, float]],
        maximize: Optional[str] = None,
        minimize: Optional[str] = None,
        constraints: Sequence[str] = (),
        grid: int = 5,
        allow_long: bool = False,
    ) -> Optimum:
        """The best design (``damper optimize``): ``vary`` maps paths to bounds ``(lo,
        hi)``, one of ``maximize`` / ``minimize`` names the figure (``"zeta1"``, ...),
        ``constraints`` as ``"reach>=0.002"``. Returns an ``Optimum``: ``x``, ``objective``,
        ``constraints``, ``kkt_residual``, ``history`` (the table of
        ``optimize_history.csv``) and ``report`` (the ``damper optimize --json`` object)."""
        if maximize is not None and minimize is None:
            objective, up = maximize, True
        elif minimize is not None and maximize is None:
            objective, up = minimize, False
        else:
            raise ValueError("give one of maximize or minimize")
        specs = []
        for p, bounds in _items(vary, "vary"):
            if isinstance(bounds, (str, bytes)) or not isinstance(bounds, Sequence) or len(bounds) != 2:
                raise TypeError(f"vary[{p!r}] must be a pair (lo, hi), not {bounds!r}")
            lo, hi = bounds
            specs.append(f"{p}={_num(_real(lo, f'vary[{p!r}] lo'))}:{_num(_real(hi, f'vary[{p!r}] hi'))}")
        report, history = _damper.optimize(
            *self._src(), specs, objective, up, _names(constraints, "constraints"), grid, allow_long
        )
        return Optimum(dict(report), history)

    def random(
        self,
        outputs: Union[str, Sequence[str]] = (),
        method: str = "auto",
        modes: int = 20,
        allow_long: bool = False,
    ) -> RandomResult:
        """The linear stationary response to the scenario's random excitations
        (``damper random``), as a ``RandomResult``: ``outputs`` as ``--output`` names them (default: every
        attachment and mechanism coordinate), ``method`` one of ``"auto"``, ``"dense"``,
        ``"modal"``, ``"quadrature"``, ``modes`` the modal basis. The result's ``report`` is the ``damper random
        --json`` object (``outputs``: ``{name, unit, rms}``, ``generators``: ``{name,
        rms_current, rms_rotor_speed, mean_power_dissipated, mean_power_load}``, ``method``,
        ...). One
        ``str`` is one output name. Refused above the limits of ``damper random`` unless
        ``allow_long``."""
        return RandomResult(dict(_damper.random(*self._src(), _names(outputs, "outputs"), method, modes, allow_long)))

    def figures(self) -> List[Dict[str, Any]]:
        """The figures this scenario offers to ``sweep`` and ``optimize`` (``damper figures
        --json``): ``{name, unit, producer, gradient, on_request, meaning}`` each, from the
        one catalogue; constraints and objectives take these names."""
        return list(_damper.figures(*self._src()))

    def __eq__(self, other: object) -> bool:
        """Equal scenarios: the same text, file name, directory and overrides (a pickled
        and unpickled scenario equals the original)."""
        if not isinstance(other, Scenario):
            return NotImplemented
        return _equal((self._text, self._file, self._base, self._sets, self.kind), (other._text, other._file, other._base, other._sets, other.kind))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"Scenario({self._file!r}, kind={self.kind!r}, sets={self._sets!r})"


class SweepPart:
    """One shard of a sweep (``Scenario.sweep_shard``): ``text`` the part file
    ``sweep.part-I-of-N.json`` (the shard's points with the sweep's record and a checksum),
    ``shard`` (I) and ``shards`` (N). A plain string inside: it pickles to an equal part
    and travels to and from the workers of a distributed engine; ``merge_sweep`` joins the
    parts of every shard, ``write(directory)`` saves it for ``damper merge``."""

    def __init__(self, text: str) -> None:
        if not isinstance(text, str):
            raise TypeError(f"a sweep part is the text of its file (str), not {type(text).__name__}")
        head = json.loads(text)
        self.text: str = text
        self.shard: int = int(head["shard"])
        self.shards: int = int(head["shards"])

    @property
    def name(self) -> str:
        """The part file's name, ``sweep.part-I-of-N.json``."""
        return f"sweep.part-{self.shard}-of-{self.shards}.json"

    def write(self, directory: PathLike) -> str:
        """Writes the part file into ``directory`` (created if missing) and returns its
        path."""
        os.makedirs(directory, exist_ok=True)
        path = os.path.join(os.fspath(directory), self.name)
        with open(path, "w", encoding="utf-8") as f:
            f.write(self.text)
        return path

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, SweepPart):
            return NotImplemented
        return self.text == other.text

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"SweepPart({self.shard} of {self.shards})"


def merge_sweep(parts: Iterable[Union[SweepPart, str]], allow_long: bool = False) -> SweepResult:
    """The parts of every shard of one sweep (``SweepPart``s, or their files' texts, in any
    order) joined as ``damper merge`` joins them — each checked (complete, its checksum,
    every shard once; otherwise ``ValueError`` with the one-line message of ``damper merge``, naming the part) — into the ``SweepResult``
    of the whole sweep: the table ``damper sweep`` writes, cell for cell."""
    texts = []
    for p in parts:
        if isinstance(p, SweepPart):
            texts.append(p.text)
        elif isinstance(p, str):
            texts.append(p)
        else:
            raise TypeError(f"merge_sweep takes SweepPart objects or their texts, not {type(p).__name__}")
    return SweepResult(_damper.sweep_merge(texts, allow_long))


def _num(x: float) -> str:
    return repr(float(x))


class Model:
    """A mechanism model file (``.toml`` or ``.json``), as ``damper eval`` and
    ``damper generate`` read it."""

    def __init__(self, path: PathLike) -> None:
        self.path: str = os.fspath(path)
        name, coordinates, parameters = _damper.model_info(self.path)
        self.name: str = name
        self.coordinates: List[str] = coordinates
        self.parameters: Dict[str, float] = {p[0]: p[1] for p in parameters}
        self.derived_parameters: List[str] = [p[0] for p in parameters if p[2]]
        self.runtime_parameters: List[str] = [p[0] for p in parameters if p[3]]

    @classmethod
    def load(cls, path: PathLike) -> "Model":
        """Reads and checks the model file (``ModelError`` naming file, line and column)."""
        return cls(path)

    def evaluate(
        self,
        q: Sequence[float],
        qd: Sequence[float],
        t: float = 0.0,
        backend: str = "interp",
        params: Optional[Mapping[str, float]] = None,
    ) -> Dict[str, Any]:
        """Every equation at one state (``damper eval``): ``M``, ``F``, ``Q``, ``h``, ``J``,
        ``A`` as arrays, ``constraint_names``, ``points`` (name → ``p``, ``J``, ``A``
        arrays) and ``op_count``. ``backend``: ``"interp"``, ``"numeric"`` or
        ``"generated"``; ``params``: parameter overrides by name."""
        pairs = [f"{k}={_real(v, f'params[{k!r}]')!r}" for k, v in _items(params, "params")]
        out = dict(
            _damper.model_eval(self.path, _floats(q, "q"), _floats(qd, "qd"), _real(t, "t"), backend, pairs)
        )
        for key in ("q", "qd", "M", "F", "Q", "h", "J", "A"):
            out[key] = np.asarray(out[key], dtype=float)
        n = len(self.coordinates)
        out["M"] = out["M"].reshape(n, n)
        out["J"] = out["J"].reshape(-1, n)
        out["points"] = {
            name: {"p": np.asarray(p["p"], dtype=float), "J": np.asarray(p["J"], dtype=float).reshape(3, n), "A": np.asarray(p["A"], dtype=float)}
            for name, p in out["points"].items()
        }
        return out

    def generate_rust(self, struct_name: Optional[str] = None) -> str:
        """The Rust module ``damper generate`` writes for this model."""
        source, _ = _damper.model_generate(self.path, struct_name)
        return source

    def op_counts(self) -> Dict[str, Dict[str, int]]:
        """The operation count of every generated function (``damper generate --stats``):
        name → ``adds``, ``muls``, ``divs``, ``funcs``, ``negs``, ``total``."""
        _, stats = _damper.model_generate(self.path, None)
        keys = ("adds", "muls", "divs", "funcs", "negs", "total")
        return {name: dict(zip(keys, counts)) for name, counts in stats}

    def __repr__(self) -> str:
        return f"Model({self.path!r}, name={self.name!r}, coordinates={self.coordinates!r})"
