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

use nalgebra::{Complex, DMatrix, DVector};

use super::linear::{LinearError, Linearization};
use super::shifted::ShiftedFactor;

type C64 = Complex<f64>;

/// The factorised pencil `S(sigma)` of a [`Linearization`] (see the module documentation).
#[derive(Clone, Debug)]
pub struct Pencil {
    sigma: C64,
    n: usize,
    nb: usize,
    band: Option<ShiftedFactor>,
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
        let (n, nb, ns) = (lin.structure_dofs(), lin.couplings().len(), lin.small_dim());
        let one = C64::new(1.0, 0.0);
        let band = match lin.structure() {
            Some(st) => Some(st.factorize_shifted(sigma).map_err(|pivot| {
                LinearError::SingularStructure {
                    kind: st.kind(),
                    shift: [sigma.re, sigma.im],
                    pivot,
                }
            })?),
            None => None,
        };
        let weights: Vec<Vec<(usize, f64)>> = lin.columns().to_vec();
        let mut x = Vec::with_capacity(nb);
        for w in &weights {
            let mut col = vec![C64::new(0.0, 0.0); n];
            for &(i, v) in w {
                col[i] = C64::new(v, 0.0);
            }
            if let Some(f) = &band {
                f.solve(&mut col);
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
            f.solve(&mut b[..n]);
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
