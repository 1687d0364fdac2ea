//! Gradients of the optimiser's figures with respect to the design variables (issue #22):
//! what the KKT residual of `damper optimize` is computed from and what its report gives
//! under `gradients`.
//!
//! **Adjoint (semi-analytic).** The figures of the linearised system are differentiated
//! through its pencil ([`hybrid_core::hybrid::EigenSensitivity`],
//! [`hybrid_core::hybrid::response_derivative`]): the eigen-solution, the peak search and
//! the Lyapunov solution are done once, at the point; the pencil's, the force vectors' and
//! the outputs' derivatives with respect to a design variable come from the linearisations
//! at the points of a difference formula in that variable ([`stencil`]: central, or the
//! one-sided second-order formula at a bound), because a scenario field reaches the model
//! through its builder and its static equilibrium, which have no derivative of their own.
//!
//! - `linear.zeta1`, `linear.f1`, `linear.decay1`: from `d lambda_1`, `lambda_1` the first
//!   eigenvalue: `f = |lambda| / 2 pi`, `zeta = -Re lambda / |lambda|`, `decay = -Re lambda`.
//! - `peak:X:F1:F2`: `d|H(omega*)| = Re(conj(H) dH) / |H|` at the peak's frequency (its
//!   shift does not change the peak to first order: `d|H|/d omega = 0` there, or the
//!   frequency is a band edge, which does not move), `dH = c^T dz + dc^T z`,
//!   `dz = S(i omega*)^-1 (df - dS z)`.
//! - `harmonic.load_power`: the response of each harmonic excitation and its `dz` (the excitation's
//!   frequency may move with the variable: the pencil's shift follows it), the load power
//!   differenced along `z + t dz` (an explicit function of the response).
//! - `linear.max_force`: `reach / |H_att(i omega_1)|` with `omega_1 = |lambda_1|` moving by
//!   `d|lambda_1|`.
//! - `random.rms:OUTPUT` (white-noise excitations, the whole first-order state up to
//!   [`crate::random::DENSE_STATES`] states): with `A P + P A^T + Q = 0`, `J = c^T P c` and the
//!   adjoint `A^T L + L A + c c^T = 0`, `dJ = 2 c^T P dc + tr(L (dA P + P dA^T + dQ))`, `rms =
//!   sqrt(J)`.
//!
//! **Differences.** Every other figure (the reach, the amplification, the disconnected and
//! bare-beam modes, the time-domain figures, an `rms:` under a PSD table) is re-evaluated
//! at the points of the same difference formula. A figure whose adjoint fails (the variable
//! changes the coordinates, a multiple eigenvalue) falls back to the differences; the method
//! used is reported with each gradient.

use hybrid_core::hybrid::{
    EigenMethod, EigenSensitivity, LinearError, Linearization, Pencil, StateOutput, StateSpace,
    lyapunov, modes, pencil_derivative, response_derivative,
};
use nalgebra::{Complex, DMatrix};
use serde::Serialize;

use crate::Error;
use crate::analysis::AnalysisError;
use crate::linear::{HarmonicResponse, LoadLimit, PeakSpec};
use crate::optimize::{Evaluation, FD_STEP, Problem, Variable};
use crate::setup::Linearizable;

type C64 = Complex<f64>;

/// How a gradient was computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// The adjoint of the linear model (see the module documentation).
    Adjoint,
    /// The figure re-evaluated at the points of the difference formula.
    Differences,
}

/// A figure's gradient at a point.
#[derive(Clone, Debug, Serialize)]
pub struct Gradient {
    /// The figure.
    pub figure: String,
    /// Its value at the point.
    pub value: f64,
    /// Its derivative with respect to each variable, in the variable's units.
    pub gradient: Vec<f64>,
    /// How.
    pub method: Method,
}

