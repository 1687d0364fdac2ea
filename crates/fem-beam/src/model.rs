//! The assembled, reduced beam model `A q'' + B q' + C q = P(t)`, eq. (44), and what the
//! coupled simulation needs from it every step: the banded matrices, the DOF map, loads at
//! time `t` into a caller buffer, static solutions, modes and interpolation (35).

use crate::banded::{BandedFactor, BandedSym, NewmarkPredictor, PairedKd3};
use crate::beam::{Beam, Damping};
use crate::dofs::DofMap;
use crate::element;
use crate::error::{BeamError, LinalgError};
use crate::modal::{self, ModalMethod, Modes};
use crate::spec::{Dof, TimeFunction};

/// Half-bandwidth of the assembled matrices with nodal ordering (an element couples four
/// consecutive DOFs).
pub const HALF_BANDWIDTH: usize = 3;

/// One load with its time dependence: `P(t) += f(t) * sum(value at dof)`.
#[derive(Clone, Debug, PartialEq)]
struct LoadPattern {
    time: TimeFunction,
    /// (reduced DOF, value); loads on locked DOFs go into the supports and are dropped.
    entries: Vec<(usize, f64)>,
}

/// Where a point `x` of the beam is and how its displacement and rotation follow from the
/// DOFs: `(w, theta) = N(zeta) q_e`, eq. (35)–(36).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeAt {
    /// Element containing the point.
    pub element: usize,
    /// Relative position in the element, 0 to 1.
    pub zeta: f64,
    /// Reduced indices of the element coordinates (26); `None` for locked DOFs.
    pub dofs: [Option<usize>; 4],
    /// Shape-function weights: row 0 displacement, row 1 rotation.
    pub weights: [[f64; 4]; 2],
}

impl ShapeAt {
    /// Displacement and rotation for a reduced DOF vector `q`.
    ///
    /// # Panics
    /// If `q` is shorter than the model's reduced DOF count.
    pub fn apply(&self, q: &[f64]) -> (f64, f64) {
        let (mut w, mut th) = (0.0, 0.0);
        for k in 0..4 {
            if let Some(i) = self.dofs[k] {
                w += self.weights[0][k] * q[i];
                th += self.weights[1][k] * q[i];
            }
        }
        (w, th)
    }
}

/// The reduced finite-element model of a [`Beam`]: banded consistent mass `A`, Rayleigh
/// damping `B` and stiffness `C` over the free DOFs (eqs. 38–44).
#[derive(Clone, Debug)]
pub struct BeamModel {
    beam: Beam,
    dofs: DofMap,
    mass: BandedSym,
    damping: BandedSym,
    stiffness: BandedSym,
    /// The stiffness two rows at a time for the step's product
    /// ([`BeamModel::stiffness_mul_add_to`]); `None` below 8 DOFs.
    stiffness_pairs: Option<PairedKd3>,
    /// The damping two rows at a time for the dissipation's quadratic form
    /// ([`BeamModel::damping_quadratic_form`]); `None` below 8 DOFs.
    damping_pairs: Option<PairedKd3>,
    alpha: f64,
    beta: f64,
    loads: Vec<LoadPattern>,
    rigid: Vec<Vec<f64>>,
    shift: f64,
    /// Eliminate from the last DOF up (supports nearer x = 0 than x = L).
    reverse: bool,
}

/// Rayleigh coefficients giving damping ratios `zeta` at angular frequencies `omega`:
/// `zeta_i = alpha / (2 omega_i) + beta omega_i / 2`, solved exactly:
///
/// ```text
///   alpha = 2 w1 w2 (z1 w2 - z2 w1) / (w2^2 - w1^2),   beta = 2 (z2 w2 - z1 w1) / (w2^2 - w1^2)
/// ```
pub fn rayleigh_from_ratios(omega: [f64; 2], zeta: [f64; 2]) -> (f64, f64) {
    let [w1, w2] = omega;
    let [z1, z2] = zeta;
    let den = w2 * w2 - w1 * w1;
    (
        2.0 * w1 * w2 * (z1 * w2 - z2 * w1) / den,
        2.0 * (z2 * w2 - z1 * w1) / den,
    )
}

