//! Solves with the shifted pencil of a linearised hybrid system,
//!
//! ```text
//! S(sigma) = K_R + sigma C_R + sigma^2 M_R + sigma sum_e P^T b_e g_e^T P / (R_e + sigma L_e)
//! ```
//!
//! (see [`super::linear`]; the last term is the inductive generators' currents eliminated
//! at the complex frequency `sigma`), in `O(n)` for a beam of `n` DOFs: the beam part
//! `S_b = C + sigma B + sigma^2 A` is banded (complex symmetric, factorised once by `L D L^T`
//! in the beam's elimination order), the mechanisms add `P^T S_s P` of rank `nb + nf`. With
//! `X = S_b^-1 N` computed once, `S z = b` is
//!
//! ```text
//! y = S_b^-1 b_x,     [I + G S_ww   G S_wu] [w]   [N^T y]
//!                     [S_uw         S_uu  ] [u] = [b_u  ],    G = N^T X,
//! x = y - X (S_ww w + S_wu u)
//! ```
//!
//! one banded solve and one small dense solve per right-hand side (Woodbury's identity in
//! bordered form). At `sigma = 0` this is the reduced stiffness (Newton's matrix of the
//! equilibrium); at `sigma = i omega` the dynamic stiffness of the frequency response; at a
//! real shift the operator of the shift-invert eigen-solver.

use fem_beam::BandedSym;
use nalgebra::{Complex, DMatrix, DVector};

use super::linear::{LinearError, Linearization};

type C64 = Complex<f64>;

/// `L D L^T` of a complex symmetric band matrix (no pivoting), in a given elimination
/// order.
#[derive(Clone, Debug)]
struct BandLdlt {
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

/// The factorised pencil `S(sigma)` of a [`Linearization`] (see the module documentation).
#[derive(Clone, Debug)]
pub struct Pencil {
    sigma: C64,
    n: usize,
    nb: usize,
    band: Option<BandLdlt>,
    /// `X = S_b^-1 N`, one column of length `n` per attachment.
    x: Vec<Vec<C64>>,
    /// `S_s(sigma)`, `ns x ns`.
    small: DMatrix<C64>,
    /// LU of the bordered small system.
    lu: nalgebra::LU<C64, nalgebra::Dyn, nalgebra::Dyn>,
    weights: Vec<Vec<(usize, f64)>>,
}

impl Pencil {
    /// The pencil at `sigma = 0` (the reduced stiffness), or at the first of the small
    /// negative shifts -1, -10, -100 where that is singular (a rigid-body mode): the shift
    /// of the shift-invert eigen-solver and of the modal basis's static responses.
    pub fn near_zero(lin: &Linearization) -> Result<Pencil, LinearError> {
        let mut last = None;
        for sigma in [0.0, -1.0, -10.0, -100.0] {
            match Pencil::new(lin, C64::new(sigma, 0.0)) {
                Ok(p) => return Ok(p),
                Err(e) => last = Some(e),
            }
        }
        Err(last.expect("a shift was tried"))
    }

    /// Factorises `S(sigma)`.
    pub fn new(lin: &Linearization, sigma: C64) -> Result<Pencil, LinearError> {
        let (n, nb, ns) = (lin.structure_dofs(), lin.attachments(), lin.small_dim());
        let one = C64::new(1.0, 0.0);
        let band = match lin.beam_matrices() {
            Some([a, b, c]) => Some(
                BandLdlt::new(
                    &[(one, c), (sigma, b), (sigma * sigma, a)],
                    lin.elimination_order(),
                )
                .map_err(|pivot| LinearError::SingularBeam {
                    shift: [sigma.re, sigma.im],
                    pivot,
                })?,
            ),
            None => None,
        };
        let weights: Vec<Vec<(usize, f64)>> =
            lin.points().iter().map(|p| p.weights.clone()).collect();
        let mut work = vec![C64::new(0.0, 0.0); n];
        let mut x = Vec::with_capacity(nb);
        for w in &weights {
            let mut col = vec![C64::new(0.0, 0.0); n];
            for &(i, v) in w {
                col[i] = C64::new(v, 0.0);
            }
            if let Some(f) = &band {
                f.solve(&mut col, &mut work);
            }
            x.push(col);
        }
        let cplx = |m: &DMatrix<f64>| m.map(|v| C64::new(v, 0.0));
        let mut small = cplx(&lin.ks) + cplx(&lin.cs) * sigma + cplx(&lin.ms) * (sigma * sigma);
        for e in &lin.electrical {
            let f = sigma / (C64::new(e.resistance, 0.0) + sigma * e.inductance);
            for r in 0..ns {
                for c in 0..ns {
                    small[(r, c)] += f * e.torque[r] * e.emf[c];
                }
            }
        }
        // Bordered system [I + G S_ww, G S_wu; S_uw, S_uu].
        let mut g = DMatrix::<C64>::zeros(nb, nb);
        for (c, col) in x.iter().enumerate() {
            for (r, w) in weights.iter().enumerate() {
                g[(r, c)] = w.iter().map(|&(i, v)| col[i] * v).sum();
            }
        }
        let mut border = small.clone();
        if nb > 0 {
            let top = &g * small.rows(0, nb);
            border.rows_mut(0, nb).copy_from(&top);
            for k in 0..nb {
                border[(k, k)] += one;
            }
        }
        let scale = border.iter().fold(1e-300f64, |m, v| m.max(v.norm()));
        let lu = border.lu();
        let tiny = (0..ns).find(|&k| {
            let p = lu.u()[(k, k)].norm();
            p.is_nan() || p <= 1e-14 * scale
        });
        if let Some(pivot) = tiny {
            return Err(LinearError::SingularReduced {
                shift: [sigma.re, sigma.im],
                pivot,
            });
        }
        Ok(Pencil {
            sigma,
            n,
            nb,
            band,
            x,
            small,
            lu,
            weights,
        })
    }

