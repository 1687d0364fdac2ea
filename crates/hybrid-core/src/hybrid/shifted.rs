//! The host structure's dynamic stiffness at a complex shift,
//!
//! ```text
//! S_b(sigma) = C + sigma B + sigma^2 A
//! ```
//!
//! factorised for the linearised analyses ([`super::Pencil`]: the equilibrium's Newton
//! matrix at `sigma = 0`, the frequency response at `sigma = i omega`, the shift-invert
//! eigen-solver at a real shift) — one factorisation per structure kind, each in its own
//! storage:
//!
//! - the beam: `L D L^T` of the complex symmetric band (no pivoting) in the beam's
//!   elimination order ([`fem_beam::BeamModel::elimination_order`]), `O(n)`;
//! - an imported sparse model: faer's sparse LU with partial pivoting of the complex
//!   combination ([`fem_structure::ComplexFactor`]);
//! - a Craig–Bampton reduced model: dense LU with partial pivoting.
//!
//! A zero pivot (relative to the matrix's scale), or a solve that is not finite, is a
//! singular dynamic stiffness: a structure without supports at `sigma = 0`, or a shift on
//! one of its eigenvalues.
//!
//! The same file gives the structure's side of the analyses' scales and reports: upper
//! bounds of the infinity norms of `A`, `B`, `C` ([`Structure::norm_bounds`]) and the
//! coordinates that are displacements ([`Structure::translation_dofs`]).

use fem_beam::BandedSym;
use fem_structure::{ComplexFactor, SparseSym, tables::NodeDof};
use nalgebra::{Complex, DMatrix, Dyn, LU};

use super::structure::Structure;

type C64 = Complex<f64>;

/// `L D L^T` of a complex symmetric band matrix (no pivoting), in a given elimination
/// order.
#[derive(Clone, Debug)]
pub(crate) struct BandLdlt {
    n: usize,
    kd: usize,
    /// `order[k]`: the original index eliminated `k`-th.
    order: Vec<usize>,
    /// Column `k` of `L` below the diagonal: `l[k * kd + d - 1] = L[k + d, k]`, `d = 1..=kd`.
    l: Vec<C64>,
    d: Vec<C64>,
}

impl BandLdlt {
    /// Factorises `sum_i c_i A_i` (same size) in elimination order `order`; `Err` with the
    /// elimination index of a zero (relative to the diagonal's scale) pivot.
    fn new(terms: &[(C64, &BandedSym)], order: &[usize]) -> Result<BandLdlt, usize> {
        let n = order.len();
        let mut pos = vec![0; n];
        for (k, &i) in order.iter().enumerate() {
            pos[i] = k;
        }
        // Band width in the elimination order.
        let mut kd = 0;
        for (_, a) in terms {
            let akd = a.half_bandwidth();
            for i in 0..n {
                for j in i.saturating_sub(akd)..i {
                    if a.get(i, j) != 0.0 {
                        kd = kd.max(pos[i].abs_diff(pos[j]));
                    }
                }
            }
        }
        // Dense band of the reordered matrix: a[k * (kd + 1) + d] = S[k + d, k].
        let w = kd + 1;
        let mut a = vec![C64::new(0.0, 0.0); n * w];
        for &(c, m) in terms {
            let mkd = m.half_bandwidth();
            for i in 0..n {
                for j in i.saturating_sub(mkd)..=i {
                    let v = m.get(i, j);
                    if v != 0.0 {
                        let (pi, pj) = (pos[i], pos[j]);
                        let (hi, lo) = (pi.max(pj), pi.min(pj));
                        a[lo * w + (hi - lo)] += c * v;
                    }
                }
            }
        }
        let scale = (0..n).fold(0.0f64, |m, k| m.max(a[k * w].norm()));
        let mut l = vec![C64::new(0.0, 0.0); n * kd.max(1)];
        let mut d = vec![C64::new(0.0, 0.0); n];
        for k in 0..n {
            // d_k = S_kk - sum_j L_kj^2 d_j.
            let mut dk = a[k * w];
            for j in k.saturating_sub(kd)..k {
                let ljk = l[j * kd + (k - j) - 1];
                dk -= ljk * ljk * d[j];
            }
            if dk.norm().is_nan() || dk.norm() <= 1e-14 * scale {
                return Err(k);
            }
            d[k] = dk;
            for i in k + 1..(k + kd + 1).min(n) {
                let mut v = a[k * w + (i - k)];
                for j in i.saturating_sub(kd)..k {
                    v -= l[j * kd + (i - j) - 1] * l[j * kd + (k - j) - 1] * d[j];
                }
                l[k * kd + (i - k) - 1] = v / dk;
            }
        }
        Ok(BandLdlt {
            n,
            kd,
            order: order.to_vec(),
            l,
            d,
        })
    }

    /// `b <- S^-1 b` (original ordering), using `work` (length `n`).
    fn solve(&self, b: &mut [C64], work: &mut [C64]) {
        let (n, kd) = (self.n, self.kd);
        for (k, &i) in self.order.iter().enumerate() {
            work[k] = b[i];
        }
        for k in 0..n {
            let v = work[k];
            for i in k + 1..(k + kd + 1).min(n) {
                work[i] -= self.l[k * kd + (i - k) - 1] * v;
            }
        }
        for k in 0..n {
            work[k] /= self.d[k];
        }
        for k in (0..n).rev() {
            let mut v = work[k];
            for i in k + 1..(k + kd + 1).min(n) {
                v -= self.l[k * kd + (i - k) - 1] * work[i];
            }
            work[k] = v;
        }
        for (k, &i) in self.order.iter().enumerate() {
            b[i] = work[k];
        }
    }
}