impl BeamModel {
    /// Assembles (42)–(43) element by element straight into reduced banded storage (44):
    /// locked rows and columns are never stored. For damping given as modal ratios the
    /// undamped modes are computed first to solve for alpha and beta.
    pub fn new(beam: &Beam) -> Result<Self, BeamError> {
        let dofs = DofMap::new((0..beam.node_count()).map(|n| {
            [
                beam.is_locked(n, Dof::Transverse),
                beam.is_locked(n, Dof::Rotation),
            ]
        }));
        let n = dofs.reduced_len();
        if n == 0 {
            return Err(BeamError::NoFreeDofs);
        }
        let mut mass = BandedSym::zeros(n, HALF_BANDWIDTH);
        let mut stiffness = BandedSym::zeros(n, HALF_BANDWIDTH);
        for (e, el) in beam.elements().iter().enumerate() {
            let seg = &beam.segments()[el.segment];
            let me = element::mass_matrix(seg.density, seg.area, el.length);
            let ke = element::stiffness_matrix(seg.youngs_modulus, seg.second_moment, el.length);
            let map = element_dofs(&dofs, e);
            for r in 0..4 {
                let Some(i) = map[r] else { continue };
                for c in 0..=r {
                    let Some(j) = map[c] else { continue };
                    mass.add(i, j, me[r][c]);
                    stiffness.add(i, j, ke[r][c]);
                }
            }
        }

        let mut rigid: Vec<Vec<f64>> = beam
            .rigid_body_motions()
            .iter()
            .map(|v| dofs.restrict(v))
            .collect();
        modal::a_orthonormalise(&mass, &mut rigid);
        // Shift for the modal factorisation when rigid modes make C singular: a tenth of
        // (pi/L)^4 EJ_min / (rho F)_max, below the lowest elastic eigenvalue of any support
        // set that leaves rigid modes (guided–free: 2.365^4 EJ/(rho F L^4) > 3 * shift), so
        // the shift neither slows convergence nor costs precision in omega^2 = nu - shift.
        let shift = if rigid.is_empty() {
            0.0
        } else {
            let ej = beam
                .segments()
                .iter()
                .map(|s| s.bending_stiffness())
                .fold(f64::INFINITY, f64::min);
            let rho_a = beam
                .segments()
                .iter()
                .map(|s| s.mass_per_length())
                .fold(0.0, f64::max);
            0.1 * (std::f64::consts::PI / beam.length()).powi(4) * ej / rho_a
        };

        let mut model = Self {
            beam: beam.clone(),
            dofs,
            damping: BandedSym::zeros(n, HALF_BANDWIDTH),
            mass,
            stiffness_pairs: PairedKd3::new(&stiffness),
            damping_pairs: None,
            stiffness,
            alpha: 0.0,
            beta: 0.0,
            loads: Vec::new(),
            rigid,
            shift,
            reverse: false,
        };
        // Start the elimination at the end farther from the supports (see
        // `BandedSym::factorize_reversed`): compare the distance of the first locked DOF from
        // the start with that of the last locked DOF from the end.
        let full = model.dofs.full_len();
        let is_locked = |f: &usize| model.dofs.reduced_of_full(*f).is_none();
        if let (Some(first), Some(last)) =
            ((0..full).find(is_locked), (0..full).rev().find(is_locked))
        {
            model.reverse = first < full - 1 - last;
        }

        let (alpha, beta) = match beam.damping() {
            Damping::Rayleigh { alpha, beta } => (alpha, beta),
            Damping::ModalRatios { modes, ratios } => model.solve_rayleigh(modes, ratios)?,
        };
        // Eq. (40) assembled: sum_e (alpha A_e + beta C_e) = alpha A + beta C.
        model.alpha = alpha;
        model.beta = beta;
        model.damping.scaled_add(alpha, &model.mass)?;
        model.damping.scaled_add(beta, &model.stiffness)?;
        model.damping_pairs = PairedKd3::new(&model.damping);
        model.loads = model.load_patterns();
        Ok(model)
    }

