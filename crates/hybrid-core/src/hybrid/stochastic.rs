//! Stationary random response of a linearised hybrid system (issue #20): the covariance of
//! the first-order form of [`super::linear`] under white noise, by the Lyapunov equation,
//! and the variance of an output under a PSD by integrating `|H(f)|² G(f)`.
//!
//! # First-order form
//!
//! On a basis `V` of `z` (`z = V q`: the identity, or a modal basis), with the inductive
//! generators' currents as states (see [`super::linear`]):
//!
//! ```text
//! y = (q, q', i_e),   M_r q'' + C_r q' + K_r q + sum_e V^T P^T b_e i_e = V^T F w(t),
//! L_e i_e' = g_e^T P V q' - R_e i_e,          y' = A y + B w,
//! M_r = V^T M_R V, C_r = V^T C_R V, K_r = V^T K_R V
//! ```
//!
//! # Lyapunov equation
//!
//! For independent white noises `w_k` of intensity `W_k` (`E[w_k(t) w_k(s)] = W_k δ(t − s)`;
//! a one-sided PSD `G` per Hz is `W = G / 2`, a two-sided `S0` per rad/s is `W = 2 π S0`)
//! the stationary covariance `P = E[y y^T]` of the stable system solves
//!
//! ```text
//! A P + P A^T + B W B^T = 0
//! ```
//!
//! solved by Bartels & Stewart (1972) on the complex Schur form `A = U T U^H`
//! (`T X + X T^H = −U^H B W B^T U`, column by column from the last, each a triangular solve;
//! `P = U X U^H`). Its relative residual `|A P + P A^T + B W B^T| / (2 |A| |P| + |B W B^T|)`
//! (Frobenius norms) is returned. An output `c^T y` has variance `c^T P c`.
//!
//! # Modal basis
//!
//! For a large beam, `V` is the real parts of the first `K` mode shapes ([`super::modes`]),
//! the static responses `K_R^{-1} F` of the inputs (so the basis is exact at `f = 0`) and the
//! modes' imaginary parts, orthonormalised in that order (modified Gram–Schmidt, twice; a
//! remainder below `1e-8` of its shape's norm dropped): a Galerkin reduction, exact when `V`
//! spans `z`.
//!
//! # PSD integration
//!
//! `σ² = ∫ |H(f)|² G(f) df` with `H` from the harmonic response
//! ([`Linearization::harmonic_response`]: the pencil at `i ω`, currents eliminated), by
//! adaptive Gauss–Kronrod (7–15) quadrature on the intervals between the given breakpoints
//! (the PSD's kinks, the modes' frequencies and half-power points), bisecting the interval of
//! largest error estimate until the summed estimate `|K15 − G7|` is below the tolerance
//! times the integral, for every output. An infinite upper end is mapped to `(0, 1]` by
//! `f = f_b / u`.

use nalgebra::{Complex, DMatrix, DVector};

use super::eigen::Mode;
use super::linear::{LinearError, Linearization, Matrix};
use super::pencil::Pencil;

type C64 = Complex<f64>;

/// A linear output of the state: `z · c_z + z' · c_v` plus, optionally, the current of one
/// inductive generator (an index into [`Linearization::electrical`]).
#[derive(Clone, Debug, PartialEq)]
pub struct StateOutput {
    /// Coefficients on `z` (length [`Linearization::dim`]).
    pub z: Vec<f64>,
    /// Coefficients on `z'`.
    pub v: Vec<f64>,
    /// An inductive generator's current, with coefficient 1.
    pub current: Option<usize>,
}

impl StateOutput {
    /// `c^T z` (a displacement, a coordinate).
    pub fn position(c: Vec<f64>) -> Self {
        let n = c.len();
        StateOutput {
            z: c,
            v: vec![0.0; n],
            current: None,
        }
    }

    /// `c^T z'` (a velocity, a rate).
    pub fn rate(c: Vec<f64>) -> Self {
        let n = c.len();
        StateOutput {
            z: vec![0.0; n],
            v: c,
            current: None,
        }
    }

    /// The current of inductive generator `e` (an index into [`Linearization::electrical`]).
    pub fn current(lin: &Linearization, e: usize) -> Self {
        StateOutput {
            z: vec![0.0; lin.dim()],
            v: vec![0.0; lin.dim()],
            current: Some(e),
        }
    }

