//! The numeric backend: the independent recursive reference
//! ([`crate::numeric::NumericModel`]) behind the dynamic [`System`] interface.

use crate::model::Model;
use crate::numeric::NumericModel;

use super::system::{Backend, ElementPower, Names, ParamError, System, Workspace, store_bias};

/// The numeric recursive reference as a [`System`]. It allocates its results (a reference,
/// not a hot path).
#[derive(Clone, Debug)]
pub struct NumericSystem {
    model: Model,
    values: Vec<f64>,
    numeric: NumericModel,
    names: Names,
    param_index: Vec<usize>,
}

impl NumericSystem {
    /// The numeric model of `model` with its default parameter values.
    pub fn new(model: &Model) -> NumericSystem {
        let values = model.default_params();
        let (names, param_index) = Names::of(model);
        NumericSystem {
            numeric: NumericModel::new(model, &values),
            model: model.clone(),
            values,
            names,
            param_index,
        }
    }

    /// The wrapped numeric model.
    pub fn model(&self) -> &NumericModel {
        &self.numeric
    }
}

impl System for NumericSystem {
    fn backend(&self) -> Backend {
        Backend::Numeric
    }
    fn dof(&self) -> usize {
        self.numeric.dof()
    }
    fn rows(&self) -> usize {
        self.numeric.constraint_rows()
    }
    fn names(&self) -> &Names {
        &self.names
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        let k = self.param_index[self.names.param(name, value)?];
        self.values[k] = value;
        self.numeric = NumericModel::new(&self.model, &self.values);
        Ok(())
    }

    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
        ws.m.copy_from(&self.numeric.mass_matrix(q));
        ws.f.copy_from(&self.numeric.f_vector(q, qd));
        ws.q.copy_from(&self.numeric.q_vector(q, qd, t));
        self.evaluate_positions(q, ws);
        store_bias(
            self.numeric.constraint_bias(q, qd).as_slice(),
            ws.a.as_mut_slice(),
        );
    }

    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
        ws.h.copy_from(&self.numeric.constraints(q));
        ws.j.copy_from(&self.numeric.constraint_jacobian(q));
    }

    fn potential_energy(&self, q: &[f64], _ws: &mut Workspace) -> f64 {
        self.numeric.potential_energy(q)
    }

    fn element_power(&self, q: &[f64], qd: &[f64], _ws: &mut Workspace) -> ElementPower {
        let (dissipated, input) = self.numeric.element_power(q, qd);
        ElementPower { dissipated, input }
    }

    fn gravity_load_jacobian(&self, q: &[f64], ws: &mut Workspace) {
        ws.gravity_jacobian
            .copy_from(&self.numeric.gravity_load_jacobian(q));
    }

    fn has_force_elements(&self) -> bool {
        !self.model.forces.is_empty()
    }

    fn point_kinematics(&self, k: usize, q: &[f64], qd: &[f64], ws: &mut Workspace) -> bool {
        if k >= self.names.points.len() {
            return false;
        }
        ws.point_p = self.numeric.point_position(k, q);
        ws.point_j.copy_from(&self.numeric.point_jacobian(k, q));
        store_bias(
            self.numeric.point_bias(k, q, qd).as_slice(),
            ws.point_a.as_mut_slice(),
        );
        true
    }

    fn clone_box(&self) -> Box<dyn System> {
        Box::new(self.clone())
    }
}