    fn solve_rayleigh(&self, modes: [usize; 2], ratios: [f64; 2]) -> Result<(f64, f64), BeamError> {
        let top = modes[0].max(modes[1]);
        if top > self.dofs.reduced_len() {
            return Err(BeamError::Damping(format!(
                "mode {top} does not exist (the beam has {} free DOFs)",
                self.dofs.reduced_len()
            )));
        }
        let m = self.modes(top)?;
        let omega = m.angular_frequencies();
        for &mode in &modes {
            if mode <= m.rigid_body_count() {
                return Err(BeamError::Damping(format!(
                    "mode {mode} is a rigid-body mode (0 Hz) and cannot be given a damping ratio; target elastic modes"
                )));
            }
        }
        let w = [omega[modes[0] - 1], omega[modes[1] - 1]];
        if (w[1] - w[0]).abs() <= 1e-9 * w[0].max(w[1]) {
            return Err(BeamError::Damping(format!(
                "modes {} and {} have the same frequency ({} Hz): Rayleigh damping cannot give them different ratios",
                modes[0],
                modes[1],
                w[0] / (2.0 * std::f64::consts::PI)
            )));
        }
        let (alpha, beta) = rayleigh_from_ratios(w, ratios);
        if alpha < 0.0 || beta < 0.0 {
            return Err(BeamError::Damping(format!(
                "ratios {} on mode {} and {} on mode {} need alpha = {alpha:e}, beta = {beta:e}; a negative \
                 coefficient would make some modes unstable (raise the ratio of the higher mode)",
                ratios[0], modes[0], ratios[1], modes[1]
            )));
        }
        Ok((alpha, beta))
    }

    fn load_patterns(&self) -> Vec<LoadPattern> {
        let mut patterns = Vec::new();
        for l in self.beam.nodal_loads() {
            let mut entries = Vec::new();
            if let Some(i) = self.dofs.reduced(l.node, Dof::Transverse) {
                entries.push((i, l.force));
            }
            if let Some(i) = self.dofs.reduced(l.node, Dof::Rotation) {
                entries.push((i, l.moment));
            }
            entries.retain(|&(_, v)| v != 0.0);
            patterns.push(LoadPattern {
                time: l.time.clone(),
                entries,
            });
        }
        for d in self.beam.distributed_loads() {
            let seg = &self.beam.segments()[d.segment];
            // Accumulate the element loads node by node (neighbouring elements share nodes).
            let mut acc: Vec<(usize, f64)> = Vec::new();
            for e in seg.first_element..seg.first_element + seg.elements {
                let pe = element::uniform_load(d.q, self.beam.elements()[e].length);
                for (k, dof) in element_dofs(&self.dofs, e).into_iter().enumerate() {
                    let Some(i) = dof else { continue };
                    // DOFs grow along the beam: a shared node's DOFs are the last two
                    // entries, so the search stays O(1) and the whole pass O(n).
                    let tail = acc.len().saturating_sub(2);
                    match acc[tail..].iter().position(|&(j, _)| j == i) {
                        Some(pos) => acc[tail + pos].1 += pe[k],
                        None => acc.push((i, pe[k])),
                    }
                }
            }
            patterns.push(LoadPattern {
                time: d.time.clone(),
                entries: acc,
            });
        }
        patterns
    }

    /// The validated beam description.
    pub fn beam(&self) -> &Beam {
        &self.beam
    }

    /// The map between full and reduced DOF indices.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Number of free DOFs (size of the reduced matrices and vectors).
    pub fn dof_count(&self) -> usize {
        self.dofs.reduced_len()
    }

    /// Reduced index of a node's DOF; `None` when locked or the node does not exist.
    pub fn dof_index(&self, node: usize, dof: Dof) -> Option<usize> {
        self.dofs.reduced(node, dof)
    }

    /// Consistent mass matrix `A^c`, eqs. (38), (43), (44).
    pub fn mass(&self) -> &BandedSym {
        &self.mass
    }

    /// Rayleigh damping matrix `B^c = alpha A^c + beta C^c`, eqs. (40), (43), (44).
    pub fn damping(&self) -> &BandedSym {
        &self.damping
    }

    /// Stiffness matrix `C^c`, eqs. (39), (43), (44).
    pub fn stiffness(&self) -> &BandedSym {
        &self.stiffness
    }

    /// `y = b + s C x` (the step's `P - C x`), bit-identical to
    /// [`BandedSym::mul_add_to`] on [`BeamModel::stiffness`]: with 8 DOFs or more through
    /// the rows two at a time ([`PairedKd3`]); no allocation.
    ///
    /// # Panics
    /// If `x`, `b` or `y` does not have length [`BeamModel::dof_count`].
    pub fn stiffness_mul_add_to(&self, s: f64, x: &[f64], b: &[f64], y: &mut [f64]) {
        match &self.stiffness_pairs {
            Some(p) => p.mul_add_to(s, x, b, y),
            None => self.stiffness.mul_add_to(s, x, b, y),
        }
    }

