"""A structure given in memory (`damper.Structure.from_matrices`) is the structure its files
would be: the bundled frame's matrices read by scipy, or assembled by scikit-fem in this
process (the export script's own assembly, never written to a file), give the file-based
scenario's results; every input the file readers refuse is refused, naming the argument
and the row or entry."""

from __future__ import annotations

import csv
import importlib.util
import pickle
from pathlib import Path
from typing import Any, Dict, List, Tuple

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

import damper
from damper.results import _equal

ROOT = Path(__file__).resolve().parents[3]
FRAME = ROOT / "scenarios" / "frame"
SCENARIO = ROOT / "scenarios" / "frame.toml"
DAMPING = {"ratios": [(1, 0.002), (2, 0.002)]}
REDUCTION = {"kind": "craig_bampton", "modes": 30}
# A short run: the comparison is of every sample, not of a long history.
SHORT = {"integrator.t_end": 0.02, "output.compare": []}


def frame_files() -> Tuple[Any, Any, np.ndarray, List[List[str]]]:
    """The committed frame as a user would read it: scipy's Matrix Market reader (which
    returns both triangles), numpy's CSV reader."""
    m = scipy.io.mmread(FRAME / "M.mtx").tocsr()
    k = scipy.io.mmread(FRAME / "K.mtx").tocsr()
    nodes = np.loadtxt(FRAME / "nodes.csv", delimiter=",", skiprows=1)
    with open(FRAME / "dofs.csv", newline="") as f:
        dofs = list(csv.reader(f))[1:]
    return m, k, nodes, dofs


@pytest.fixture(scope="module")
def given() -> damper.Structure:
    m, k, nodes, dofs = frame_files()
    return damper.Structure.from_matrices(m, k, nodes, dofs, damping=DAMPING, reduction=REDUCTION)


def report_without_overrides(lin: damper.Linearization) -> Dict[str, Any]:
    return {k: v for k, v in lin.report.items() if k != "overrides"}


def test_given_frame_linearizes_as_its_files(given: damper.Structure) -> None:
    files = damper.Scenario.load(SCENARIO)
    mem = damper.Scenario.load(SCENARIO, structure=given)
    a, b = files.linearize(), mem.linearize()
    # The same numbers in (scipy parses the files' decimals as our reader does): the same
    # results bit for bit; only the record of the override differs.
    assert _equal(report_without_overrides(a), report_without_overrides(b))
    assert all(_equal(x.__dict__, y.__dict__) for x, y in zip(a.modes, b.modes))
    assert b.report["overrides"][0]["value"]["kind"] == "given"
    assert given.equations == 1990


def test_given_frame_simulates_and_sweeps_as_its_files(given: damper.Structure) -> None:
    files = damper.Scenario.load(SCENARIO, set=SHORT)
    mem = damper.Scenario.load(SCENARIO, set=SHORT, structure=given)
    ra, rb = files.simulate(), mem.simulate()
    assert ra.columns == rb.columns
    for c in ra.columns:
        assert np.array_equal(ra[c], rb[c]), c
    # A sweep re-loads the scenario at every point: the structure travels with it.
    axes = {"force[0].load_resistance": [2.0, 4.0]}
    sa, sb = files.sweep(axes), mem.sweep(axes)
    assert np.array_equal(sa["linear.zeta1"], sb["linear.zeta1"])
    assert sa["linear.zeta1"][0] != sa["linear.zeta1"][1]
    out = ["613:ux", "613:uy"]
    harmonic = 'amplitude = 5.0                 # N\ntime = { kind = "harmonic", frequency_hz = 38.9 }'
    text = SCENARIO.read_text()
    assert harmonic in text
    text = text.replace(harmonic, 'time = { kind = "white_noise", psd = 1e-3, band = [1.0, 500.0] }')
    noisy = lambda s: damper.Scenario.from_str(text, base_dir=SCENARIO.parent, name="frame.toml", structure=s)
    xa, xb = noisy(None).random(outputs=out), noisy(given).random(outputs=out)
    assert xa.report["outputs"][0]["rms"] > 0
    assert np.array_equal(xa.rms, xb.rms) and _equal(xa.generators, xb.generators)


