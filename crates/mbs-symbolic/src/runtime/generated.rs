//! The generated backend: any [`Mechanism<N, NC>`] (code emitted from a model file and
//! compiled in) behind the dynamic [`System`] interface.

use super::mechanism::{Evaluation, Mechanism, PointKinematics};
use super::system::{Backend, ElementPower, Names, ParamError, System, Workspace, store_bias};

/// Generated code as a [`System`]: the fixed-size outputs are copied into the workspace
/// buffers. Allocation-free.
#[derive(Clone, Debug)]
pub struct GeneratedSystem<T, const N: usize, const NC: usize> {
    mech: T,
    names: Names,
}

/// A list of names whose length does not match the mechanism's size.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{what}: {found} names given, the mechanism has {expected}")]
pub struct NameCount {
    /// Which names.
    pub what: &'static str,
    /// The mechanism's count.
    pub expected: usize,
    /// Names given.
    pub found: usize,
}

fn owned(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

/// Copies `R` rows of `C` into a column-major `R x C` buffer.
#[inline(always)]
fn copy_rows<const R: usize, const C: usize>(rows: &[[f64; C]; R], out: &mut [f64]) {
    let out = &mut out[..R * C];
    for (r, row) in rows.iter().enumerate() {
        for (c, v) in row.iter().enumerate() {
            out[c * R + r] = *v;
        }
    }
}

/// `M`, `F`, `Q`, `h`, `A`, `J` of a generated evaluation into the workspace. Column-major
/// copies through the raw slices (no per-entry bounds checks: this is on every step of the
/// damper). Inlined into its callers: a call costs about as much as the copies themselves.
#[inline(always)]
fn store_evaluation<const N: usize, const NC: usize>(e: &Evaluation<N, NC>, ws: &mut Workspace) {
    copy_rows(&e.mass, ws.m.as_mut_slice());
    ws.f.as_mut_slice().copy_from_slice(&e.f);
    ws.q.as_mut_slice().copy_from_slice(&e.q);
    ws.h.as_mut_slice().copy_from_slice(&e.h);
    store_bias(&e.a, ws.a.as_mut_slice());
    copy_rows(&e.j, ws.j.as_mut_slice());
}

/// A point's position, bias and Jacobian into the workspace.
#[inline(always)]
fn store_point<const N: usize>(pk: &PointKinematics<N>, ws: &mut Workspace) {
    ws.point_p.as_mut_slice().copy_from_slice(&pk.p);
    store_bias(&pk.a, ws.point_a.as_mut_slice());
    copy_rows(&pk.j, ws.point_j.as_mut_slice());
}

fn array<const N: usize>(v: &[f64]) -> [f64; N] {
    let mut a = [0.0; N];
    a.copy_from_slice(v);
    a
}

impl<T: Mechanism<N, NC>, const N: usize, const NC: usize> GeneratedSystem<T, N, NC> {
    /// Wraps `mech`; the names are the generated `COORDINATE_NAMES` and `CONSTRAINT_NAMES`
    /// constants (point and parameter names come from the [`Mechanism`] trait).
    pub fn new(
        mech: T,
        coordinate_names: &[&str],
        constraint_names: &[&str],
    ) -> Result<Self, NameCount> {
        if coordinate_names.len() != N {
            return Err(NameCount {
                what: "coordinate names",
                expected: N,
                found: coordinate_names.len(),
            });
        }
        if constraint_names.len() != NC {
            return Err(NameCount {
                what: "constraint names",
                expected: NC,
                found: constraint_names.len(),
            });
        }
        Ok(GeneratedSystem {
            names: Names {
                coordinates: owned(coordinate_names),
                constraints: owned(constraint_names),
                points: owned(mech.point_names()),
                units: mech.coordinate_units().to_vec(),
                params: owned(mech.param_names()),
            },
            mech,
        })
    }

    /// The wrapped mechanism.
    pub fn mechanism(&self) -> &T {
        &self.mech
    }

    /// [`System::evaluate_with_point`] through [`Mechanism::evaluate_with_points`] for a
    /// mechanism with exactly `P` named points (`k < P`): the
    /// evaluation and point `k` into `ws`; `false`, with nothing written, when the
    /// mechanism has another number of points.
    fn fused<const P: usize>(
        &self,
        k: usize,
        q: &[f64; N],
        qd: &[f64; N],
        t: f64,
        ws: &mut Workspace,
    ) -> bool {
        let mut e = Evaluation::<N, NC>::default();
        // Built in place (an array repeat expression built one default and copied it).
        let mut points: [PointKinematics<N>; P] =
            core::array::from_fn(|_| PointKinematics::default());
        if !self
            .mech
            .evaluate_with_points(q, qd, t, &mut e, &mut points)
        {
            return false;
        }
        store_evaluation(&e, ws);
        store_point(&points[k], ws);
        true
    }

    /// The wrapped mechanism, mutably (to set run-time parameters).
    pub fn mechanism_mut(&mut self) -> &mut T {
        &mut self.mech
    }
}

impl<T, const N: usize, const NC: usize> System for GeneratedSystem<T, N, NC>
where
    T: Mechanism<N, NC> + Clone + Send + Sync + 'static,
{
    fn backend(&self) -> Backend {
        Backend::Generated
    }
    fn dof(&self) -> usize {
        N
    }
    fn rows(&self) -> usize {
        NC
    }
    fn names(&self) -> &Names {
        &self.names
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        self.names.param(name, value)?;
        // The name is one of the mechanism's own: the generated setter accepts it.
        let known = self.mech.set_param(name, value);
        debug_assert!(known);
        Ok(())
    }

    fn evaluate(&self, q: &[f64], qd: &[f64], t: f64, ws: &mut Workspace) {
        let (q, qd) = (array::<N>(q), array::<N>(qd));
        // One fused generated body: trigonometric leaves and rotations computed once.
        let mut e = Evaluation::<N, NC>::default();
        self.mech.evaluate(&q, &qd, t, &mut e);
        store_evaluation(&e, ws);
    }

    fn evaluate_positions(&self, q: &[f64], ws: &mut Workspace) {
        let q = array::<N>(q);
        let mut h = [0.0; NC];
        let mut j = [[0.0; N]; NC];
        self.mech.constraints(&q, &mut h);
        self.mech.constraint_jacobian(&q, &mut j);
        for r in 0..NC {
            ws.h[r] = h[r];
            for c in 0..N {
                ws.j[(r, c)] = j[r][c];
            }
        }
    }

    fn potential_energy(&self, q: &[f64], _ws: &mut Workspace) -> f64 {
        self.mech.potential_energy(&array::<N>(q))
    }

    fn has_force_elements(&self) -> bool {
        T::FORCE_ELEMENTS
    }

    fn gravity_load_jacobian(&self, q: &[f64], ws: &mut Workspace) {
        let mut g = [[0.0; 3]; N];
        self.mech.gravity_load_jacobian(&array::<N>(q), &mut g);
        for (r, row) in g.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                ws.gravity_jacobian[(r, c)] = *v;
            }
        }
    }

    fn element_power(&self, q: &[f64], qd: &[f64], _ws: &mut Workspace) -> ElementPower {
        let [dissipated, input] = self.mech.element_power(&array::<N>(q), &array::<N>(qd));
        ElementPower { dissipated, input }
    }

    fn point_kinematics(&self, k: usize, q: &[f64], qd: &[f64], ws: &mut Workspace) -> bool {
        let mut pk = PointKinematics::<N>::default();
        if !self
            .mech
            .point_kinematics(k, &array::<N>(q), &array::<N>(qd), &mut pk)
        {
            return false;
        }
        store_point(&pk, ws);
        true
    }

    fn point_position(&self, k: usize, q: &[f64], ws: &mut Workspace) -> bool {
        // The position straight into the workspace; the Jacobian through a row-major array
        // (the workspace's is column-major). No bias computed, `point_a` left unchanged.
        let mut j = [[0.0; N]; 3];
        let p: &mut [f64; 3] = ws.point_p.as_mut();
        if !self.mech.point_position(k, &array::<N>(q), p, &mut j) {
            return false;
        }
        copy_rows(&j, ws.point_j.as_mut_slice());
        true
    }

    fn evaluate_with_point(
        &self,
        k: usize,
        q: &[f64],
        qd: &[f64],
        t: f64,
        ws: &mut Workspace,
    ) -> bool {
        let np = self.names.points.len();
        let (qa, qda) = (array::<N>(q), array::<N>(qd));
        // Mechanisms with at most 8 named points use the fused body, the points on the
        // stack, exactly as many as the mechanism names (zeroing a fixed 8 of them on every
        // call cost about as much as the generated body itself); larger ones make the two
        // separate calls.
        let fused = k < np
            && match np {
                1 => self.fused::<1>(k, &qa, &qda, t, ws),
                2 => self.fused::<2>(k, &qa, &qda, t, ws),
                3 => self.fused::<3>(k, &qa, &qda, t, ws),
                4 => self.fused::<4>(k, &qa, &qda, t, ws),
                5 => self.fused::<5>(k, &qa, &qda, t, ws),
                6 => self.fused::<6>(k, &qa, &qda, t, ws),
                7 => self.fused::<7>(k, &qa, &qda, t, ws),
                8 => self.fused::<8>(k, &qa, &qda, t, ws),
                _ => false,
            };
        if !fused {
            self.evaluate(q, qd, t, ws);
            return self.point_kinematics(k, q, qd, ws);
        }
        true
    }

    fn clone_box(&self) -> Box<dyn System> {
        Box::new(self.clone())
    }
}