    /// The complex output of the harmonic response `z` at `omega` (rad/s).
    pub fn harmonic(&self, lin: &Linearization, z: &[C64], omega: f64) -> C64 {
        let iw = C64::new(0.0, omega);
        let mut out = C64::new(0.0, 0.0);
        for ((zi, a), b) in z.iter().zip(&self.z).zip(&self.v) {
            if *a != 0.0 || *b != 0.0 {
                out += zi * (iw * *b + *a);
            }
        }
        if let Some(e) = self.current {
            let el = &lin.electrical[e];
            let mut s = vec![C64::new(0.0, 0.0); lin.small_dim()];
            lin.to_small(z, &mut s);
            let emf: C64 = s.iter().zip(el.emf.iter()).map(|(s, g)| s * *g).sum();
            out += iw * emf / C64::new(el.resistance, omega * el.inductance);
        }
        out
    }
}

/// The first-order form `y' = A y + B w` of a linearisation on a basis (see the module
/// documentation).
#[derive(Clone, Debug)]
pub struct StateSpace {
    /// `A`.
    pub a: DMatrix<f64>,
    /// `B`: one column per input.
    pub b: DMatrix<f64>,
    /// The basis `V` (`None`: the identity).
    basis: Option<DMatrix<f64>>,
    /// Size of `q`.
    r: usize,
}

/// `V^T X V` for the reduced matrix `which` (`X` itself for the identity basis).
fn project(lin: &Linearization, which: Matrix, v: Option<&DMatrix<f64>>) -> DMatrix<f64> {
    let Some(v) = v else {
        return lin.dense(which);
    };
    let d = lin.dim();
    let mut xv = DMatrix::zeros(d, v.ncols());
    let mut y = vec![0.0; d];
    for c in 0..v.ncols() {
        let col: Vec<f64> = v.column(c).iter().copied().collect();
        lin.mul(which, &col, &mut y);
        xv.column_mut(c).copy_from_slice(&y);
    }
    v.transpose() * xv
}

/// `V^T x` (`x` itself for the identity basis).
fn reduce(v: Option<&DMatrix<f64>>, x: &[f64]) -> DVector<f64> {
    let x = DVector::from_column_slice(x);
    match v {
        Some(v) => v.transpose() * x,
        None => x,
    }
}

impl StateSpace {
    /// The first-order form on the basis `basis` (`None`: the whole `z`) for the generalised
    /// forces `inputs` (each of length [`Linearization::dim`], e.g.
    /// [`Linearization::force_vector`]). Refused when `V^T M_R V` is singular (a coordinate
    /// without mass).
    pub fn new(
        lin: &Linearization,
        inputs: &[Vec<f64>],
        basis: Option<DMatrix<f64>>,
    ) -> Result<StateSpace, LinearError> {
        let v = basis.as_ref();
        let m = project(lin, Matrix::Mass, v);
        let c = project(lin, Matrix::Damping, v);
        let k = project(lin, Matrix::Stiffness, v);
        let r = m.nrows();
        let ne = lin.electrical.len();
        let n = 2 * r + ne;
        let lu = m.clone().lu();
        let Some(minv) = lu.try_inverse() else {
            return Err(LinearError::SingularMass { size: r });
        };
        let mut a = DMatrix::zeros(n, n);
        for i in 0..r {
            a[(i, r + i)] = 1.0;
        }
        a.view_mut((r, 0), (r, r)).copy_from(&(-&minv * &k));
        a.view_mut((r, r), (r, r)).copy_from(&(-&minv * &c));
        let d = lin.dim();
        for (e, el) in lin.electrical.iter().enumerate() {
            // Torque P^T b_e and EMF row g_e^T P, in z, then on the basis.
            let mut torque = vec![0.0; d];
            lin.add_from_small(el.torque.as_slice(), &mut torque);
            let mut emf = vec![0.0; d];
            lin.add_from_small(el.emf.as_slice(), &mut emf);
            let t = &minv * reduce(v, &torque);
            let g = reduce(v, &emf);
            for i in 0..r {
                a[(r + i, 2 * r + e)] = -t[i];
                a[(2 * r + e, r + i)] = g[i] / el.inductance;
            }
            a[(2 * r + e, 2 * r + e)] = -el.resistance / el.inductance;
        }
        let mut b = DMatrix::zeros(n, inputs.len());
        for (j, f) in inputs.iter().enumerate() {
            let mf = &minv * reduce(v, f);
            b.view_mut((r, j), (r, 1)).copy_from(&mf);
        }
        Ok(StateSpace { a, b, basis, r })
    }