/// The difference formula of variable `v` at `x`: `(offset, weight)` pairs, the derivative
/// of `g` being `sum w g(x + offset)`; central with step `FD_STEP (hi - lo)`, or the
/// one-sided second-order formula where a central step would leave the bounds.
pub fn stencil(v: &Variable, x: f64) -> Vec<(f64, f64)> {
    let h = FD_STEP * (v.hi - v.lo);
    if x - h < v.lo {
        vec![(0.0, -1.5 / h), (h, 2.0 / h), (2.0 * h, -0.5 / h)]
    } else if x + h > v.hi {
        vec![(0.0, 1.5 / h), (-h, -2.0 / h), (-2.0 * h, 0.5 / h)]
    } else {
        vec![(h, 0.5 / h), (-h, -0.5 / h)]
    }
}

/// A linearised point.
struct Point {
    input: Linearizable,
    lin: Linearization,
}

/// One point of a variable's difference formula: offset, weight and its linearisation.
struct Shifted<'a> {
    offset: f64,
    weight: f64,
    point: &'a Point,
}

fn linearised(p: &Problem<'_>, x: &[f64]) -> Result<Point, Error> {
    let overrides =
        crate::optimize::overrides_at(p.fixed, p.variables.iter().map(|v| v.path.as_str()).zip(x));
    let file = p.path.display().to_string();
    let loaded = crate::scenario::parse_with(p.text, p.path, &overrides)?;
    let (input, lin) = crate::linear::linearise_scenario(&file, &loaded.scenario)?;
    Ok(Point { input, lin })
}

fn linear_error(p: &Problem<'_>) -> impl Fn(LinearError) -> Error {
    let file = p.path.display().to_string();
    move |error| Error::Linear {
        file: file.clone(),
        error,
    }
}

/// The gradients of the figures of [`Problem::gradient_figures`] at `x` (the objective, every
/// constraint's figure, then the right-hand figures of constraints between figures), by the
/// adjoint where the figure has one, else by differences (module documentation).
pub fn gradients(p: &Problem<'_>, x: &[f64]) -> Result<Vec<Gradient>, Error> {
    let names = p.gradient_figures();
    let base = linearised(p, x)?;
    let stencils: Vec<Vec<(f64, f64)>> = p
        .variables
        .iter()
        .zip(x)
        .map(|(v, &xi)| stencil(v, xi))
        .collect();
    // The linearisations at the stencils' points (the point itself where an offset is 0),
    // where a figure has an adjoint.
    let mut shifted_points: Vec<Vec<Option<Point>>> = vec![];
    let any_adjoint = names.iter().any(|n| AdjointFigure::parse(n).is_some());
    for (k, st) in stencils.iter().enumerate().filter(|_| any_adjoint) {
        let mut row = vec![];
        for &(offset, _) in st {
            row.push(if offset == 0.0 {
                None
            } else {
                let mut xs = x.to_vec();
                xs[k] += offset;
                Some(linearised(p, &xs)?)
            });
        }
        shifted_points.push(row);
    }
    let shifted: Vec<Vec<Shifted<'_>>> = stencils
        .iter()
        .zip(&shifted_points)
        .map(|(st, pts)| {
            st.iter()
                .zip(pts)
                .map(|(&(offset, weight), pt)| Shifted {
                    offset,
                    weight,
                    point: pt.as_ref().unwrap_or(&base),
                })
                .collect()
        })
        .collect();
    let adjoint = Adjoint {
        p,
        base: &base,
        shifted: &shifted,
    };
    let mut evaluations: Option<(Evaluation, Vec<Vec<Evaluation>>)> = None;
    let mut out = vec![];
    for name in &names {
        if let Some(Ok((value, gradient))) = adjoint.figure(name) {
            out.push(Gradient {
                figure: name.clone(),
                value,
                gradient,
                method: Method::Adjoint,
            });
            continue;
        }
        let (at, around) = evaluations.get_or_insert_with(|| differences_points(p, x, &stencils));
        // The figure of an evaluation.
        let read = |e: &Evaluation| e.value_of(p, name);
        let value = read(at).ok_or_else(|| {
            AnalysisError::unavailable(
                p.path.display().to_string(),
                format!("the figure {name} is not available at the point"),
            )
        })?;
        let mut gradient = vec![];
        for (st, evals) in stencils.iter().zip(around.iter()) {
            let mut g = 0.0;
            for (&(offset, w), e) in st.iter().zip(evals) {
                let v = if offset == 0.0 { Some(value) } else { read(e) };
                g += w * v.ok_or_else(|| {
                    AnalysisError::unavailable(
                        p.path.display().to_string(),
                        format!(
                            "the figure {name} is not available near the point ({})",
                            e.error.clone().unwrap_or_default()
                        ),
                    )
                })?;
            }
            gradient.push(g);
        }
        out.push(Gradient {
            figure: name.clone(),
            value,
            gradient,
            method: Method::Differences,
        });
    }
    Ok(out)
}