def test_later_overrides_reach_the_given_structure(given: damper.Structure) -> None:
    """`structure.reduction.modes` set after the structure: the reduction follows it."""
    mem = damper.Scenario.load(SCENARIO, structure=given)
    a = mem.with_set({"structure.reduction.modes": 12}).linearize()
    b = damper.Scenario.load(SCENARIO, set={"structure.reduction.modes": 12}).linearize()
    assert _equal(a.modes[0].__dict__, b.modes[0].__dict__)
    assert a.modes[0].natural_frequency_hz != mem.linearize().modes[0].natural_frequency_hz


def test_given_structure_pickles(given: damper.Structure) -> None:
    mem = damper.Scenario.load(SCENARIO, structure=given)
    back = pickle.loads(pickle.dumps(mem))
    assert back == mem
    assert pickle.loads(pickle.dumps(given)) == given
    assert _equal(back.linearize().modes[0].__dict__, mem.linearize().modes[0].__dict__)


def load_export_script() -> Any:
    spec = importlib.util.spec_from_file_location("export_frame", FRAME / "export_frame.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_frame_assembled_in_memory_by_scikit_fem() -> None:
    """The frame assembled by scikit-fem in this process goes in without a file: its first
    coupled mode equals the committed files' (written from the same assembly with 17
    significant digits, one triangle: the assembled matrices are symmetric to round-off,
    so the results agree to the reduction's sensitivity to that round-off, 1e-9)."""
    ex = load_export_script()
    k, m, positions, _ = ex.frame()
    nodes = [(i + 1, x, y) for i, (x, y) in enumerate(positions)]
    s = damper.Structure.from_matrices(m, k, nodes, ex.dof_rows(len(positions)), damping=DAMPING, reduction=REDUCTION)
    a = damper.Scenario.load(SCENARIO).linearize().modes[0]
    b = damper.Scenario.load(SCENARIO, structure=s).linearize().modes[0]
    assert b.natural_frequency_hz == pytest.approx(a.natural_frequency_hz, rel=1e-9)
    assert b.damping_ratio == pytest.approx(a.damping_ratio, rel=1e-9)


def spring_node(kx: float = 4.0e4, ky: float = 4.0e10, mass: float = 2.0) -> Tuple[np.ndarray, np.ndarray]:
    return np.diag([mass, mass]), np.diag([kx, ky])


def test_dense_and_sparse_inputs_agree() -> None:
    """A one-node structure given as dense numpy arrays, as scipy.sparse, and by a mapping
    of nodes: one structure (the same linearisation, bit for bit)."""
    m, k = spring_node()
    # The frame's scenario on one node (613, where the damper is pinned, also loaded).
    text = SCENARIO.read_text().replace("node = 741", "node = 613")
    dofs = [(0, 613, "ux"), (1, 613, "uy")]
    dense = damper.Structure.from_matrices(m, k, [[613, 0.4, 0.58]], dofs)
    sparse = damper.Structure.from_matrices(sp.csr_matrix(m), sp.coo_matrix(k), {613: (0.4, 0.58)}, dofs)
    load = lambda s: damper.Scenario.from_str(text, base_dir=SCENARIO.parent, name="frame.toml", structure=s)
    a, b = load(dense).linearize(), load(sparse).linearize()
    assert _equal(a.modes[0].__dict__, b.modes[0].__dict__)
    assert a.modes[0].natural_frequency_hz > 0


def message_of(excinfo: pytest.ExceptionInfo[BaseException]) -> str:
    text = str(excinfo.value)
    assert "\n" not in text, text
    return text


@pytest.mark.parametrize(
    "change, expected",
    [
        ({"K": np.array([[4.0, 1.0], [0.0, 4.0]])}, "Structure.from_matrices: K: the matrix is not symmetric: entry [0, 1]"),
        ({"M": np.diag([1.0, -1.0])}, "Structure.from_matrices: M"),
        ({"K": np.diag([1.0, 2.0, 3.0])}, "Structure.from_matrices: K: 3 rows, but M has 2"),
        ({"M": np.array([[1.0, np.nan], [np.nan, 1.0]])}, "entry [0, 1] is NaN"),
        ({"dofs": [(0, 7, "ux")]}, "Structure.from_matrices: dofs: 1 equation(s) of the matrices have no row: 1"),
        ({"dofs": [(0, 7, "ux"), (0, 7, "uy")]}, "row 1: equation 0 listed twice (first on row 0)"),
        ({"dofs": [(0, 7, "ux"), (1, 8, "uy")]}, "Structure.from_matrices: dofs: row 1: unknown node 8"),
        ({"dofs": [(0, 7, "ux"), (1, 7, "uq")]}, "row 1: expected `eq,node,dof`"),
        ({"nodes": [[7, 0.0, 0.0], [7, 1.0, 0.0]]}, "Structure.from_matrices: nodes: row 1: node 7 defined twice (first on row 0)"),
        ({"nodes": [[7.5, 0.0, 0.0]]}, "nodes: row 0: expected a non-negative integer id"),
        ({"nodes": [[7, 0.0]]}, "nodes: row 0: 2 values: expected [id, x, y] or [id, x, y, z]"),
    ],
)
def test_bad_structures_are_refused_in_one_line(change: Dict[str, Any], expected: str) -> None:
    m, k = spring_node()
    args: Dict[str, Any] = {"M": m, "K": k, "nodes": [[7, 0.0, 0.0]], "dofs": [(0, 7, "ux"), (1, 7, "uy")]}
    args.update(change)
    with pytest.raises(damper.ScenarioError) as e:
        damper.Structure.from_matrices(**args)
    assert expected in message_of(e)


def test_bad_arguments_raise_type_and_value_errors() -> None:
    m, k = spring_node()
    nodes, dofs = [[7, 0.0, 0.0]], [(0, 7, "ux"), (1, 7, "uy")]
    with pytest.raises(ValueError, match="square matrix"):
        damper.Structure.from_matrices(np.ones((2, 3)), k, nodes, dofs)
    with pytest.raises(TypeError, match="real matrix"):
        damper.Structure.from_matrices(m.astype(complex), k, nodes, dofs)
    with pytest.raises(ValueError, match="craig_bampton"):
        damper.Structure.from_matrices(m, k, nodes, dofs, reduction={"kind": "guyan", "modes": 3})
    with pytest.raises(TypeError, match="damper.Structure"):
        damper.Scenario.load(SCENARIO, structure="frame")  # type: ignore[arg-type]


def test_given_structure_where_it_cannot_go(given: damper.Structure) -> None:
    # A scenario with a [beam]: one host structure.
    with pytest.raises(damper.ScenarioError, match="one host structure") as e:
        damper.Scenario.load(ROOT / "scenarios" / "two_dampers.toml", structure=given)
    message_of(e)
    # The damper kind (the paper's beam, a preset) has no [structure] at all.
    with pytest.raises(damper.ScenarioError, match="unknown field `structure`"):
        damper.Scenario.load(ROOT / "scenarios" / "damper.toml", structure=given)
    # `kind = "given"` written in a file has nothing to stand for.
    text = SCENARIO.read_text().replace('kind = "matrices"', 'kind = "given"', 1)
    with pytest.raises(damper.ScenarioError, match="structure given in memory") as e:
        damper.Scenario.from_str(text, base_dir=SCENARIO.parent, name="frame.toml")
    message_of(e)


def test_frame_simulates_with_its_bare_structure() -> None:
    """``compare=["bare_structure"]`` on the frame: the structure alone, read at the damper's
    node as the damped run reads it (``pin.ux``, ``pin.uy``), the same rows, the summary's
    ``points`` peaks the columns'; ``bare_beam`` is refused."""
    sc = damper.Scenario.load(str(SCENARIO), set={"integrator.t_end": 0.01})
    run = sc.simulate(compare=["bare_structure"])
    assert list(run.comparisons) == ["bare_structure"]
    bare = run.comparisons["bare_structure"]
    assert len(bare) == len(run)
    peak = float(np.max(np.abs(bare["pin.uy [m]"])))
    entry = run.summary["comparisons"]["bare_structure"]
    assert entry["label"] == "bare structure (no mechanism)"
    assert entry["attachments"][0]["peak_displacement"] == pytest.approx(peak, rel=1e-6)
    sway = float(np.max(np.abs(bare["pin.ux [m]"])))
    points = {p["name"]: p["peak_displacement"] for p in entry["points"]}
    assert points["pin.ux"] == pytest.approx(sway, rel=1e-12) and sway > 100 * peak
    with pytest.raises(Exception, match="use \"bare_structure\""):
        sc.simulate(compare=["bare_beam"])
