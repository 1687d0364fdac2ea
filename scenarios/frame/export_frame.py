#!/usr/bin/env python3
"""Export the bundled steel portal frame from scikit-fem as a `matrices` structure.

The frame (README.md beside this script): two columns clamped at the base and one girder,
all a 20 mm deep, 40 mm thick steel flat bar, 0.8 m wide and 0.6 m high over the outer
faces, modelled as a plane-stress continuum (thickness 40 mm) with biquadratic
nine-node quadrilaterals (scikit-fem's ElementQuad2), two elements through each member's
depth. Quadratic elements represent the linear strain of bending exactly on rectangles, so
they do not lock in bending as bilinear ones do. The base nodes are eliminated (clamped).

Written into the output directory (default: this script's directory):

- M.mtx, K.mtx: Matrix Market coordinate real symmetric, lower triangle, 1-based, values
  printed with %.17g (they read back to the same doubles), entries sorted by column then
  row, exact zeros left out;
- nodes.csv: id,x,y (m), ids 1.. in order of (y, x);
- dofs.csv: eq,node,dof: equation 2 k is node k+1's ux and 2 k + 1 its uy (free nodes only);
- elements.csv: node1,node2: the outline of the mesh (its boundary edges, each split at its
  mid-side node), for drawing only;
- frequencies.csv: mode,frequency_hz: the ten lowest natural frequencies of the exported
  (M, K) by scipy's ARPACK (scipy.sparse.linalg.eigsh) in shift-invert mode about 0,
  tol=0 (machine precision).

Re-running gives byte-identical files on the same machine (BLAS held to one thread so that
no reduction order depends on the thread count):

    python scenarios/frame/export_frame.py [OUTDIR]

Requires numpy, scipy, scikit-fem (the pinned versions of
crates/damper-py/requirements-test.txt).
"""

import os

# One BLAS thread: ARPACK's dot products and matrix-vector products then sum in one order.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import pathlib  # noqa: E402

import numpy as np  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402
from skfem import (  # noqa: E402
    Basis,
    BilinearForm,
    ElementQuad2,
    ElementVector,
    MeshQuad,
    asm,
)
from skfem.helpers import ddot, dot, sym_grad, trace, eye  # noqa: E402

# Geometry (m): outer width, outer height, member depth (in the plane), thickness (out of it).
WIDTH = 0.8
HEIGHT = 0.6
DEPTH = 0.02
THICKNESS = 0.04
# Elements: two through each member's depth, 20 mm long along it.
ACROSS = 2
ALONG = 0.02
# Steel.
YOUNGS_MODULUS = 210e9  # Pa
POISSON = 0.3
DENSITY = 7850.0  # kg/m^3
# Natural frequencies recorded.
MODES = 10
# Positions are rounded to this (m) before they are compared, sorted and written.
POSITION_DIGITS = 9


def grid_lines():
    """The x and y lines of the tensor grid the frame's cells are taken from."""
    h = DEPTH / ACROSS
    col = [i * h for i in range(ACROSS + 1)]  # across a column
    span = WIDTH - 2 * DEPTH
    n_span = round(span / ALONG)
    x = col + [DEPTH + span * i / n_span for i in range(1, n_span)] + [
        WIDTH - DEPTH + c for c in col
    ]
    rise = HEIGHT - DEPTH
    n_rise = round(rise / ALONG)
    y = [rise * i / n_rise for i in range(n_rise)] + [rise + c for c in col]
    return np.array(x), np.array(y)


def mesh():
    """The frame: the cells of the grid inside a column or the girder."""
    x, y = grid_lines()
    m = MeshQuad.init_tensor(x, y)
    c = m.p[:, m.t].mean(axis=1)
    inside = (c[0] < DEPTH) | (c[0] > WIDTH - DEPTH) | (c[1] > HEIGHT - DEPTH)
    return m.remove_elements(np.nonzero(~inside)[0])


def forms():
    """Plane-stress elasticity and mass, per unit area of the plane times the thickness."""
    mu = YOUNGS_MODULUS / (2.0 * (1.0 + POISSON))
    lam = YOUNGS_MODULUS * POISSON / (1.0 - POISSON**2)  # plane-stress lambda

    @BilinearForm
    def stiffness(u, v, w):
        e = sym_grad(u)
        return THICKNESS * ddot(2.0 * mu * e + lam * eye(trace(e), 2), sym_grad(v))

    @BilinearForm
    def mass(u, v, w):
        return THICKNESS * DENSITY * dot(u, v)

    return stiffness, mass


def rounded(p):
    return round(float(p), POSITION_DIGITS) + 0.0  # + 0.0: no "-0.0"


def nodes_of(basis):
    """Every node of the nine-node elements (vertices, mid-sides, centres): its position
    and its (ux, uy) global DOFs of scikit-fem's numbering."""
    pairs = [basis.nodal_dofs, basis.facet_dofs, basis.interior_dofs]
    dofs = np.concatenate([p for p in pairs if p.size], axis=1).T  # (nodes, 2)
    xy = basis.doflocs[:, dofs[:, 0]].T
    return [((rounded(a), rounded(b)), (int(u), int(v))) for (a, b), (u, v) in zip(xy, dofs)]


