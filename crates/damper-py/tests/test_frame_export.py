"""The bundled frame (scenarios/frame) is what its export script writes: the script is
re-run twice into temporary directories (scikit-fem, scipy: pinned in
requirements-test.txt) and compared with itself and with the committed files.

- Two runs on one machine are byte-identical, every file (the script holds BLAS to one
  thread).
- Against the committed files: the tables (nodes, dofs, outline; integers and positions
  rounded to 1e-9 m) byte for byte; the matrices line for line with the same indices and
  values to 1e-12 of the matrix's largest entry (their assembly uses numpy only and was
  byte-identical under every OpenBLAS kernel tried, but numpy's SIMD loops may round
  differently on another processor); the frequencies to 1e-9 relative: ARPACK's result
  moves in the 11th digit with the BLAS kernel (measured up to 9e-11 between OpenBLAS's
  Haswell, Nehalem and Prescott kernels on one machine).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
FRAME = ROOT / "scenarios" / "frame"
SCRIPT = FRAME / "export_frame.py"
TABLES = ["nodes.csv", "dofs.csv", "elements.csv"]
MATRICES = ["M.mtx", "K.mtx"]
ALL = TABLES + MATRICES + ["frequencies.csv"]


def export(out: Path) -> None:
    r = subprocess.run([sys.executable, str(SCRIPT), str(out)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert "995 nodes, 1990 equations" in r.stdout


def mtx_entries(path: Path):
    lines = path.read_text().splitlines()
    head = lines[:2]
    entries = [line.split() for line in lines[2:]]
    return head, [(int(i), int(j)) for i, j, _ in entries], [float(v) for _, _, v in entries]


def test_the_export_is_reproducible_and_is_the_committed_frame(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    export(a)
    export(b)
    for name in ALL:
        assert (a / name).read_bytes() == (b / name).read_bytes(), f"{name}: two runs differ"

    for name in TABLES:
        assert (a / name).read_bytes() == (FRAME / name).read_bytes(), f"{name} differs"

    for name in MATRICES:
        head, idx, val = mtx_entries(a / name)
        head_c, idx_c, val_c = mtx_entries(FRAME / name)
        assert head == head_c, name
        assert idx == idx_c, f"{name}: the pattern differs"
        scale = max(abs(v) for v in val_c)
        worst = max(abs(x - y) for x, y in zip(val, val_c)) / scale
        assert worst <= 1e-12, f"{name}: {worst:e} of the largest entry"

    def frequencies(d: Path):
        lines = (d / "frequencies.csv").read_text().splitlines()
        assert lines[0] == "mode,frequency_hz"
        return [float(line.split(",")[1]) for line in lines[1:]]

    fa, fc = frequencies(a), frequencies(FRAME)
    assert len(fa) == len(fc) == 10
    for i, (x, y) in enumerate(zip(fa, fc)):
        assert abs(x - y) <= 1e-9 * y, f"mode {i + 1}: {x} vs committed {y}"