/// The problem's figures evaluated at `x` and at the points of every variable's stencil.
fn differences_points(
    p: &Problem<'_>,
    x: &[f64],
    stencils: &[Vec<(f64, f64)>],
) -> (Evaluation, Vec<Vec<Evaluation>>) {
    let at = crate::optimize::evaluate(p, x, "gradient");
    let around = stencils
        .iter()
        .enumerate()
        .map(|(k, st)| {
            st.iter()
                .map(|&(offset, _)| {
                    if offset == 0.0 {
                        at.clone()
                    } else {
                        let mut xs = x.to_vec();
                        xs[k] += offset;
                        crate::optimize::evaluate(p, &xs, "gradient")
                    }
                })
                .collect()
        })
        .collect();
    (at, around)
}

/// The adjoint gradients at a linearised point (module documentation).
struct Adjoint<'a> {
    p: &'a Problem<'a>,
    base: &'a Point,
    shifted: &'a [Vec<Shifted<'a>>],
}

/// A figure's value and gradient.
type Valued = Result<(f64, Vec<f64>), Error>;

/// The first-order form's `A`, the noise's covariance `Q` and an output row `c` (a column).
type Covariance = (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>);

/// A figure that has an adjoint (module documentation).
enum AdjointFigure<'n> {
    /// `linear.zeta1`, `linear.f1` or `linear.decay1`.
    Eigen(&'n str),
    /// `linear.max_force`.
    MaxForce,
    /// `power`.
    Power,
    /// `peak:X:F1:F2`.
    Peak(PeakSpec),
    /// `rms:OUTPUT` (white noise only: see [`Adjoint::rms`]).
    Rms(&'n str),
}

impl<'n> AdjointFigure<'n> {
    /// The figure `name`, if it has an adjoint.
    fn parse(name: &'n str) -> Option<AdjointFigure<'n>> {
        Some(match name {
            "linear.zeta1" | "linear.f1" | "linear.decay1" => AdjointFigure::Eigen(name),
            "linear.max_force" => AdjointFigure::MaxForce,
            "harmonic.load_power" => AdjointFigure::Power,
            _ => match PeakSpec::parse(name) {
                Some(spec) => AdjointFigure::Peak(spec),
                None => AdjointFigure::Rms(name.strip_prefix("random.rms:")?),
            },
        })
    }
}

/// `z + t dz`: the response moved along its tangent.
fn along(z: &[C64], dz: &[C64], t: f64) -> Vec<C64> {
    z.iter().zip(dz).map(|(a, b)| a + b * t).collect()
}

impl Adjoint<'_> {
    /// The figure `name`'s value and gradient, `None` where it has no adjoint here.
    fn figure(&self, name: &str) -> Option<Valued> {
        Some(match AdjointFigure::parse(name)? {
            AdjointFigure::Eigen(name) => self.eigen(name),
            AdjointFigure::MaxForce => self.max_force(),
            AdjointFigure::Power => self.power(),
            AdjointFigure::Peak(spec) => self.peak(&spec),
            AdjointFigure::Rms(output) => self.rms(output)?,
        })
    }

    fn file(&self) -> String {
        self.p.path.display().to_string()
    }

    /// The first mode and its sensitivity, with `d lambda` per variable.
    fn first_eigenvalue(&self) -> Result<(C64, Vec<C64>), Error> {
        let lin = &self.base.lin;
        let err = linear_error(self.p);
        let found = modes(lin, 1, EigenMethod::Auto).map_err(&err)?;
        let mode = found.first().ok_or_else(|| {
            AnalysisError::unavailable(self.file(), "the linearised system has no mode")
        })?;
        let sens = EigenSensitivity::new(lin, mode).map_err(&err)?;
        let d = self
            .shifted
            .iter()
            .map(|st| {
                let terms: Vec<(f64, &Linearization)> =
                    st.iter().map(|s| (s.weight, &s.point.lin)).collect();
                sens.derivative_over(&terms).map_err(&err)
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok((sens.lambda(), d))
    }

    fn eigen(&self, name: &str) -> Valued {
        let (l, dl) = self.first_eigenvalue()?;
        let an = l.norm();
        let tau = std::f64::consts::TAU;
        let figure = |dl: C64| -> f64 {
            let dan = (l.conj() * dl).re / an;
            match name {
                "linear.f1" => dan / tau,
                "linear.zeta1" => -dl.re / an + l.re * dan / (an * an),
                _ => -dl.re,
            }
        };
        let value = match name {
            "linear.f1" => an / tau,
            "linear.zeta1" => -l.re / an,
            _ => -l.re,
        };
        Ok((value, dl.into_iter().map(figure).collect()))
    }

    /// `dz = S(sigma)^-1 (df - dS z)` for the response `z` of `S(sigma) z = f` along
    /// variable `k`'s stencil, the shift at each point `sigma(point)` and the force
    /// `forces[j]` at its point `j`.
    fn response_tangent(
        &self,
        pencil: &Pencil,
        z: &[C64],
        k: usize,
        sigma: &dyn Fn(&Shifted<'_>) -> C64,
        forces: &[Vec<f64>],
    ) -> Result<Vec<C64>, Error> {
        let st = &self.shifted[k];
        let terms: Vec<(f64, &Linearization, C64)> = st
            .iter()
            .map(|s| (s.weight, &s.point.lin, sigma(s)))
            .collect();
        let ds_z = pencil_derivative(&terms, z).map_err(linear_error(self.p))?;
        let mut df = vec![0.0; z.len()];
        for (s, f) in st.iter().zip(forces) {
            if f.len() != df.len() {
                return Err(Error::Linear {
                    file: self.file(),
                    error: LinearError::LayoutChanged { what: "size" },
                });
            }
            df.iter_mut().zip(f).for_each(|(d, f)| *d += s.weight * f);
        }
        Ok(response_derivative(pencil, &ds_z, &df))
    }

    fn pencil(&self, sigma: C64) -> Result<Pencil, Error> {
        Pencil::new(&self.base.lin, sigma).map_err(linear_error(self.p))
    }

    fn peak(&self, spec: &PeakSpec) -> Valued {
        let file = self.file();
        let (model, lin) = (&self.base.input.model, &self.base.lin);
        let (hz, value) = crate::linear::peak_of(&file, model, lin, spec)?;
        let sigma = C64::new(0.0, std::f64::consts::TAU * hz);
        let (_, f) = crate::linear::peak_input(&file, model, lin, spec)?;
        let pencil = self.pencil(sigma)?;
        let mut z: Vec<C64> = f.iter().map(|&v| C64::new(v, 0.0)).collect();
        pencil.solve_in_place(&mut z);
        let mut gradient = vec![];
        for (k, st) in self.shifted.iter().enumerate() {
            // The output point and the force at each point of the stencil.
            let (points, forces): (Vec<_>, Vec<_>) = st
                .iter()
                .map(|s| crate::linear::peak_input(&file, &s.point.input.model, &s.point.lin, spec))
                .collect::<Result<Vec<_>, _>>()?
                .into_iter()
                .unzip();
            let dz = self.response_tangent(&pencil, &z, k, &|_| sigma, &forces)?;
            let g = st
                .iter()
                .zip(&points)
                .map(|(s, point)| s.weight * point.complex_value(&along(&z, &dz, s.offset)).norm())
                .sum();
            gradient.push(g);
        }
        Ok((value, gradient))
    }

    fn power(&self) -> Valued {
        let file = self.file();
        let (model, lin) = (&self.base.input.model, &self.base.lin);
        let responses = crate::linear::harmonic_responses(&file, model, lin)?;
        let value = crate::linear::load_power(model, lin, &responses);
        let pencils: Vec<Pencil> = responses
            .iter()
            .map(|r| self.pencil(C64::new(0.0, r.omega)))
            .collect::<Result<_, _>>()?;
        let unavailable = |m: &str| Error::from(AnalysisError::unavailable(&file, m));
        let harmonic = |s: &Shifted<'_>, e: usize| {
            s.point
                .input
                .model
                .excitations
                .get(e)
                .and_then(crate::linear::harmonic_of)
                .ok_or_else(|| unavailable("the excitations change with the variable"))
        };
        let mut gradient = vec![];
        for k in 0..self.shifted.len() {
            let mut tangents = vec![];
            for (e, (r, pencil)) in responses.iter().zip(&pencils).enumerate() {
                let sigma = |s: &Shifted<'_>| {
                    C64::new(0.0, harmonic(s, e).map_or(r.omega, |(omega, _)| omega))
                };
                let forces = self.shifted[k]
                    .iter()
                    .map(|s| {
                        let ex = s.point.input.model.excitations.get(e);
                        let ex = ex.ok_or_else(|| {
                            unavailable("the excitations change with the variable")
                        })?;
                        Ok(s.point.lin.force_vector(&ex.target))
                    })
                    .collect::<Result<Vec<_>, Error>>()?;
                tangents.push(self.response_tangent(pencil, &r.z, k, &sigma, &forces)?);
            }
            let mut g = 0.0;
            for s in &self.shifted[k] {
                let moved = responses
                    .iter()
                    .zip(&tangents)
                    .enumerate()
                    .map(|(e, (r, dz))| {
                        let (omega, scale) = harmonic(s, e)?;
                        Ok(HarmonicResponse {
                            omega,
                            scale,
                            z: along(&r.z, dz, s.offset),
                        })
                    })
                    .collect::<Result<Vec<_>, Error>>()?;
                g += s.weight
                    * crate::linear::load_power(&s.point.input.model, &s.point.lin, &moved);
            }
            gradient.push(g);
        }
        Ok((value, gradient))
    }

    fn max_force(&self) -> Valued {
        let (model, lin) = (&self.base.input.model, &self.base.lin);
        let file = self.file();
        let none = || {
            Error::from(AnalysisError::unavailable(
                &file,
                "no admissible load (no excitation or reach)",
            ))
        };
        let e = model.excitations.first().ok_or_else(none)?;
        let (l, dl) = self.first_eigenvalue()?;
        let omega = l.norm();
        let limit = |model, lin: &Linearization, z: &[C64]| {
            LoadLimit::of(model, lin)
                .iter()
                .map(|m| m.max_force(z))
                .reduce(f64::min)
        };
        let sigma = C64::new(0.0, omega);
        let pencil = self.pencil(sigma)?;
        let f = lin.force_vector(&e.target);
        let mut z: Vec<C64> = f.iter().map(|&v| C64::new(v, 0.0)).collect();
        pencil.solve_in_place(&mut z);
        let value = limit(model, lin, &z).ok_or_else(none)?;
        let mut gradient = vec![];
        for (k, dl) in dl.iter().enumerate() {
            let domega = (l.conj() * dl).re / omega;
            let forces = self.shifted[k]
                .iter()
                .map(|s| {
                    let ex = s.point.input.model.excitations.first().ok_or_else(none)?;
                    Ok(s.point.lin.force_vector(&ex.target))
                })
                .collect::<Result<Vec<_>, Error>>()?;
            let shift = |s: &Shifted<'_>| C64::new(0.0, omega + s.offset * domega);
            let dz = self.response_tangent(&pencil, &z, k, &shift, &forces)?;
            let mut g = 0.0;
            for s in &self.shifted[k] {
                let zs = along(&z, &dz, s.offset);
                g += s.weight * limit(&s.point.input.model, &s.point.lin, &zs).ok_or_else(none)?;
            }
            gradient.push(g);
        }
        Ok((value, gradient))
    }

    /// `rms:OUTPUT` by the Lyapunov adjoint, `None` where it does not apply (an excitation
    /// that is not white noise, a state too large for the dense solution).
    fn rms(&self, output: &str) -> Option<Valued> {
        let model = &self.base.input.model;
        let random: Vec<usize> = (0..model.excitations.len())
            .filter(|&e| model.excitations[e].time.is_random())
            .collect();
        let white = |m: &hybrid_core::hybrid::HybridModel, e: usize| match m.excitations[e].time {
            fem_beam::TimeFunction::WhiteNoise { psd, .. } => Some(psd),
            _ => None,
        };
        if random.is_empty()
            || random.iter().any(|&e| white(model, e).is_none())
            || crate::random::states(&self.base.lin) > crate::random::DENSE_STATES
        {
            return None;
        }
        let file = self.file();
        let forces = |pt: &Point| -> Vec<Vec<f64>> {
            let m = &pt.input.model;
            random
                .iter()
                .map(|&e| pt.lin.force_vector(&m.excitations[e].target))
                .collect()
        };
        // The complete modal basis of the point, the same at every point of the stencils
        // (a change of coordinates: `J` is unchanged, but the Schur form of the modal state
        // matrix resolves the slow modes to their own rounding, as `damper random` does).
        let basis = |lin: &Linearization| -> Result<Option<DMatrix<f64>>, Error> {
            let all = modes(lin, lin.dim(), EigenMethod::Dense).map_err(linear_error(self.p))?;
            let v = StateSpace::modal_basis(lin, &all, &forces(self.base))
                .map_err(linear_error(self.p))?;
            Ok((v.ncols() == lin.dim()).then_some(v))
        };
        let basis = match basis(&self.base.lin) {
            Ok(b) => b,
            Err(e) => return Some(Err(e)),
        };
        // The first-order form, the noise's covariance and the output row at a point.
        let system = |pt: &Point| -> Result<Covariance, Error> {
            let m = &pt.input.model;
            let ss = StateSpace::new(&pt.lin, &forces(pt), basis.clone())
                .map_err(linear_error(self.p))?;
            let w: Vec<f64> = random
                .iter()
                .map(|&e| 0.5 * white(m, e).unwrap_or(0.0))
                .collect();
            let bw = DMatrix::from_fn(ss.b.nrows(), ss.b.ncols(), |i, j| ss.b[(i, j)] * w[j]);
            let q = &bw * ss.b.transpose();
            let (target, _, _) = crate::analysis::frf::parse_output(m, output)?;
            let c = ss.row(&StateOutput::position(pt.lin.force_vector(&target)));
            Ok((
                ss.a,
                q,
                DMatrix::from_column_slice(c.len(), 1, c.as_slice()),
            ))
        };
        Some((|| {
            let (a, q, c) = system(self.base)?;
            let (pcov, _) = lyapunov(&a, &q).map_err(linear_error(self.p))?;
            let (adj, _) =
                lyapunov(&a.transpose(), &(&c * c.transpose())).map_err(linear_error(self.p))?;
            let j = (c.transpose() * &pcov * &c)[(0, 0)];
            let value = j.max(0.0).sqrt();
            let mut gradient = vec![];
            for st in self.shifted {
                let mut dj = 0.0;
                for s in st {
                    let (aj, qj, cj) = system(s.point)?;
                    if aj.nrows() != a.nrows() {
                        return Err(Error::Linear {
                            file: file.clone(),
                            error: LinearError::LayoutChanged { what: "size" },
                        });
                    }
                    let ap = &aj * &pcov;
                    let inner = &ap + ap.transpose() + qj;
                    let trace = adj.component_mul(&inner).sum();
                    dj += s.weight * (2.0 * (cj.transpose() * &pcov * &c)[(0, 0)] + trace);
                }
                gradient.push(dj / (2.0 * value));
            }
            Ok((value, gradient))
        })())
    }
}
