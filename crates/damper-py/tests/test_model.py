"""`Model` against `damper eval` and `damper generate` on every bundled model, for the three
backends."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import damper
from conftest import MODELS, cli

BACKENDS = ["interp", "numeric", "generated"]


def state(n: int) -> tuple:
    q = [0.3 + 0.1 * i for i in range(n)]
    qd = [0.5 - 0.2 * i for i in range(n)]
    return q, qd


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.name)
def test_evaluate_equals_damper_eval(model: Path, backend: str, monkeypatch: pytest.MonkeyPatch, root: Path) -> None:
    monkeypatch.chdir(root)
    rel = str(model.relative_to(root))
    m = damper.Model.load(rel)
    n = len(m.coordinates)
    q, qd = state(n)
    # A run-time parameter changed (every backend takes those).
    params = {m.runtime_parameters[0]: m.parameters[m.runtime_parameters[0]] * 1.25} if m.runtime_parameters else {}
    args = ["eval", rel, "--backend", backend, "--t", "0.1"]
    args += [f"--q={','.join(repr(x) for x in q)}", f"--qd={','.join(repr(x) for x in qd)}"]
    args += [f"--param={k}={float(v)!r}" for k, v in params.items()]
    expected = json.loads(cli(*args).stdout)
    got = m.evaluate(q, qd, t=0.1, backend=backend, params=params)
    assert got["backend"] == expected["backend"] == backend
    assert got["model"] == expected["model"] == m.name
    for key in ("M", "F", "Q", "h", "J", "A"):
        assert isinstance(got[key], np.ndarray)
        np.testing.assert_array_equal(got[key], np.array(expected[key], dtype=float).reshape(got[key].shape), err_msg=key)
    assert got["M"].shape == (n, n)
    assert got["constraint_names"] == expected["constraint_names"]
    assert got["op_count"] == expected["op_count"]
    assert list(got["points"]) == list(expected["points"])
    for name, p in expected["points"].items():
        for key in ("p", "J", "A"):
            np.testing.assert_array_equal(got["points"][name][key], np.array(p[key], dtype=float).reshape(got["points"][name][key].shape))


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.name)
def test_the_three_backends_agree(model: Path) -> None:
    """The interpreter, the numeric recursive reference and the generated code: independent
    implementations of the same equations agree to round-off."""
    m = damper.Model.load(model)
    q, qd = state(len(m.coordinates))
    results = [m.evaluate(q, qd, t=0.1, backend=b) for b in BACKENDS]
    for key in ("M", "F", "Q", "h", "J", "A"):
        scale = max(1.0, float(np.abs(results[0][key]).max(initial=0.0)))
        for r in results[1:]:
            np.testing.assert_allclose(r[key], results[0][key], rtol=0, atol=1e-11 * scale, err_msg=key)


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.name)
def test_generate_rust_and_op_counts_equal_damper_generate(model: Path, tmp_path: Path) -> None:
    out = tmp_path / "gen.rs"
    table = cli("generate", str(model), "-o", str(out), "--stats").stdout
    m = damper.Model.load(model)
    assert m.generate_rust() == out.read_text()
    counts = m.op_counts()
    rows = [line.split() for line in table.splitlines()[1:]]
    assert [r[0] for r in rows[:-1]] == list(counts)
    for r in rows[:-1]:
        c = counts[r[0]]
        assert [c["adds"], c["muls"], c["divs"], c["funcs"], c["negs"], c["total"]] == [int(x) for x in r[1:]]
    named = m.generate_rust(struct_name="MyMechanism")
    assert "pub struct MyMechanism" in named


def test_model_attributes(root: Path) -> None:
    m = damper.Model.load(root / "models" / "double_bar.toml")
    assert m.coordinates == ["q1", "q2"]
    assert m.parameters["L1"] == 0.10
    assert "L1" in m.runtime_parameters


def test_bad_model_arguments_raise_value_errors(root: Path) -> None:
    m = damper.Model.load(root / "models" / "double_bar.toml")
    with pytest.raises(ValueError, match="backend"):
        m.evaluate([0.1, 0.2], [0, 0], backend="fast")
    with pytest.raises(ValueError, match="expected 2 values"):
        m.evaluate([0.1], [0, 0])
    with pytest.raises(ValueError, match="no such parameter"):
        m.evaluate([0.1, 0.2], [0, 0], params={"nope": 1.0})