    /// The shift `sigma`.
    pub fn sigma(&self) -> C64 {
        self.sigma
    }

    /// `b <- S(sigma)^-1 b` for `b` in the layout `z = (q^c, u)`.
    pub fn solve_in_place(&self, b: &mut [C64]) {
        let (n, nb) = (self.n, self.nb);
        let ns = self.small.nrows();
        if let Some(f) = &self.band {
            let mut work = vec![C64::new(0.0, 0.0); n];
            f.solve(&mut b[..n], &mut work);
        }
        let mut rhs = DVector::<C64>::zeros(ns);
        for (k, w) in self.weights.iter().enumerate() {
            rhs[k] = w.iter().map(|&(i, v)| b[i] * v).sum();
        }
        for k in nb..ns {
            rhs[k] = b[n + k - nb];
        }
        if ns == 0 {
            return;
        }
        let s = self.lu.solve(&rhs).expect("checked non-singular");
        let t = self.small.rows(0, nb) * &s;
        for (k, col) in self.x.iter().enumerate() {
            for i in 0..n {
                b[i] -= col[i] * t[k];
            }
        }
        for k in nb..ns {
            b[n + k - nb] = s[k];
        }
    }
}

impl Linearization {
    /// `sum_x c_x X z` over `X = K_R, C_R, M_R` with complex coefficients `[k, c, m]`, plus
    /// `sum_e e(e) P^T b_e (g_e^T P z)` for the electrical states: the products of the pencil
    /// and of its derivative with a complex vector.
    fn combination(
        &self,
        z: &[C64],
        [k, c, m]: [C64; 3],
        electrical: impl Fn(&super::linear::ElectricalState) -> C64,
    ) -> Vec<C64> {
        use super::linear::Matrix;
        let d = self.dim();
        let re: Vec<f64> = z.iter().map(|x| x.re).collect();
        let im: Vec<f64> = z.iter().map(|x| x.im).collect();
        let mut out = vec![C64::new(0.0, 0.0); d];
        let (mut a, mut b) = (vec![0.0; d], vec![0.0; d]);
        for (which, coef) in [
            (Matrix::Stiffness, k),
            (Matrix::Damping, c),
            (Matrix::Mass, m),
        ] {
            if coef == C64::new(0.0, 0.0) {
                continue;
            }
            self.mul(which, &re, &mut a);
            self.mul(which, &im, &mut b);
            for ((o, &x), &y) in out.iter_mut().zip(&a).zip(&b) {
                *o += coef * C64::new(x, y);
            }
        }
        if !self.electrical.is_empty() {
            let ns = self.small_dim();
            let mut s = vec![C64::new(0.0, 0.0); ns];
            self.to_small(z, &mut s);
            let mut f = vec![C64::new(0.0, 0.0); ns];
            for e in &self.electrical {
                let gz: C64 = e.emf.iter().zip(&s).map(|(a, b)| *b * *a).sum();
                let coef = electrical(e) * gz;
                for (fi, b) in f.iter_mut().zip(e.torque.iter()) {
                    *fi += coef * *b;
                }
            }
            self.add_from_small(&f, &mut out);
        }
        out
    }

    /// `S(sigma) z` (see the module documentation) for a complex `z`.
    pub fn pencil_mul(&self, sigma: C64, z: &[C64]) -> Vec<C64> {
        let one = C64::new(1.0, 0.0);
        self.combination(z, [one, sigma, sigma * sigma], |e| {
            sigma / (C64::new(e.resistance, 0.0) + sigma * e.inductance)
        })
    }

    /// `S'(sigma) z`, the derivative of the pencil with respect to `sigma`:
    /// `(C_R + 2 sigma M_R + sum_e P^T b_e g_e^T P R_e / (R_e + sigma L_e)^2) z`.
    pub fn pencil_rate_mul(&self, sigma: C64, z: &[C64]) -> Vec<C64> {
        let (zero, one) = (C64::new(0.0, 0.0), C64::new(1.0, 0.0));
        self.combination(z, [zero, one, sigma * 2.0], |e| {
            let den = C64::new(e.resistance, 0.0) + sigma * e.inductance;
            C64::new(e.resistance, 0.0) / (den * den)
        })
    }

    /// The linearisation whose pencil is the transpose of this one's, `S(sigma)^T`: the
    /// small blocks transposed, every electrical state's torque and EMF rows swapped (the
    /// beam's matrices are symmetric). Only its pencil (products, [`Pencil`]) is
    /// meaningful: the left null vectors of `S` are the null vectors of its pencil.
    pub fn transposed(&self) -> Linearization {
        let mut t = self.clone();
        t.ms.transpose_mut();
        t.cs.transpose_mut();
        t.ks.transpose_mut();
        for e in &mut t.electrical {
            std::mem::swap(&mut e.torque, &mut e.emf);
        }
        t
    }
}