    /// The modal basis of the first modes `modes` and the static responses of `inputs` (see
    /// the module documentation), orthonormal, `dim x r`.
    pub fn modal_basis(
        lin: &Linearization,
        modes: &[Mode],
        inputs: &[Vec<f64>],
    ) -> Result<DMatrix<f64>, LinearError> {
        let d = lin.dim();
        // (vector, the norm its remainder is measured against).
        let mut candidates: Vec<(Vec<f64>, f64)> = vec![];
        let shapes: Vec<Vec<C64>> = modes.iter().map(Mode::shape_complex).collect();
        let norm = |s: &[C64]| s.iter().map(|c| c.norm_sqr()).sum::<f64>().sqrt();
        for s in &shapes {
            candidates.push((s.iter().map(|c| c.re).collect(), norm(s)));
        }
        let pencil = Pencil::near_zero(lin)?;
        for f in inputs {
            let mut x: Vec<C64> = f.iter().map(|&v| C64::new(v, 0.0)).collect();
            pencil.solve_in_place(&mut x);
            let re: Vec<f64> = x.iter().map(|c| c.re).collect();
            let n = re.iter().map(|v| v * v).sum::<f64>().sqrt();
            candidates.push((re, n));
        }
        // The imaginary parts last, measured against the whole shape: a lightly damped
        // mode's small imaginary part adds a direction only where it is not rounding.
        for s in &shapes {
            candidates.push((s.iter().map(|c| c.im).collect(), norm(s)));
        }
        let mut basis: Vec<DVector<f64>> = vec![];
        for (c, reference) in candidates {
            let mut x = DVector::from_vec(c);
            if !(reference > 0.0 && reference.is_finite()) {
                continue;
            }
            for _ in 0..2 {
                for q in &basis {
                    let p = q.dot(&x);
                    x.axpy(-p, q, 1.0);
                }
            }
            let norm = x.norm();
            if norm > 1e-8 * reference {
                basis.push(x / norm);
            }
        }
        let mut v = DMatrix::zeros(d, basis.len());
        for (c, q) in basis.iter().enumerate() {
            v.column_mut(c).copy_from(q);
        }
        Ok(v)
    }

    /// Size of `q` (the basis).
    pub fn basis_size(&self) -> usize {
        self.r
    }

    /// The row `c` of an output on the state `y = (q, q', i)`.
    pub fn row(&self, o: &StateOutput) -> DVector<f64> {
        let n = self.a.nrows();
        let r = self.r;
        let mut c = DVector::zeros(n);
        let v = self.basis.as_ref();
        c.rows_mut(0, r).copy_from(&reduce(v, &o.z));
        c.rows_mut(r, r).copy_from(&reduce(v, &o.v));
        if let Some(e) = o.current {
            c[2 * r + e] = 1.0;
        }
        c
    }

    /// The stationary covariance under independent white noises of intensities `w` (one per
    /// input) and the Lyapunov residual.
    pub fn covariance(&self, w: &[f64]) -> Result<(DMatrix<f64>, f64), LinearError> {
        let bw = DMatrix::from_fn(self.b.nrows(), self.b.ncols(), |i, j| self.b[(i, j)] * w[j]);
        let q = &bw * self.b.transpose();
        lyapunov(&self.a, &q)
    }
}