def outline(m, id_of_position, basis):
    """Boundary edges of the mesh, each split at its mid-side node: (node1, node2) pairs."""
    edges = []
    for f in m.boundary_facets():
        a, b = m.p[:, m.facets[0, f]], m.p[:, m.facets[1, f]]
        mid = basis.doflocs[:, basis.facet_dofs[0, f]]
        ids = [id_of_position.get((rounded(p[0]), rounded(p[1]))) for p in (a, mid, b)]
        for i, j in ((ids[0], ids[1]), (ids[1], ids[2])):
            if i is not None and j is not None:  # base nodes are eliminated
                edges.append((min(i, j), max(i, j)))
    return sorted(set(edges))


def write_mtx(path, a):
    """The lower triangle of symmetric `a` as Matrix Market, sorted by column then row."""
    low = sp.tril(a, format="csc")
    low.eliminate_zeros()
    low.sort_indices()
    n = a.shape[0]
    lines = ["%%MatrixMarket matrix coordinate real symmetric", f"{n} {n} {low.nnz}"]
    for j in range(n):
        for k in range(low.indptr[j], low.indptr[j + 1]):
            lines.append(f"{low.indices[k] + 1} {j + 1} {low.data[k]:.17g}")
    path.write_text("\n".join(lines) + "\n")
    return sym_from_lower(low)


def sym_from_lower(low):
    """The symmetric matrix the lower triangle `low` stands for (what the file says)."""
    return (low + sp.tril(low, k=-1).T).tocsc()


def lowest_frequencies(k, m, count):
    """The `count` lowest natural frequencies (Hz) by ARPACK, shift-invert about 0."""
    n = k.shape[0]
    v0 = np.cos(np.arange(n) * 0.7) + 1.5  # deterministic start
    w = spla.eigsh(k, k=count, M=m, sigma=0.0, which="LM", tol=0.0, v0=v0,
                   return_eigenvectors=False)
    return np.sqrt(np.sort(w)) / (2.0 * np.pi)


def frame():
    """The frame as assembled: `(k, m, nodes, outline)`, the stiffness and mass over the free
    nodes' equations (base eliminated; node i+1 at `nodes[i]`, its ux and uy equations
    2 i and 2 i + 1, the free nodes in order of (y, x)) and the outline's node pairs.
    Python users hand `k`, `m` and the tables to `damper.Structure.from_matrices` directly."""
    m = mesh()
    basis = Basis(m, ElementVector(ElementQuad2()))
    stiffness, mass = forms()
    k_full = asm(stiffness, basis)
    m_full = asm(mass, basis)

    # Free nodes (base eliminated) in order of (y, x); equation 2 i (ux), 2 i + 1 (uy).
    nodes = sorted((p, d) for p, d in nodes_of(basis) if p[1] != 0.0)
    nodes.sort(key=lambda nd: (nd[0][1], nd[0][0]))
    perm = np.array([d for _, uv in nodes for d in uv])
    id_of_position = {p: i + 1 for i, (p, _) in enumerate(nodes)}
    positions = [p for p, _ in nodes]
    return k_full[perm][:, perm], m_full[perm][:, perm], positions, outline(m, id_of_position, basis)


def dof_rows(count):
    """The DOF table's rows `(eq, node, dof)` of `count` nodes (ux, uy each)."""
    return [(2 * i + c, i + 1, name) for i in range(count) for c, name in enumerate(("ux", "uy"))]


def export(out):
    out.mkdir(parents=True, exist_ok=True)
    k, mm, nodes, edges = frame()
    k_written = write_mtx(out / "K.mtx", k)
    m_written = write_mtx(out / "M.mtx", mm)

    rows = ["id,x,y"] + [f"{i + 1},{p[0]!r},{p[1]!r}" for i, p in enumerate(nodes)]
    (out / "nodes.csv").write_text("\n".join(rows) + "\n")
    rows = ["eq,node,dof"] + [f"{e},{n},{d}" for e, n, d in dof_rows(len(nodes))]
    (out / "dofs.csv").write_text("\n".join(rows) + "\n")
    rows = ["node1,node2"] + [f"{a},{b}" for a, b in edges]
    (out / "elements.csv").write_text("\n".join(rows) + "\n")

    f = lowest_frequencies(k_written, m_written, MODES)
    rows = ["mode,frequency_hz"] + [f"{i + 1},{v:.17g}" for i, v in enumerate(f)]
    (out / "frequencies.csv").write_text("\n".join(rows) + "\n")
    return len(nodes), k_written.shape[0]


def main():
    here = pathlib.Path(__file__).resolve().parent
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("outdir", nargs="?", default=str(here), help="output directory")
    args = ap.parse_args()
    n_nodes, n_eq = export(pathlib.Path(args.outdir))
    print(f"{n_nodes} nodes, {n_eq} equations written to {args.outdir}")


if __name__ == "__main__":
    main()