    /// The folded step's predictor and product: `p.predict(old, out)` (`old = [q, v, a]`,
    /// `out = [q^, v^, x]`) then `y = b - C x`, bit-identical to
    /// [`NewmarkPredictor::predict`] then [`BeamModel::stiffness_mul_add_to`] with `s = -1`:
    /// with 8 DOFs or more in one pass ([`PairedKd3::predict_mul_sub`]); no allocation.
    ///
    /// # Panics
    /// If a vector does not have length [`BeamModel::dof_count`].
    pub fn predict_stiffness_mul_sub(
        &self,
        p: &NewmarkPredictor,
        old: [&[f64]; 3],
        out: [&mut [f64]; 3],
        b: &[f64],
        y: &mut [f64],
    ) {
        match &self.stiffness_pairs {
            Some(pairs) => pairs.predict_mul_sub(p, old, out, b, y),
            None => {
                let [q_hat, v_hat, x] = out;
                p.predict(old, [q_hat, v_hat, &mut *x]);
                self.stiffness.mul_add_to(-1.0, x, b, y);
            }
        }
    }

    /// `x^T B x` (the Rayleigh dissipation `v^T B v` of every step), bit-identical to
    /// [`BandedSym::quadratic_form`] on [`BeamModel::damping`]: with 8 DOFs or more
    /// through the rows two at a time ([`PairedKd3`]).
    ///
    /// # Panics
    /// If `x` does not have length [`BeamModel::dof_count`].
    pub fn damping_quadratic_form(&self, x: &[f64]) -> f64 {
        match &self.damping_pairs {
            Some(p) => p.quadratic_form(x),
            None => self.damping.quadratic_form(x),
        }
    }

    /// The Rayleigh coefficients `(alpha, beta)` in use (solved from the target ratios when
    /// the damping was given that way).
    pub fn rayleigh_coefficients(&self) -> (f64, f64) {
        (self.alpha, self.beta)
    }

    /// Number of rigid-body modes the supports leave (0, 1 or 2).
    pub fn rigid_body_count(&self) -> usize {
        self.rigid.len()
    }

    /// The load vector `P^c(t)` of the description (nodal forces and moments, consistent
    /// loads of distributed loads, each times its time function) into `out`; no
    /// allocation. Loads on locked DOFs are carried by the supports and do not appear.
    ///
    /// # Panics
    /// If `out` does not have length [`dof_count`](Self::dof_count).
    pub fn load_into(&self, t: f64, out: &mut [f64]) {
        assert_eq!(
            out.len(),
            self.dof_count(),
            "BeamModel::load_into: buffer has the wrong length"
        );
        out.fill(0.0);
        for p in &self.loads {
            let f = p.time.value(t);
            if f != 0.0 {
                for &(i, v) in &p.entries {
                    out[i] += f * v;
                }
            }
        }
    }

    /// Whether the description has loads (else [`load_into`](Self::load_into) writes zeros
    /// at every `t`, and a time integration need not evaluate it).
    pub fn has_loads(&self) -> bool {
        !self.loads.is_empty()
    }

    /// The time-independent part of the load vector: the loads whose time function is
    /// [`TimeFunction::Constant`] (the static loads of an equilibrium; harmonic, step and
    /// table loads are the dynamic input) into `out`.
    ///
    /// # Panics
    /// If `out` does not have length [`dof_count`](Self::dof_count).
    pub fn constant_load_into(&self, out: &mut [f64]) {
        assert_eq!(
            out.len(),
            self.dof_count(),
            "BeamModel::constant_load_into: buffer has the wrong length"
        );
        out.fill(0.0);
        for p in self
            .loads
            .iter()
            .filter(|p| p.time == TimeFunction::Constant)
        {
            for &(i, v) in &p.entries {
                out[i] += v;
            }
        }
    }

    /// The load vector at time `t` (allocating wrapper of [`load_into`](Self::load_into)).
    pub fn load(&self, t: f64) -> Vec<f64> {
        let mut p = vec![0.0; self.dof_count()];
        self.load_into(t, &mut p);
        p
    }

