//! Potential energy `V(q)`: gravity `-sum m_i g . x_Ci` plus the potentials `V_e` of the
//! force elements that store energy (`k s^2 / 2` of the springs, stated with each element in
//! `elements.rs`). The gravity part of `F^b` and the spring part of `Q^b` are its gradient
//! (docs/theory.md section 8).

use super::kinematics::{BodyKinematics, ground_point};
use super::{Builder, vec3};
use crate::expr::Id;

/// `V(q)`: gravity and the element potentials `element_potentials` (see
/// [`Symbolic::potential`](super::Symbolic::potential)).
pub(super) fn potential_energy(
    b: &mut Builder<'_>,
    kin: &[BodyKinematics],
    element_potentials: &[Id],
) -> Id {
    let model = b.model;
    let g = b.v(&model.gravity);
    let mut v = b.dag.zero();
    for (i, body) in model.bodies.iter().enumerate() {
        let m = b.s(&body.mass);
        let c = b.v(&body.com);
        let x = ground_point(&mut b.dag, kin, Some(i), c);
        let gx = vec3::dot(&mut b.dag, g, x);
        let mgx = b.dag.mul(m, gx);
        v = b.dag.sub(v, mgx);
    }
    for &e in element_potentials {
        v = b.dag.add(v, e);
    }
    v
}