/// Solves `A P + P A^T + Q = 0` (real `A`, symmetric `Q`; `A` stable) by Bartels–Stewart on
/// the complex Schur form (see the module documentation): `P` and the relative residual.
pub fn lyapunov(a: &DMatrix<f64>, q: &DMatrix<f64>) -> Result<(DMatrix<f64>, f64), LinearError> {
    let n = a.nrows();
    if let Some(i) = a.iter().chain(q.iter()).position(|v| !v.is_finite()) {
        return Err(LinearError::NonFinite {
            matrix: "state matrix of the Lyapunov equation",
            row: i % n.max(1),
            column: i / n.max(1),
            value: f64::NAN,
        });
    }
    if n == 0 {
        return Ok((DMatrix::zeros(0, 0), 0.0));
    }
    // Balanced: A_b = D^-1 A D (powers of two, exact), Q_b = D^-1 Q D^-1, P = D P_b D.
    let dscale = balancing(a);
    let ab = DMatrix::from_fn(n, n, |i, j| a[(i, j)] * dscale[j] / dscale[i]);
    let qb = DMatrix::from_fn(n, n, |i, j| q[(i, j)] / (dscale[i] * dscale[j]));
    let ac = ab.map(|v| C64::new(v, 0.0));
    let cap = 30 * n.max(10);
    let schur =
        nalgebra::Schur::try_new(ac, f64::EPSILON, cap).ok_or(LinearError::NoEigenConvergence {
            what: "complex Schur form of the state matrix",
            iterations: cap,
            size: n,
        })?;
    let (u, t) = schur.unpack();
    for i in 0..n {
        if t[(i, i)].re >= 0.0 {
            return Err(LinearError::NotStable {
                eigenvalue: [t[(i, i)].re, t[(i, i)].im],
            });
        }
    }
    let qc = qb.map(|v| C64::new(v, 0.0));
    // T X + X T^H = C, C = -U^H Q U.
    let c = -(u.adjoint() * qc * &u);
    let mut x = DMatrix::<C64>::zeros(n, n);
    for j in (0..n).rev() {
        let mut rhs: DVector<C64> = c.column(j).into_owned();
        for k in j + 1..n {
            let tjk = t[(j, k)].conj();
            if tjk != C64::new(0.0, 0.0) {
                rhs.axpy(-tjk, &x.column(k), C64::new(1.0, 0.0));
            }
        }
        // (T + conj(T_jj) I) x_j = rhs, upper triangular.
        let shift = t[(j, j)].conj();
        for i in (0..n).rev() {
            let mut s = rhs[i];
            for l in i + 1..n {
                s -= t[(i, l)] * x[(l, j)];
            }
            x[(i, j)] = s / (t[(i, i)] + shift);
        }
    }
    let pb = (&u * x * u.adjoint()).map(|v| v.re);
    let p = DMatrix::from_fn(n, n, |i, j| pb[(i, j)] * dscale[i] * dscale[j]);
    let p = 0.5 * (&p + p.transpose());
    let res = a * &p + &p * a.transpose() + q;
    let scale = 2.0 * a.norm() * p.norm() + q.norm();
    let residual = if scale > 0.0 { res.norm() / scale } else { 0.0 };
    Ok((p, residual))
}

/// The diagonal `D` (powers of two) that balances the row and column norms of `D^-1 A D`
/// (Parlett & Reinsch 1969, LAPACK `dgebal` without permutations; at most 100 sweeps): the
/// Schur form of the balanced matrix resolves the slow modes of a stiff system to rounding
/// relative to themselves rather than to the fastest ones.
fn balancing(a: &DMatrix<f64>) -> Vec<f64> {
    let n = a.nrows();
    let mut b = a.clone();
    let mut d = vec![1.0; n];
    for _ in 0..100 {
        let mut done = true;
        for i in 0..n {
            let c: f64 = (0..n).filter(|&j| j != i).map(|j| b[(j, i)].abs()).sum();
            let r: f64 = (0..n).filter(|&j| j != i).map(|j| b[(i, j)].abs()).sum();
            if c == 0.0 || r == 0.0 {
                continue;
            }
            let (mut c2, mut r2, mut f) = (c, r, 1.0);
            let s = c + r;
            for _ in 0..2000 {
                if c2 >= r2 / 2.0 {
                    break;
                }
                c2 *= 2.0;
                r2 /= 2.0;
                f *= 2.0;
            }
            for _ in 0..2000 {
                if c2 < r2 * 2.0 {
                    break;
                }
                c2 /= 2.0;
                r2 *= 2.0;
                f /= 2.0;
            }
            if c2 + r2 < 0.95 * s {
                done = false;
                d[i] *= f;
                for j in 0..n {
                    b[(i, j)] /= f;
                    b[(j, i)] *= f;
                }
            }
        }
        if done {
            break;
        }
    }
    d
}

