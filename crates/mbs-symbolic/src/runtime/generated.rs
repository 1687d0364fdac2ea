//! The generated backend: any [`Mechanism<N, NC>`] (code emitted from a model file and
//! compiled in) behind the dynamic [`System`] interface.

use super::mechanism::{Evaluation, Mechanism, PointKinematics};
use super::system::{Backend, ParamError, System, Workspace};

/// Generated code as a [`System`]: the fixed-size outputs are copied into the workspace
/// buffers. Allocation-free.
#[derive(Clone, Debug)]
pub struct GeneratedSystem<T, const N: usize, const NC: usize> {
    mech: T,
    coords: Vec<String>,
    cons: Vec<String>,
    points: Vec<String>,
    params: Vec<String>,
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
            points: owned(mech.point_names()),
            params: owned(mech.param_names()),
            mech,
            coords: owned(coordinate_names),
            cons: owned(constraint_names),
        })
    }

    /// The wrapped mechanism.
    pub fn mechanism(&self) -> &T {
        &self.mech
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
    fn coordinate_names(&self) -> &[String] {
        &self.coords
    }
    fn constraint_names(&self) -> &[String] {
        &self.cons
    }
    fn point_names(&self) -> &[String] {
        &self.points
    }
    fn param_names(&self) -> &[String] {
        &self.params
    }

    fn set_param(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        if !self.params.iter().any(|p| p == name) {
            return Err(ParamError::Unknown {
                name: name.to_string(),
                available: self.params.clone(),
            });
        }
        if !value.is_finite() {
            return Err(ParamError::NotFinite {
                name: name.to_string(),
                value,
            });
        }
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
        for r in 0..N {
            for c in 0..N {
                ws.m[(r, c)] = e.mass[r][c];
            }
            ws.f[r] = e.f[r];
            ws.q[r] = e.q[r];
        }
        for r in 0..NC {
            ws.h[r] = e.h[r];
            ws.a[r] = e.a[r];
            for c in 0..N {
                ws.j[(r, c)] = e.j[r][c];
            }
        }
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

    fn point_kinematics(&self, k: usize, q: &[f64], qd: &[f64], ws: &mut Workspace) -> bool {
        let mut pk = PointKinematics::<N>::default();
        if !self
            .mech
            .point_kinematics(k, &array::<N>(q), &array::<N>(qd), &mut pk)
        {
            return false;
        }
        for r in 0..3 {
            ws.point_p[r] = pk.p[r];
            ws.point_a[r] = pk.a[r];
            for c in 0..N {
                ws.point_j[(r, c)] = pk.j[r][c];
            }
        }
        true
    }

    fn clone_box(&self) -> Box<dyn System> {
        Box::new(self.clone())
    }
}
