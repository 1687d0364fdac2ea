//! Potential energy `V(q)`: gravity `-sum m_i g . x_Ci` plus `k s^2 / 2` of every force
//! element that stores energy (its stretch comes from `forces.rs`). The gravity part of `F^b`
//! and the spring part of `Q^b` are its gradient.

use super::kinematics::{BodyKinematics, ground_point};
use super::{Builder, forces, vec3};
use crate::expr::Id;

/// `V(q)`: gravity and the springs of the force elements (see
/// [`Symbolic::potential`](super::Symbolic::potential)).
pub(super) fn potential_energy(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Id {
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
    let half = b.dag.constant(0.5);
    for fe in &model.forces {
        if let Some((s, k)) = forces::spring_stretch(b, kin, fe) {
            let s2 = b.dag.mul(s, s);
            let ks2 = b.dag.mul(k, s2);
            let e = b.dag.mul(half, ks2);
            v = b.dag.add(v, e);
        }
    }
    v
}