/// Gauss–Kronrod 7–15 nodes on `[0, 1]` of the half interval (QUADPACK `qk15`).
const XGK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
/// Kronrod weights.
const WGK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_2,
    0.140_653_259_715_525_9,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_8,
];
/// Gauss weights of the nodes `XGK[1], XGK[3], XGK[5], XGK[7]`.
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// The result of [`psd_variances`].
#[derive(Clone, Debug, PartialEq)]
pub struct Quadrature {
    /// Per output, `∫ |H|² G df`.
    pub variances: Vec<f64>,
    /// Per output, the summed `|K15 − G7|` error estimate.
    pub errors: Vec<f64>,
    /// Harmonic solves made.
    pub evaluations: usize,
}

/// One input of [`psd_variances`]: its generalised force and its one-sided PSD per Hz.
pub struct PsdInput<'a> {
    /// The generalised force of a unit input ([`Linearization::force_vector`]).
    pub force: Vec<f64>,
    /// `G(f)` (per Hz).
    pub psd: &'a dyn Fn(f64) -> f64,
}

/// The variances of `outputs` under independent inputs, `Σ_k ∫ |H_k(f)|² G_k(f) df` over
/// `[f_lo, f_hi]` (`f_hi` may be infinite), `H_k` from the pencil
/// ([`Linearization::harmonic_response`]), by `integrate_psd`.
pub fn psd_variances(
    lin: &Linearization,
    inputs: &[PsdInput<'_>],
    outputs: &[StateOutput],
    range: (f64, f64),
    breakpoints: &[f64],
    tol: f64,
    max_intervals: usize,
) -> Result<Quadrature, LinearError> {
    let mut eval = |f: f64, out: &mut [f64]| psd_at(lin, inputs, outputs, f, out);
    integrate_psd(
        &mut eval,
        outputs.len(),
        range,
        breakpoints,
        tol,
        max_intervals,
    )
}

/// The one-sided PSDs of `outputs` at `f` (Hz) under independent inputs,
/// `S_y(f) = Σ_k |H_k(f)|² G_k(f)` with `H_k` from the pencil
/// ([`Linearization::harmonic_response`]), written into `out` (one per output); returns the
/// harmonic solves made (none for an input whose `G_k(f)` is zero). The integrand of
/// [`psd_variances`].
pub fn psd_at(
    lin: &Linearization,
    inputs: &[PsdInput<'_>],
    outputs: &[StateOutput],
    f: f64,
    out: &mut [f64],
) -> Result<usize, LinearError> {
    out.fill(0.0);
    let omega = 2.0 * std::f64::consts::PI * f;
    let mut solves = 0;
    for inp in inputs {
        let g = (inp.psd)(f);
        if g == 0.0 {
            continue;
        }
        let z = lin.harmonic_response(&inp.force, omega)?;
        solves += 1;
        for (o, out) in outputs.iter().zip(out.iter_mut()) {
            *out += o.harmonic(lin, &z, omega).norm_sqr() * g;
        }
    }
    Ok(solves)
}

impl StateSpace {
    /// The variances of the outputs `rows` (from [`StateSpace::row`]) under the independent
    /// inputs of PSDs `psds` (one per input), `Σ_k ∫ |c^T (i ω − A)^{-1} b_k|² G_k df`, by
    /// `integrate_psd` (one dense complex solve per frequency).
    pub fn psd_variances(
        &self,
        psds: &[&dyn Fn(f64) -> f64],
        rows: &[DVector<f64>],
        range: (f64, f64),
        breakpoints: &[f64],
        tol: f64,
        max_intervals: usize,
    ) -> Result<Quadrature, LinearError> {
        // On the complex Schur form A = U T U^H: (i w - A)^-1 B = U (i w - T)^-1 U^H B, one
        // triangular solve (O(N^2)) per input and frequency.
        let n = self.a.nrows();
        let cap = 30 * n.max(10);
        let schur = nalgebra::Schur::try_new(self.a.map(|v| C64::new(v, 0.0)), f64::EPSILON, cap)
            .ok_or(LinearError::NoEigenConvergence {
            what: "complex Schur form of the state matrix",
            iterations: cap,
            size: n,
        })?;
        let (u, t) = schur.unpack();
        let ub = u.adjoint() * self.b.map(|v| C64::new(v, 0.0));
        let cu: Vec<DVector<C64>> = rows
            .iter()
            .map(|c| u.transpose() * c.map(|v| C64::new(v, 0.0)))
            .collect();
        let mut y = DVector::<C64>::zeros(n);
        let mut eval = |f: f64, out: &mut [f64]| -> Result<usize, LinearError> {
            out.fill(0.0);
            let omega = 2.0 * std::f64::consts::PI * f;
            let iw = C64::new(0.0, omega);
            for (k, g) in psds.iter().enumerate() {
                let g = g(f);
                if g == 0.0 {
                    continue;
                }
                for i in (0..n).rev() {
                    let mut s = ub[(i, k)];
                    for l in i + 1..n {
                        s += t[(i, l)] * y[l];
                    }
                    y[i] = s / (iw - t[(i, i)]);
                }
                for (c, out) in cu.iter().zip(out.iter_mut()) {
                    let h: C64 = c.iter().zip(y.iter()).map(|(c, y)| c * y).sum();
                    *out += h.norm_sqr() * g;
                }
            }
            Ok(1)
        };
        integrate_psd(
            &mut eval,
            rows.len(),
            range,
            breakpoints,
            tol,
            max_intervals,
        )
    }
}

/// The integrand of [`integrate_psd`]: writes every output's value at `f` (Hz), returns the
/// solves it made.
pub type Integrand<'a> = dyn FnMut(f64, &mut [f64]) -> Result<usize, LinearError> + 'a;

/// `∫ integrand(f) df` over `[f_lo, f_hi]` (`f_hi` may be infinite) for `no` outputs at
/// once, `eval(f, out)` writing the integrand of every output at `f` (Hz) and returning the
/// solves it made: adaptive Gauss–Kronrod quadrature on the intervals between `breakpoints`
/// to the relative tolerance `tol` (see the module documentation); at most `max_intervals`
/// intervals (then the result as it stands, its error estimates above the tolerance: an
/// integrand whose rounding noise is above the tolerance stops there).
pub fn integrate_psd(
    eval: &mut Integrand<'_>,
    no: usize,
    (f_lo, f_hi): (f64, f64),
    breakpoints: &[f64],
    tol: f64,
    max_intervals: usize,
) -> Result<Quadrature, LinearError> {
    let evaluations = std::cell::Cell::new(0usize);
    // The finite part and the mapped tail `f = f_b / u`, u in (0, 1].
    let finite_hi = if f_hi.is_finite() {
        f_hi
    } else {
        breakpoints
            .iter()
            .copied()
            .filter(|f| f.is_finite())
            .fold(f_lo.max(1.0), f64::max)
            * 2.0
    };
    let mut cuts: Vec<f64> = breakpoints
        .iter()
        .copied()
        .filter(|&f| f > f_lo && f < finite_hi)
        .chain([f_lo, finite_hi])
        .collect();
    cuts.sort_by(f64::total_cmp);
    cuts.dedup();
    // An interval: (a, b, mapped tail?) with its estimate and error per output.
    struct Piece {
        a: f64,
        b: f64,
        tail: bool,
        value: Vec<f64>,
        error: Vec<f64>,
    }
    let mut fk = vec![0.0; no];
    let mut rule = |a: f64, b: f64, tail: bool| -> Result<Piece, LinearError> {
        let (c, h) = (0.5 * (a + b), 0.5 * (b - a));
        let mut k15 = vec![0.0; no];
        let mut g7 = vec![0.0; no];
        for (i, (&x, &wk)) in XGK.iter().zip(&WGK).enumerate() {
            let nodes: &[f64] = if x == 0.0 { &[0.0] } else { &[-x, x] };
            for &s in nodes {
                let u = c + h * s;
                let (f, jac) = if tail {
                    (finite_hi / u, finite_hi / (u * u))
                } else {
                    (u, 1.0)
                };
                evaluations.set(evaluations.get() + eval(f, &mut fk)?);
                for o in 0..no {
                    let v = fk[o] * jac;
                    k15[o] += wk * v;
                    if i % 2 == 1 {
                        g7[o] += WG[i / 2] * v;
                    }
                }
            }
        }
        Ok(Piece {
            a,
            b,
            tail,
            value: k15.iter().map(|v| v * h).collect(),
            error: k15
                .iter()
                .zip(&g7)
                .map(|(k, g)| ((k - g) * h).abs())
                .collect(),
        })
    };
    let mut pieces = vec![];
    for w in cuts.windows(2) {
        pieces.push(rule(w[0], w[1], false)?);
    }
    if !f_hi.is_finite() {
        // u from 0 to 1: the node u = 0 is never evaluated (Gauss–Kronrod nodes are interior).
        pieces.push(rule(0.0, 1.0, true)?);
    }
    loop {
        let total: Vec<f64> = (0..no)
            .map(|o| pieces.iter().map(|p| p.value[o]).sum())
            .collect();
        let err: Vec<f64> = (0..no)
            .map(|o| pieces.iter().map(|p| p.error[o]).sum())
            .collect();
        let worst = (0..no)
            .filter(|&o| err[o] > tol * total[o].abs())
            .max_by(|&x, &y| (err[x] / total[x].abs()).total_cmp(&(err[y] / total[y].abs())));
        // Converged, or at the cap: the error estimates say how far it got (an integrand
        // whose rounding noise is above the tolerance stops here).
        let Some(o) = worst.filter(|_| pieces.len() < max_intervals) else {
            return Ok(Quadrature {
                variances: total,
                errors: err,
                evaluations: evaluations.get(),
            });
        };
        let k = (0..pieces.len())
            .max_by(|&x, &y| pieces[x].error[o].total_cmp(&pieces[y].error[o]))
            .expect("at least one interval");
        let p = pieces.swap_remove(k);
        let m = 0.5 * (p.a + p.b);
        pieces.push(rule(p.a, m, p.tail)?);
        pieces.push(rule(m, p.b, p.tail)?);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Crandall & Mark (1963), eq. (2.43)-(2.48): for `m x'' + c x' + k x = f`, `f` white of
    /// two-sided PSD `S0` per rad/s, `σ_x² = π S0 / (k c)` and `σ_v² = π S0 / (m c)`.
    #[test]
    fn lyapunov_of_a_single_oscillator() {
        let (m, c, k, s0) = (2.0, 0.3, 50.0, 0.7);
        let a = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -k / m, -c / m]);
        let b = DMatrix::from_row_slice(2, 1, &[0.0, 1.0 / m]);
        let w = 2.0 * std::f64::consts::PI * s0;
        let (p, res) = lyapunov(&a, &(&b * b.transpose() * w)).unwrap();
        let pi = std::f64::consts::PI;
        assert!((p[(0, 0)] / (pi * s0 / (k * c)) - 1.0).abs() < 1e-12, "{p}");
        assert!((p[(1, 1)] / (pi * s0 / (m * c)) - 1.0).abs() < 1e-12, "{p}");
        assert!(p[(0, 1)].abs() < 1e-12 * p[(0, 0)]);
        assert!(res < 1e-14, "{res}");
    }

    #[test]
    fn lyapunov_residual_of_a_random_stable_matrix() {
        // A = -(I + R R^T) + (S - S^T): stable (its symmetric part is negative definite).
        let n = 12;
        let mut s = 1u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let r = DMatrix::from_fn(n, n, |_, _| next());
        let sk = DMatrix::from_fn(n, n, |_, _| next());
        let a = -(DMatrix::identity(n, n) + &r * r.transpose()) + (&sk - sk.transpose());
        let b = DMatrix::from_fn(n, 2, |_, _| next());
        let q = &b * b.transpose();
        let (p, res) = lyapunov(&a, &q).unwrap();
        let direct = &a * &p + &p * a.transpose() + &q;
        assert!(direct.norm() < 1e-12 * q.norm(), "{}", direct.norm());
        assert!(res < 1e-14);
        // Symmetric positive semi-definite.
        assert!(p.symmetric_eigenvalues().iter().all(|&l| l > -1e-12));
        assert!(lyapunov(&(-a), &q).is_err());
    }
}
