"""The typed results of ``damper``'s calls: tables of named columns with their units, and
the reports of the random response and of the optimiser.

A ``Table`` holds the columns of a CSV the command line writes, built by the same code
(the report's table: ``sweep.csv``, ``frf.csv``, ``frf_nonlinear.csv``,
``optimize_history.csv``, a simulation's time history). A column is addressed by its name
without the unit (``sweep["linear.zeta1"]``) or by the CSV header (``sweep["linear.zeta1
[-]"]``, as the package's first versions did); ``units`` maps every column that has a unit
to it. Every result pickles to an equal object (plain Python attributes and numpy arrays), so
that it travels to and from the workers of a distributed engine. Plots need matplotlib
(``pip install matplotlib``) and return its ``Axes`` for the caller to adjust.
"""

from __future__ import annotations

import html
import math
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np

Column = Tuple[str, Optional[str], Any]

__all__ = ["Column", "FrfResult", "Optimum", "RandomResult", "Run", "SweepResult", "Table"]


def _pyplot(what: str) -> Any:
    """``matplotlib.pyplot``, or an ``ImportError`` naming the call that needs it."""
    try:
        import matplotlib.pyplot as plt  # type: ignore[import-not-found,unused-ignore]
    except ImportError as e:
        raise ImportError(f"{what} needs matplotlib: pip install matplotlib") from e
    return plt


def _pandas(what: str) -> Any:
    """``pandas``, or an ``ImportError`` naming the call that needs it."""
    try:
        import pandas as pd  # type: ignore[import-untyped,unused-ignore]
    except ImportError as e:
        raise ImportError(f"{what} needs pandas: pip install pandas") from e
    return pd


def _equal(a: Any, b: Any) -> bool:
    """Deep equality of results: arrays element by element (NaN equal to NaN, dtype
    included), mappings and sequences item by item."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        if not (isinstance(a, np.ndarray) and isinstance(b, np.ndarray)) or a.dtype != b.dtype:
            return False
        return bool(np.array_equal(a, b, equal_nan=a.dtype.kind == "f"))
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


def _brief(values: Any) -> str:
    """A column's range in a few characters (numbers to 4 significant digits)."""
    if isinstance(values, np.ndarray) and values.dtype.kind == "f":
        finite = values[np.isfinite(values)]
        if finite.size == 0:
            return "(empty)"
        lo, hi = float(finite.min()), float(finite.max())
        gaps = "" if finite.size == values.size else f", {values.size - finite.size} empty"
        return (f"{lo:.4g}" if lo == hi else f"{lo:.4g} .. {hi:.4g}") + gaps
    items = list(values)
    present = [x for x in items if x is not None]
    if not present:
        return "(none)" if items else "(empty)"
    distinct = list(dict.fromkeys(str(x) for x in present))
    shown = ", ".join(distinct[:4]) + (", ..." if len(distinct) > 4 else "")
    return shown if len(shown) <= 60 else shown[:57] + "..."