    /// Static deflection `C q = p` for a reduced load vector `p`.
    pub fn static_deflection(&self, p: &[f64]) -> Result<Vec<f64>, BeamError> {
        if p.len() != self.dof_count() {
            return Err(BeamError::Length {
                what: "load vector",
                got: p.len(),
                expected: self.dof_count(),
            });
        }
        if !self.rigid.is_empty() {
            return Err(BeamError::Unconstrained {
                rigid_modes: self.rigid.len(),
            });
        }
        let factor = self.factorize(&self.stiffness)?;
        let mut q = vec![0.0; p.len()];
        let mut work = vec![0.0; p.len()];
        // A plain solve loses ~log10(n^3) digits, and so would refinement with the assembled
        // (rounded) matrix: refine with the element-wise residual instead.
        factor.refine_with(p, &mut q, &mut work, |q, p, r| {
            self.stiffness_residual_into(q, p, r)
        });
        Ok(q)
    }

    /// `r = p - C q`, computed element by element in deformation form instead of with the
    /// assembled matrix: with the end rotations relative to the chord
    ///
    /// ```text
    ///   phi_i = theta_i - (w_j - w_i)/l,   phi_j = theta_j - (w_j - w_i)/l
    ///   m_i = (E J / l)(4 phi_i + 2 phi_j),  m_j = (E J / l)(2 phi_i + 4 phi_j),  v = (m_i + m_j)/l
    ///   C_e q_e = (v, m_i, -v, m_j)
    /// ```
    ///
    /// which is (39) factored as `T^T D T`. Rigid-body motions give exactly zero deformation
    /// here, whereas the rounded entries of the assembled `C` do not annihilate them: that
    /// mismatch costs a relative error ~ `(L/h)^3 eps` in static deflections. Used for the
    /// iterative refinement of static and modal solves ([`BandedFactor::refine_with`]).
    /// `O(n)`, no allocation.
    ///
    /// [`BandedFactor::refine_with`]: crate::BandedFactor::refine_with
    ///
    /// # Panics
    /// If the slices do not have length [`dof_count`](Self::dof_count).
    pub fn stiffness_residual_into(&self, q: &[f64], p: &[f64], r: &mut [f64]) {
        let n = self.dof_count();
        assert!(
            q.len() == n && p.len() == n && r.len() == n,
            "BeamModel::stiffness_residual_into: vectors must have length {n}"
        );
        r.copy_from_slice(p);
        let get = |d: Option<usize>| d.map_or(0.0, |i| q[i]);
        let segments = self.beam.segments();
        for (e, el) in self.beam.elements().iter().enumerate() {
            let dofs = element_dofs(&self.dofs, e);
            let l = el.length;
            let k = segments[el.segment].bending_stiffness() / l;
            let (wi, ti, wj, tj) = (get(dofs[0]), get(dofs[1]), get(dofs[2]), get(dofs[3]));
            let slope = (wj - wi) / l;
            let (pi, pj) = (ti - slope, tj - slope);
            let mi = k * (4.0 * pi + 2.0 * pj);
            let mj = k * (2.0 * pi + 4.0 * pj);
            let v = (mi + mj) / l;
            for (d, f) in dofs.into_iter().zip([v, mi, -v, mj]) {
                if let Some(i) = d {
                    r[i] -= f;
                }
            }
        }
    }

    /// Factorises a reduced matrix of this model (`A`, `C`, or a combination such as an
    /// integrator's effective matrix), eliminating from the end of the beam farther from the
    /// supports, the order with the least cancellation (see
    /// [`BandedSym::factorize_reversed`]).
    pub fn factorize(&self, matrix: &BandedSym) -> Result<BandedFactor, LinalgError> {
        if self.reverse {
            matrix.factorize_reversed(&self.node_groups())
        } else {
            matrix.factorize()
        }
    }

    /// The order in which [`factorize`](Self::factorize) eliminates the reduced DOFs:
    /// entry `k` is the DOF eliminated `k`-th (the nodes from the end farther from the
    /// supports, each node's DOFs in their own order). For solvers written elsewhere (for
    /// example complex-shifted pencils) that want the same rounding behaviour.
    pub fn elimination_order(&self) -> Vec<usize> {
        if !self.reverse {
            return (0..self.dof_count()).collect();
        }
        let groups = self.node_groups();
        let mut starts = Vec::with_capacity(groups.len());
        let mut at = 0;
        for &g in &groups {
            starts.push(at);
            at += g;
        }
        let mut order = Vec::with_capacity(at);
        for (&start, &g) in starts.iter().zip(&groups).rev() {
            order.extend(start..start + g);
        }
        order
    }