/// `S_b(sigma)` of a [`Structure`], factorised.
#[derive(Clone, Debug)]
pub(crate) enum ShiftedFactor {
    /// The beam's complex band `L D L^T`.
    Band(BandLdlt),
    /// An imported model's sparse LU.
    Sparse(Box<ComplexFactor>),
    /// A reduced model's dense LU.
    Dense(LU<C64, Dyn, Dyn>),
}

impl ShiftedFactor {
    /// `b <- S_b^-1 b`.
    pub(crate) fn solve(&self, b: &mut [C64]) {
        match self {
            ShiftedFactor::Band(f) => {
                let mut work = vec![C64::new(0.0, 0.0); b.len()];
                f.solve(b, &mut work);
            }
            ShiftedFactor::Sparse(f) => f.solve_in_place(b),
            ShiftedFactor::Dense(lu) => {
                let mut v = nalgebra::DVectorViewMut::from_slice(b, b.len());
                lu.solve_mut(&mut v);
            }
        }
    }
}

/// Infinity norm of a symmetric sparse matrix (its largest column sum of magnitudes).
fn sparse_norm(a: &SparseSym) -> f64 {
    (0..a.n())
        .map(|j| a.column(j).map(|(_, v)| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Infinity norm of a dense matrix.
fn dense_norm(a: &DMatrix<f64>) -> f64 {
    (0..a.nrows())
        .map(|r| a.row(r).iter().map(|v| v.abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Infinity norm of a band matrix.
fn band_norm(m: &BandedSym) -> f64 {
    let kd = m.half_bandwidth();
    (0..m.size())
        .map(|i| {
            (i.saturating_sub(kd)..(i + kd + 1).min(m.size()))
                .map(|j| m.get(i, j).abs())
                .sum::<f64>()
        })
        .fold(0.0, f64::max)
}

impl Structure {
    /// Factorises `S_b(sigma) = C + sigma B + sigma^2 A`; `Err` with the elimination index
    /// of a zero pivot (`None` where the factorisation does not tell it).
    pub(crate) fn factorize_shifted(&self, sigma: C64) -> Result<ShiftedFactor, Option<usize>> {
        let one = C64::new(1.0, 0.0);
        match self {
            Structure::Beam(b) => BandLdlt::new(
                &[
                    (one, b.stiffness()),
                    (sigma, b.damping()),
                    (sigma * sigma, b.mass()),
                ],
                &b.elimination_order(),
            )
            .map(ShiftedFactor::Band)
            .map_err(Some),
            Structure::Imported(s) => {
                let mut terms = vec![(one, &s.stiffness), (sigma * sigma, &s.mass)];
                if let Some(d) = &s.damping {
                    terms.push((sigma, d));
                }
                ComplexFactor::combination(&terms)
                    .map(|f| ShiftedFactor::Sparse(Box::new(f)))
                    .map_err(|_| None)
            }
            Structure::Reduced { reduced: r, .. } => {
                let c = |m: &DMatrix<f64>| m.map(|v| C64::new(v, 0.0));
                let s = c(&r.stiffness) + c(&r.damping) * sigma + c(&r.mass) * (sigma * sigma);
                let scale = s.iter().fold(0.0f64, |m, v| m.max(v.norm()));
                let lu = s.lu();
                let n = lu.u().nrows();
                match (0..n).find(|&k| {
                    let p = lu.u()[(k, k)].norm();
                    p.is_nan() || p <= 1e-14 * scale
                }) {
                    Some(k) => Err(Some(k)),
                    None => Ok(ShiftedFactor::Dense(lu)),
                }
            }
        }
    }

    /// Upper bounds of the infinity norms of the structure's `[A, B, C]` (mass, damping,
    /// stiffness).
    pub fn norm_bounds(&self) -> [f64; 3] {
        match self {
            Structure::Beam(b) => [
                band_norm(b.mass()),
                band_norm(b.damping()),
                band_norm(b.stiffness()),
            ],
            Structure::Imported(s) => [
                sparse_norm(&s.mass),
                s.damping.as_ref().map_or(0.0, sparse_norm),
                sparse_norm(&s.stiffness),
            ],
            Structure::Reduced { reduced: r, .. } => [
                dense_norm(&r.mass),
                dense_norm(&r.damping),
                dense_norm(&r.stiffness),
            ],
        }
    }

    /// The coordinates that are displacements of the structure's points in the plane of the
    /// mechanisms: the beam's transverse DOFs; an imported model's `ux`, `uy`; a reduced
    /// model's interface `ux`, `uy` (its other coordinates are modal amplitudes). Modes are
    /// normalised on the largest of these, and the equilibrium's largest deflection is taken
    /// over them.
    pub fn translation_dofs(&self) -> Vec<usize> {
        let planar = |d: NodeDof| matches!(d, NodeDof::Ux | NodeDof::Uy);
        match self {
            Structure::Beam(b) => (0..b.dof_count())
                .filter(|&k| matches!(b.dofs().node_dof(k), Some((_, fem_beam::Dof::Transverse))))
                .collect(),
            Structure::Imported(s) => (0..s.dof_count())
                .filter(|&k| planar(s.dofs.of_equation[k].1))
                .collect(),
            Structure::Reduced { full, reduced } => (0..reduced.interface.len())
                .filter(|&k| planar(full.dofs.of_equation[reduced.interface[k]].1))
                .collect(),
        }
    }
}
