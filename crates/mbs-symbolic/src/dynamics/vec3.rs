//! Small symbolic 3-vector and 3x3-matrix algebra on the DAG (row-major `m[row][col]`).
//! Zero entries fold away at construction, so planar models never compute out-of-plane terms.

use crate::expr::{Dag, Id};

/// A symbolic 3-vector.
pub type V3 = [Id; 3];
/// A symbolic 3x3 matrix, row-major.
pub type M3 = [[Id; 3]; 3];

/// The zero vector.
pub fn zero(d: &mut Dag) -> V3 {
    let z = d.zero();
    [z, z, z]
}

/// The identity matrix.
pub fn identity(d: &mut Dag) -> M3 {
    let (z, o) = (d.zero(), d.one());
    [[o, z, z], [z, o, z], [z, z, o]]
}

/// Unit vector along axis `k`.
pub fn unit(d: &mut Dag, k: usize) -> V3 {
    let mut v = zero(d);
    v[k] = d.one();
    v
}

/// `a + b`
pub fn add(d: &mut Dag, a: V3, b: V3) -> V3 {
    [d.add(a[0], b[0]), d.add(a[1], b[1]), d.add(a[2], b[2])]
}

/// `a - b`
pub fn sub(d: &mut Dag, a: V3, b: V3) -> V3 {
    [d.sub(a[0], b[0]), d.sub(a[1], b[1]), d.sub(a[2], b[2])]
}

/// `s a`
pub fn scale(d: &mut Dag, s: Id, a: V3) -> V3 {
    [d.mul(s, a[0]), d.mul(s, a[1]), d.mul(s, a[2])]
}

/// `a . b`
pub fn dot(d: &mut Dag, a: V3, b: V3) -> Id {
    let t0 = d.mul(a[0], b[0]);
    let t1 = d.mul(a[1], b[1]);
    let t2 = d.mul(a[2], b[2]);
    let s = d.add(t0, t1);
    d.add(s, t2)
}

/// `a x b`
pub fn cross(d: &mut Dag, a: V3, b: V3) -> V3 {
    let c = |d: &mut Dag, i: usize, j: usize| {
        let p = d.mul(a[i], b[j]);
        let m = d.mul(a[j], b[i]);
        d.sub(p, m)
    };
    [c(d, 1, 2), c(d, 2, 0), c(d, 0, 1)]
}

/// `m v`
pub fn mat_vec(d: &mut Dag, m: &M3, v: V3) -> V3 {
    let row = |d: &mut Dag, r: usize| dot(d, m[r], v);
    [row(d, 0), row(d, 1), row(d, 2)]
}

/// `m^T v`
pub fn mat_t_vec(d: &mut Dag, m: &M3, v: V3) -> V3 {
    let col = |d: &mut Dag, c: usize| dot(d, [m[0][c], m[1][c], m[2][c]], v);
    [col(d, 0), col(d, 1), col(d, 2)]
}

/// `a b`
pub fn mat_mul(d: &mut Dag, a: &M3, b: &M3) -> M3 {
    let mut out = [[d.zero(); 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            out[r][c] = dot(d, a[r], [b[0][c], b[1][c], b[2][c]]);
        }
    }
    out
}

/// `a + b` for matrices.
pub fn mat_add(d: &mut Dag, a: &M3, b: &M3) -> M3 {
    let mut out = *a;
    for r in 0..3 {
        for c in 0..3 {
            out[r][c] = d.add(a[r][c], b[r][c]);
        }
    }
    out
}

/// Elementary rotation `Rot(axis, t)` given `sin t` and `cos t` (active; columns are the
/// rotated axes, see `model::types`).
pub fn rot(d: &mut Dag, axis: usize, s: Id, c: Id) -> M3 {
    let (z, o) = (d.zero(), d.one());
    let ns = d.neg(s);
    match axis {
        0 => [[o, z, z], [z, c, ns], [z, s, c]],
        1 => [[c, z, s], [z, o, z], [ns, z, c]],
        _ => [[c, ns, z], [s, c, z], [z, z, o]],
    }
}
