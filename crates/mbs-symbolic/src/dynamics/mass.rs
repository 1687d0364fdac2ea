//! `M^b` (eq. 11) by composite rigid bodies: the response of the subtree of body `j` to a
//! unit `q''_j` is the composite body of that subtree (mass, first moment, inertia about
//! `O_j`, accumulated from the leaves) times the joint's motion; projecting it on the axes of
//! `j` and of its ancestors gives column `j` of `M^b` on and above the diagonal (the "sum
//! over `l : i <= l`" of eq. 9 done once per subtree).

use super::kinematics::{BodyKinematics, wrench_to_parent};
use super::vec3::{self, M3, V3};
use super::{Builder, joint};
use crate::expr::Id;

/// Composite rigid body: mass, first moment `h = sum m r` and inertia `J` about the origin.
#[derive(Clone, Copy)]
struct Composite {
    m: Id,
    h: V3,
    j: M3,
}

/// `M^b` (eq. 11) by composite bodies: see the module documentation.
pub(super) fn mass_matrix(b: &mut Builder<'_>, kin: &[BodyKinematics]) -> Vec<Id> {
    let model = b.model;
    let n = model.dof();
    let mut comp: Vec<Composite> = Vec::with_capacity(n);
    for body in &model.bodies {
        let m = b.s(&body.mass);
        let c = b.v(&body.com);
        let ic = b.inertia(&body.inertia);
        let h = vec3::scale(&mut b.dag, m, c);
        // J = I_C + m (|c|^2 1 - c c^T)
        let cc = vec3::dot(&mut b.dag, c, c);
        let mut j = ic;
        for r in 0..3 {
            for col in r..3 {
                let outer = b.dag.mul(c[r], c[col]);
                let t = if r == col {
                    b.dag.sub(cc, outer)
                } else {
                    b.dag.neg(outer)
                };
                let mt = b.dag.mul(m, t);
                j[r][col] = b.dag.add(ic[r][col], mt);
                j[col][r] = j[r][col];
            }
        }
        comp.push(Composite { m, h, j });
    }
    for i in (0..n).rev() {
        let Some(p) = model.bodies[i].parent else {
            continue;
        };
        let child = comp[i];
        let d = &mut b.dag;
        let rot = &kin[i].rel_rot;
        let off = kin[i].offset;
        // h' = R h, J' = R J R^T + m(|d|^2 1 - d d^T) + 2 (d.h') 1 - (d h'^T + h' d^T)
        let hr = vec3::mat_vec(d, rot, child.h);
        let rj = vec3::mat_mul(d, rot, &child.j);
        let mut jt = [[d.zero(); 3]; 3];
        for r in 0..3 {
            for c in r..3 {
                jt[r][c] = vec3::dot(d, rj[r], rot[c]);
                jt[c][r] = jt[r][c];
            }
        }
        let dd = vec3::dot(d, off, off);
        let dh = vec3::dot(d, off, hr);
        let two = d.constant(2.0);
        let two_dh = d.mul(two, dh);
        let md = vec3::scale(d, child.m, off);
        let mut add_j = [[d.zero(); 3]; 3];
        for r in 0..3 {
            for c in r..3 {
                // m (|d|^2 delta - d_r d_c) + 2 (d.h) delta - (d_r h_c + h_r d_c)
                let mut t = d.mul(md[r], off[c]);
                t = d.neg(t);
                let cross_terms = {
                    let a = d.mul(off[r], hr[c]);
                    let bb = d.mul(hr[r], off[c]);
                    d.add(a, bb)
                };
                t = d.sub(t, cross_terms);
                if r == c {
                    let mdd = d.mul(child.m, dd);
                    t = d.add(t, mdd);
                    t = d.add(t, two_dh);
                }
                add_j[r][c] = t;
                add_j[c][r] = t;
            }
        }
        let j_shift = vec3::mat_add(d, &jt, &add_j);
        let parent = comp[p];
        let m_new = d.add(parent.m, child.m);
        let h_shift = vec3::add(d, hr, md);
        let h_new = vec3::add(d, parent.h, h_shift);
        let j_new = vec3::mat_add(d, &parent.j, &j_shift);
        comp[p] = Composite {
            m: m_new,
            h: h_new,
            j: j_new,
        };
    }
    let zero = b.dag.zero();
    let mut mass = vec![zero; n * n];
    for i in 0..n {
        let c = comp[i];
        // Wrench of the subtree for a unit q''_i, about O_i in F_i.
        let (mut f, mut nn) =
            joint::unit_motion_wrench(&mut b.dag, &model.bodies[i].joint, c.m, c.h, &c.j);
        mass[i * n + i] = joint::project(model, i, f, nn);
        let mut k = i;
        while let Some(j) = model.bodies[k].parent {
            (f, nn) = wrench_to_parent(&mut b.dag, &kin[k], f, nn);
            let mji = joint::project(model, j, f, nn);
            mass[j * n + i] = mji;
            mass[i * n + j] = mji;
            k = j;
        }
    }
    mass
}
