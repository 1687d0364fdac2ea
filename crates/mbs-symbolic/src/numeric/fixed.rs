//! The numeric reference behind the fixed-size runtime trait, so that code generic over
//! [`Mechanism`] (the coupled damper, the closed-loop integrator) can run the same scenario
//! with generated code and with the independent numeric implementation.
//!
//! This adapter is a reference, not a hot path: every call goes through the allocating
//! `DMatrix`/`DVector` API of [`NumericModel`].

use crate::model::Model;
use crate::runtime::{Mechanism, PointKinematics};

use super::NumericModel;

/// [`NumericModel`] implementing [`Mechanism<N, NC>`].
#[derive(Clone, Debug)]
pub struct NumericMechanism<const N: usize, const NC: usize> {
    model: Model,
    params: Vec<f64>,
    numeric: NumericModel,
    runtime_names: Vec<&'static str>,
    point_names: Vec<&'static str>,
}

/// The model's sizes do not match the adapter's const parameters.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("model {model:?} has {dof} coordinates and {rows} constraint rows, expected {n} and {nc}")]
pub struct SizeMismatch {
    /// Model name.
    pub model: String,
    /// The model's coordinates.
    pub dof: usize,
    /// The model's constraint rows.
    pub rows: usize,
    /// Expected coordinates.
    pub n: usize,
    /// Expected constraint rows.
    pub nc: usize,
}

impl<const N: usize, const NC: usize> NumericMechanism<N, NC> {
    /// Wraps the model with its default parameter values. The parameter and point names are
    /// leaked once (a few bytes per model) so they can be returned as `&'static str` like the
    /// generated code's constants.
    pub fn new(model: &Model) -> Result<Self, SizeMismatch> {
        if model.dof() != N || model.constraint_rows() != NC {
            return Err(SizeMismatch {
                model: model.name.clone(),
                dof: model.dof(),
                rows: model.constraint_rows(),
                n: N,
                nc: NC,
            });
        }
        let params = model.default_params();
        let leak = |s: &str| -> &'static str { String::leak(s.to_string()) };
        Ok(NumericMechanism {
            numeric: NumericModel::new(model, &params),
            runtime_names: model
                .parameters
                .iter()
                .filter(|p| p.runtime)
                .map(|p| leak(&p.name))
                .collect(),
            point_names: model.points.iter().map(|p| leak(&p.name)).collect(),
            model: model.clone(),
            params,
        })
    }
}

impl<const N: usize, const NC: usize> Mechanism<N, NC> for NumericMechanism<N, NC> {
    fn param_names(&self) -> &[&'static str] {
        &self.runtime_names
    }

    fn set_param(&mut self, name: &str, value: f64) -> bool {
        match self
            .model
            .parameters
            .iter()
            .position(|p| p.runtime && p.name == name)
        {
            Some(k) => {
                self.params[k] = value;
                self.numeric = NumericModel::new(&self.model, &self.params);
                true
            }
            None => false,
        }
    }

    fn point_names(&self) -> &[&'static str] {
        &self.point_names
    }

    fn mass_matrix(&self, q: &[f64; N], m: &mut [[f64; N]; N]) {
        let mm = self.numeric.mass_matrix(q);
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = mm[(i, j)];
            }
        }
    }

    fn f_vector(&self, q: &[f64; N], qd: &[f64; N], f: &mut [f64; N]) {
        f.copy_from_slice(self.numeric.f_vector(q, qd).as_slice());
    }

    fn q_vector(&self, q: &[f64; N], qd: &[f64; N], t: f64, out: &mut [f64; N]) {
        out.copy_from_slice(self.numeric.q_vector(q, qd, t).as_slice());
    }

    fn constraints(&self, q: &[f64; N], h: &mut [f64; NC]) {
        h.copy_from_slice(self.numeric.constraints(q).as_slice());
    }

    fn constraint_jacobian(&self, q: &[f64; N], j: &mut [[f64; N]; NC]) {
        let jj = self.numeric.constraint_jacobian(q);
        for (r, row) in j.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate() {
                *v = jj[(r, c)];
            }
        }
    }

    fn constraint_bias(&self, q: &[f64; N], qd: &[f64; N], a: &mut [f64; NC]) {
        a.copy_from_slice(self.numeric.constraint_bias(q, qd).as_slice());
    }

    fn potential_energy(&self, q: &[f64; N]) -> f64 {
        self.numeric.potential_energy(q)
    }

    fn point_kinematics(
        &self,
        k: usize,
        q: &[f64; N],
        qd: &[f64; N],
        out: &mut PointKinematics<N>,
    ) -> bool {
        if k >= self.point_names.len() {
            return false;
        }
        let p = self.numeric.point_position(k, q);
        let j = self.numeric.point_jacobian(k, q);
        let a = self.numeric.point_bias(k, q, qd);
        for r in 0..3 {
            out.p[r] = p[r];
            out.a[r] = a[r];
            for c in 0..N {
                out.j[r][c] = j[(r, c)];
            }
        }
        true
    }
}