    /// Number of free DOFs of each node with any (the groups of
    /// [`BandedSym::factorize_reversed`]).
    fn node_groups(&self) -> Vec<usize> {
        (0..self.dofs.node_count())
            .map(|n| {
                usize::from(self.dofs.reduced(n, Dof::Transverse).is_some())
                    + usize::from(self.dofs.reduced(n, Dof::Rotation).is_some())
            })
            .filter(|&m| m > 0)
            .collect()
    }

    /// Static deflection under the description's loads evaluated at time `t`.
    pub fn static_deflection_at(&self, t: f64) -> Result<Vec<f64>, BeamError> {
        self.static_deflection(&self.load(t))
    }

    /// The lowest `k` natural modes (dense for small models, subspace iteration above
    /// [`crate::DENSE_LIMIT`] free DOFs).
    pub fn modes(&self, k: usize) -> Result<Modes, BeamError> {
        self.modes_with(k, ModalMethod::Auto)
    }

    /// The lowest `k` natural modes with a chosen method.
    pub fn modes_with(&self, k: usize, method: ModalMethod) -> Result<Modes, BeamError> {
        let shift = self.shift;
        // Residual of (C + shift A) x = b for the refined solves of the subspace iteration.
        let residual = |x: &[f64], b: &[f64], r: &mut [f64]| {
            self.stiffness_residual_into(x, b, r);
            self.mass.mul_add_into(-shift, x, r);
        };
        modal::lowest_modes(
            &self.mass,
            &self.stiffness,
            &self.rigid,
            k,
            method,
            shift,
            self.reverse.then(|| self.node_groups()).as_deref(),
            &residual,
        )
    }

    /// Interpolation data for position `x` (0 to L): element, shape-function weights (35)
    /// and reduced DOF indices. At a node shared by two elements the element to the left is
    /// used (the Hermite interpolation is continuous in both w and theta, so either gives the
    /// same result). `O(log n)`.
    pub fn shape_at(&self, x: f64) -> Result<ShapeAt, BeamError> {
        let xs = self.beam.node_positions();
        let length = self.beam.length();
        let tol = 1e-12 * length;
        if !(x >= -tol && x <= length + tol) {
            return Err(BeamError::OutOfBeam { x, length });
        }
        let ne = self.beam.elements().len();
        let e = xs
            .partition_point(|&xn| xn < x)
            .saturating_sub(1)
            .min(ne - 1);
        let el = &self.beam.elements()[e];
        let zeta = ((x - xs[e]) / el.length).clamp(0.0, 1.0);
        Ok(ShapeAt {
            element: e,
            zeta,
            dofs: element_dofs(&self.dofs, e),
            weights: element::shape_functions(zeta, el.length),
        })
    }

    /// Displacement and rotation at `x` for a reduced DOF vector `q`, eq. (36).
    pub fn deflection_at(&self, x: f64, q: &[f64]) -> Result<(f64, f64), BeamError> {
        if q.len() != self.dof_count() {
            return Err(BeamError::Length {
                what: "DOF vector",
                got: q.len(),
                expected: self.dof_count(),
            });
        }
        Ok(self.shape_at(x)?.apply(q))
    }
}