def _html_table(caption: str, head: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """An HTML table (every text escaped)."""
    e = html.escape
    out = [f"<table><caption style='text-align:left'>{e(caption)}</caption><thead><tr>"]
    out += [f"<th style='text-align:left'>{e(h)}</th>" for h in head]
    out.append("</tr></thead><tbody>")
    for r in rows:
        out.append("<tr>" + "".join(f"<td style='text-align:left'>{e(c)}</td>" for c in r) + "</tr>")
    out.append("</tbody></table>")
    return "".join(out)


class _Result:
    """What every result shares: equality of its content (a pickled and unpickled result
    equals the original), and a summary of rows ``(name, unit or role, value)`` printed as
    text and shown in a notebook as an HTML table."""

    _head: Tuple[str, str, str] = ("name", "unit", "value")

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return _equal(self.__dict__, other.__dict__)

    __hash__ = None  # type: ignore[assignment]

    def _title(self) -> str:
        raise NotImplementedError

    def _rows(self) -> List[Tuple[str, str, str]]:
        raise NotImplementedError

    def __repr__(self) -> str:
        rows = self._rows()
        width = max([len(n) for n, _, _ in rows] + [6])
        unit = max([len(u) for _, u, _ in rows] + [8])
        return "\n".join([self._title()] + [f"  {n:<{width}}  {u:<{unit}}  {v}".rstrip() for n, u, v in rows])

    def _repr_html_(self) -> str:
        return _html_table(self._title(), self._head, self._rows())


class Table(_Result):
    """Named columns of equal length, as a CSV of the command line has them.

    ``columns``: the names without units, in the CSV's order; ``units``: name → unit for
    every column that has one (``"-"`` for a ratio); ``headers``: the CSV header
    (``"name [unit]"``). ``table[name]`` (or ``table["name [unit]"]``) is a column: numbers
    as a float ``numpy.ndarray`` (NaN for an empty cell), counts as int64, flags as bool,
    texts (``error``) and scenario values (a sweep's axes) as lists. ``len(table)`` is the
    number of rows; iteration gives the names; ``to_dict()``, ``to_pandas()``; printed, a
    summary of every column (its unit and range); in a notebook, the same as an HTML table.
    """

    _what = "Table"

    def __init__(self, columns: Sequence[Column]) -> None:
        self.columns: List[str] = [name for name, _, _ in columns]
        self.units: Dict[str, str] = {name: unit for name, unit, _ in columns if unit is not None}
        self._data: Dict[str, Any] = {name: values for name, _, values in columns}

    @property
    def headers(self) -> List[str]:
        """The CSV header: ``"name [unit]"``, or ``"name"`` for a column without a unit."""
        return [self.header(name) for name in self.columns]

    def header(self, name: str) -> str:
        """The CSV header of the column ``name``."""
        unit = self.units.get(name)
        return name if unit is None else f"{name} [{unit}]"

    def _name(self, key: str) -> str:
        if key in self._data:
            return key
        for name in self.columns:
            if self.header(name) == key:
                return name
        raise KeyError(f"no column {key!r}; columns: {', '.join(self.columns)}")

    def __getitem__(self, key: str) -> Any:
        return self._data[self._name(key)]

    def __contains__(self, key: object) -> bool:
        return isinstance(key, str) and (key in self._data or key in self.headers)

    def __iter__(self) -> Iterator[str]:
        return iter(self.columns)

    def __len__(self) -> int:
        """The number of rows."""
        return len(self._data[self.columns[0]]) if self.columns else 0

    def keys(self) -> List[str]:
        """The column names."""
        return list(self.columns)

    def values(self) -> List[Any]:
        """The columns, in order."""
        return [self._data[n] for n in self.columns]

    def items(self) -> List[Tuple[str, Any]]:
        """``(name, column)`` pairs, in order."""
        return [(n, self._data[n]) for n in self.columns]

    def to_dict(self) -> Dict[str, Any]:
        """Every column by name (the arrays themselves, not copies)."""
        return {name: self._data[name] for name in self.columns}

    def to_pandas(self, headers: bool = False) -> Any:
        """The columns as a ``pandas.DataFrame`` (pandas is an optional dependency:
        ``ImportError`` without it); its columns named by ``columns``, or by the CSV
        ``headers`` with ``headers=True``."""
        pd = _pandas(f"{type(self).__name__}.to_pandas")
        names = self.headers if headers else self.columns
        return pd.DataFrame({k: self._data[n] for k, n in zip(names, self.columns)}, columns=names)

    def _title(self) -> str:
        return f"{self._what}: {len(self)} rows, {len(self.columns)} columns"

    _head = ("column", "unit", "values")

    def _rows(self) -> List[Tuple[str, str, str]]:
        return [(n, self.units.get(n, ""), _brief(self._data[n])) for n in self.columns]


class Run(Table):
    """One simulated run (``damper simulate``): its time history as a ``Table`` (the CSV's
    columns: ``run["t"]``, ``run["t [s]"]``), ``summary`` the ``summary.json`` object (for
    a comparison run, its block of the summary's ``comparisons``), ``comparisons`` each
    comparison run of ``[output] compare`` (``"generator_disconnected"``,
    ``"bare_beam"``) as a ``Run``; ``psd`` under random excitation the table of
    ``random_psd.csv`` (``run.psd["f"]``, ``run.psd["w(x=1) estimate"]``,
    ``run.psd["w(x=1) prediction"]``, ``run.psd["relative standard error"]``), else
    ``None``."""

    _what = "Run"

    def __init__(
        self,
        columns: Sequence[Column],
        summary: Dict[str, Any],
        comparisons: Optional[Dict[str, "Run"]] = None,
        psd: Optional[Sequence[Column]] = None,
    ) -> None:
        super().__init__(columns)
        self.summary: Dict[str, Any] = summary
        self.comparisons: Dict[str, Run] = comparisons or {}
        self.psd: Optional[Table] = None if psd is None else Table(psd)

    def _title(self) -> str:
        extra = f", comparisons: {', '.join(self.comparisons)}" if self.comparisons else ""
        psd = "" if self.psd is None else f", response PSD at {len(self.psd)} frequencies"
        return f"Run: {len(self)} rows, {len(self.columns)} columns{extra}{psd}"

    def plot(self, columns: Optional[Sequence[str]] = None, x: Optional[str] = None, ax: Any = None) -> Any:
        """Draws ``columns`` (names or headers; default: the first column after ``x``)
        against ``x`` (default: the first column, the time) with matplotlib and returns
        the ``Axes`` (a new figure's unless ``ax`` is given)."""
        plt = _pyplot("Run.plot")
        xname = self._name(x) if x is not None else self.columns[0]
        if columns is None:
            wanted: Sequence[str] = [c for c in self.columns if c != xname][:1]
        else:
            wanted = [columns] if isinstance(columns, str) else columns
        names = [self._name(c) for c in wanted]
        if ax is None:
            _, ax = plt.subplots()
        for n in names:
            ax.plot(self._data[xname], self._data[n], label=self.header(n))
        ax.set_xlabel(self.header(xname))
        units = {self.units.get(n) for n in names}
        ax.set_ylabel(f"[{units.pop()}]" if len(units) == 1 and None not in units else "")
        ax.legend()
        return ax


class FrfResult(Table):
    """A frequency response (``damper frf``): the table of ``frf.csv`` (``frf["f"]``,
    ``frf["|H| with generator"]``, its unit ``frf.units["|H| with generator"]``, the phases,
    real and imaginary parts, the admissible loads and the generators' currents, voltages
    and powers per unit force); ``nonlinear`` the table of ``frf_nonlinear.csv`` with
    ``nonlinear=M`` (``periods`` int64, ``settled`` bool, ``error`` a list), else ``None``;
    ``warnings`` the command's warnings (also issued as ``DamperWarning``)."""

    _what = "FrfResult"

    def __init__(self, columns: Sequence[Column], nonlinear: Optional[Sequence[Column]], warnings: Sequence[str]) -> None:
        super().__init__(columns)
        self.nonlinear: Optional[Table] = None if nonlinear is None else Table(nonlinear)
        self.warnings: List[str] = list(warnings)

    def _title(self) -> str:
        nl = "" if self.nonlinear is None else f", nonlinear at {len(self.nonlinear)} frequencies"
        return f"FrfResult: {len(self)} frequencies, {len(self.columns)} columns{nl}"

    def _rows(self) -> List[Tuple[str, str, str]]:
        rows = super()._rows()
        return rows + [("warning", "", w) for w in self.warnings]

    def plot(self, ax: Any = None) -> Any:
        """Draws ``|H|`` with the generator and disconnected against the frequency (log
        axes) and, with ``nonlinear``, the measured ``|H|`` of the runs (filled: settled)
        with matplotlib; returns the ``Axes``."""
        plt = _pyplot("FrfResult.plot")
        if ax is None:
            _, ax = plt.subplots()
        f = self._data["f"]
        for name in ("|H| with generator", "|H| generator disconnected"):
            ax.plot(f, self._data[name], label=name)
        if self.nonlinear is not None:
            nl = self.nonlinear
            settled = np.asarray(nl["settled"], dtype=bool)
            for mask, style, label in ((settled, "o", "nonlinear (settled)"), (~settled, "x", "nonlinear (not settled)")):
                if mask.any():
                    ax.plot(nl["f"][mask], nl["|H|"][mask], style, label=label)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(self.header("f"))
        ax.set_ylabel(self.header("|H| with generator").replace(" with generator", ""))
        ax.legend()
        return ax


class SweepResult(Table):
    """A sweep (``damper sweep``): the table of ``sweep.csv`` — ``index`` (int64), each
    swept path (``axes``, a list of its values), every figure (``figures``; a float array,
    NaN where a point does not give it; ``units[figure]``), ``error`` (and with the time
    domain ``time_domain_error``): a list of ``str`` or ``None``."""

    _what = "SweepResult"
    _errors = ("index", "error", "time_domain_error")

    @property
    def axes(self) -> List[str]:
        """The swept paths, in grid order (the last varying fastest)."""
        return [n for n in self.columns if n not in self.units and n not in self._errors]

    @property
    def figures(self) -> List[str]:
        """The figures' names."""
        return [n for n in self.columns if n in self.units]

    @property
    def errors(self) -> List[Optional[str]]:
        """Why each point failed (``None``: it did not)."""
        return list(self._data["error"])

    def _title(self) -> str:
        failed = sum(e is not None for e in self._data.get("error", []))
        return f"SweepResult: {len(self)} points over {', '.join(self.axes) or 'no axis'}, {len(self.figures)} figures, {failed} failed"

    def plot_map(self, figure: str = "linear.zeta1", ax: Any = None) -> Any:
        """Draws ``figure`` over the swept axes with matplotlib: a filled contour map (with
        its colour bar) over two axes of more than one numeric value, a line over one;
        returns the ``Axes``. The other axes must have one value each (``ValueError``
        otherwise)."""
        plt = _pyplot("SweepResult.plot_map")
        name = self._name(figure)
        z = np.asarray(self._data[name], dtype=float)
        varying = [a for a in self.axes if len(dict.fromkeys(map(repr, self._data[a]))) > 1]
        if not 1 <= len(varying) <= 2:
            raise ValueError(f"plot_map draws over one or two varying axes; this sweep varies {len(varying)} ({', '.join(varying)})")
        values = [np.asarray(self._data[a], dtype=float) for a in varying]
        if ax is None:
            _, ax = plt.subplots()
        label = self.header(name)
        if len(varying) == 1:
            order = np.argsort(values[0], kind="stable")
            ax.plot(values[0][order], z[order], marker="o", label=label)
            ax.set_xlabel(varying[0])
            ax.set_ylabel(label)
            return ax
        xs, ys = (np.array(list(dict.fromkeys(v.tolist()))) for v in values)
        grid = np.full((len(ys), len(xs)), np.nan)
        xi = {x: i for i, x in enumerate(xs.tolist())}
        yi = {y: j for j, y in enumerate(ys.tolist())}
        for x, y, v in zip(values[0].tolist(), values[1].tolist(), z):
            grid[yi[y], xi[x]] = v
        ox, oy = np.argsort(xs, kind="stable"), np.argsort(ys, kind="stable")
        filled = ax.contourf(xs[ox], ys[oy], grid[np.ix_(oy, ox)], levels=12)
        ax.figure.colorbar(filled, ax=ax, label=label)
        ax.set_xlabel(varying[0])
        ax.set_ylabel(varying[1])
        ax.set_title(label)
        return ax


class RandomResult(_Result):
    """The stationary random response (``damper random``): ``outputs`` the output names,
    ``rms`` their RMS values (a float array in that order), ``units`` name → unit,
    ``result[name]`` one output's RMS, ``generators`` name → ``{rms_current,
    rms_rotor_speed, mean_power_dissipated, mean_power_load}``, ``method``, and ``report``
    the whole ``damper random --json`` object (``result["outputs"]`` and the report's other
    keys still read it, as the package's first versions returned it)."""

    def __init__(self, report: Dict[str, Any]) -> None:
        self.report: Dict[str, Any] = report
        self.outputs: List[str] = [o["name"] for o in report["outputs"]]
        self.units: Dict[str, str] = {o["name"]: o["unit"] for o in report["outputs"]}
        self.rms: np.ndarray = np.array([o["rms"] for o in report["outputs"]], dtype=float)
        self.generators: Dict[str, Dict[str, Any]] = {
            g["name"]: {k: v for k, v in g.items() if k != "name"} for g in report["generators"]
        }
        self.method: str = report["method"]

    def __getitem__(self, key: str) -> Any:
        if key in self.units:
            return float(self.rms[self.outputs.index(key)])
        if key in self.report:
            return self.report[key]
        raise KeyError(f"no output {key!r}; outputs: {', '.join(self.outputs)}")

    def __contains__(self, key: object) -> bool:
        return key in self.units

    def __iter__(self) -> Iterator[str]:
        return iter(self.outputs)

    def __len__(self) -> int:
        return len(self.outputs)

    def to_dict(self) -> Dict[str, Any]:
        """The ``damper random --json`` object."""
        return self.report

    def to_pandas(self) -> Any:
        """The outputs as a ``pandas.DataFrame`` (``output``, ``unit``, ``rms``)."""
        pd = _pandas("RandomResult.to_pandas")
        return pd.DataFrame({"output": self.outputs, "unit": [self.units[o] for o in self.outputs], "rms": self.rms})

    def _rows(self) -> List[Tuple[str, str, str]]:
        rows = [(o, self.units[o], f"{r:.4g}") for o, r in zip(self.outputs, self.rms)]
        for g, v in self.generators.items():
            rows.append((f"{g}.mean_power_load", "W", f"{v['mean_power_load']:.4g}"))
            rows.append((f"{g}.rms_current", "A", f"{v['rms_current']:.4g}"))
        return rows

    def _title(self) -> str:
        return f"RandomResult ({self.method}): RMS of {len(self.outputs)} outputs, {len(self.generators)} generators"

    _head = ("output", "unit", "RMS")


class Optimum(_Result):
    """The best design (``damper optimize``): ``x`` path → value at the optimum,
    ``objective`` (name, value), ``constraints`` (each ``{constraint, value, rhs, margin,
    active, multiplier, ...}``), ``kkt_residual``, ``certificate``, ``at_bounds``; ``history`` the
    table of ``optimize_history.csv`` (every evaluation: ``stage``, the variables, the
    objective and constraint figures, ``error``); ``report`` the whole ``damper optimize
    --json`` object (``optimum["optimum"]`` and the report's other keys still read it)."""

    def __init__(self, report: Dict[str, Any], history: Sequence[Column]) -> None:
        self.report: Dict[str, Any] = report
        self.x: Dict[str, float] = {p: v for p, v in report["optimum"]}
        name, value = report["objective"]
        self.objective: Tuple[str, float] = (name, value)
        self.constraints: List[Dict[str, Any]] = report["constraints"]
        self.kkt_residual: Optional[float] = report.get("kkt_residual")
        self.certificate: str = report.get("certificate", "")
        self.at_bounds: List[Tuple[str, str]] = [(p, s) for p, s in report.get("at_bounds", [])]
        self.history: Table = Table(history)

    def __getitem__(self, key: str) -> Any:
        return self.report[key]

    def to_dict(self) -> Dict[str, Any]:
        """The ``damper optimize --json`` object."""
        return self.report

    def to_pandas(self) -> Any:
        """The history as a ``pandas.DataFrame``."""
        return self.history.to_pandas()

    def _rows(self) -> List[Tuple[str, str, str]]:
        rows = [(p, "variable", f"{v:.6g}") for p, v in self.x.items()]
        rows.append((self.objective[0], "objective", f"{self.objective[1]:.6g}"))
        for c in self.constraints:
            state = "active" if c.get("active") else "inactive"
            rows.append((str(c.get("constraint", "")), f"constraint ({state})", f"margin {c.get('margin', float('nan')):.3g}"))
        return rows

    def _title(self) -> str:
        kkt = "" if self.kkt_residual is None else f", KKT residual {self.kkt_residual:.2e}"
        return f"Optimum after {len(self.history)} evaluations{kkt}"

    _head = ("name", "role", "value")

    def __repr__(self) -> str:
        return super().__repr__() + (f"\n  {self.certificate}" if self.certificate else "")