/// Reduced indices of element `e`'s coordinates (26).
fn element_dofs(dofs: &DofMap, e: usize) -> [Option<usize>; 4] {
    [
        dofs.reduced(e, Dof::Transverse),
        dofs.reduced(e, Dof::Rotation),
        dofs.reduced(e + 1, Dof::Transverse),
        dofs.reduced(e + 1, Dof::Rotation),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spec::{
        BeamSpec, DistributedLoadSpec, NodalLoadSpec, SegmentSpec, SupportKind, SupportSpec,
    };

    fn cantilever(n: usize) -> BeamSpec {
        BeamSpec {
            segments: vec![SegmentSpec::with_section(2.0, 1e3, 1.0, 1.0, 1.0, n)],
            supports: vec![SupportSpec::at_node(0, SupportKind::Clamped)],
            ..Default::default()
        }
    }

    #[test]
    fn assembled_matrices_match_dense_assembly() {
        // Dense assembly of (43) with locked rows/columns deleted (44) as the reference.
        let beam = Beam::new(&cantilever(3)).unwrap();
        let model = BeamModel::new(&beam).unwrap();
        let mut full = nalgebra::DMatrix::<f64>::zeros(8, 8);
        for e in 0..3 {
            let ke = element::stiffness_matrix(1e3, 1.0, 2.0 / 3.0);
            for r in 0..4 {
                for c in 0..4 {
                    full[(2 * e + r, 2 * e + c)] += ke[r][c];
                }
            }
        }
        let reduced = full.view((2, 2), (6, 6)).into_owned();
        assert_eq!(model.stiffness().to_dense(), reduced);
        assert_eq!(model.dof_index(0, Dof::Rotation), None);
        assert_eq!(model.dof_index(1, Dof::Transverse), Some(0));
    }

    #[test]
    fn loads_follow_time_functions() {
        let mut spec = cantilever(4);
        spec.loads.push(NodalLoadSpec {
            node: Some(4),
            force: 2.0,
            moment: 0.5,
            time: TimeFunction::Step { at: 1.0 },
            ..Default::default()
        });
        spec.loads.push(NodalLoadSpec {
            node: Some(0),
            force: 9.0,
            ..Default::default()
        });
        spec.distributed_loads.push(DistributedLoadSpec {
            segment: 0,
            q: 3.0,
            time: TimeFunction::Constant,
        });
        let model = BeamModel::new(&Beam::new(&spec).unwrap()).unwrap();
        let tip = model.dof_index(4, Dof::Transverse).unwrap();
        let p0 = model.load(0.0);
        let p1 = model.load(1.0);
        // Element length 0.5: interior nodes get q l = 1.5, the tip q l / 2 = 0.75.
        assert!((p0[tip] - 0.75).abs() < 1e-15);
        assert!((p1[tip] - 2.75).abs() < 1e-15);
        assert!((p0[model.dof_index(2, Dof::Transverse).unwrap()] - 1.5).abs() < 1e-15);
        // Interior moments cancel; the tip moment is -q l^2 / 12 (+ 0.5 after the step).
        assert!(p0[model.dof_index(2, Dof::Rotation).unwrap()].abs() < 1e-15);
        let m_tip = model.dof_index(4, Dof::Rotation).unwrap();
        assert!((p1[m_tip] - (0.5 - 3.0 * 0.25 / 12.0)).abs() < 1e-15);
        // The force on the clamped node goes into the support.
        let total: f64 = (1..=4)
            .map(|n| p0[model.dof_index(n, Dof::Transverse).unwrap()])
            .sum();
        assert!((total - (3.0 * 2.0 - 0.75)).abs() < 1e-14);
    }

    #[test]
    fn shape_at_locates_elements_and_rejects_outside() {
        let model = BeamModel::new(&Beam::new(&cantilever(4)).unwrap()).unwrap();
        let s = model.shape_at(0.75).unwrap();
        assert_eq!(s.element, 1);
        assert!((s.zeta - 0.5).abs() < 1e-15);
        assert_eq!(model.shape_at(2.0).unwrap().element, 3);
        assert_eq!(model.shape_at(0.0).unwrap().dofs[..2], [None, None]);
        assert!(matches!(
            model.shape_at(2.1),
            Err(BeamError::OutOfBeam { .. })
        ));
        assert!(matches!(
            model.shape_at(f64::NAN),
            Err(BeamError::OutOfBeam { .. })
        ));
        assert!(matches!(
            model.deflection_at(1.0, &[0.0; 3]),
            Err(BeamError::Length { .. })
        ));
    }

    #[test]
    fn rayleigh_from_ratios_hits_the_targets() {
        let (a, b) = rayleigh_from_ratios([10.0, 60.0], [0.02, 0.05]);
        assert!((a / 20.0 + b * 5.0 - 0.02).abs() < 1e-15);
        assert!((a / 120.0 + b * 30.0 - 0.05).abs() < 1e-15);
    }

    #[test]
    fn fully_locked_beam_is_an_error() {
        let mut spec = cantilever(1);
        spec.supports
            .push(SupportSpec::at_node(1, SupportKind::Clamped));
        assert!(matches!(
            BeamModel::new(&Beam::new(&spec).unwrap()),
            Err(BeamError::NoFreeDofs)
        ));
    }
}
