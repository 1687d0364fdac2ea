//! The paper's damper of a [`PaperDamper`] as the rank-one oracle: the same beam, beam
//! point, placement and generator as [`PaperDamper::hybrid`] builds for the engine.

use mbs_symbolic::runtime::System;

use super::{Attachment, DamperModel, Integrator, MechanismLink, State};
use crate::common::PaperDamper;
use crate::common::damper::double_bar;

impl PaperDamper {
    /// The same damper as the rank-one oracle with the generated double bar, and the
    /// initial guess of the double bar's coordinates.
    pub fn oracle(&self) -> (DamperModel<Box<dyn System>>, [f64; 2]) {
        self.oracle_with(double_bar())
    }

    /// The rank-one oracle with `system` as its double bar.
    pub fn oracle_with<M: System>(&self, system: M) -> (DamperModel<M>, [f64; 2]) {
        let system = self.with_parameters(system);
        let beam = self.beam();
        let g = self.geometry(&beam, &system);
        let attachment = Attachment {
            point: g.tip,
            x0: g.target[0],
            y0: g.target[1],
        };
        let mut link = MechanismLink::new(system, attachment, g.joint, self.max_condition)
            .unwrap_or_else(|e| panic!("{e}"));
        link.reach = Some(g.reach);
        let model = DamperModel {
            beam,
            link,
            generator: self.generator.clone(),
            coupling: g.point.weights,
        };
        (model, g.guess)
    }

    /// The oracle's initial state and integrator.
    pub fn oracle_start<M: System>(
        &self,
        model: &DamperModel<M>,
        guess: [f64; 2],
    ) -> (State, Integrator) {
        let state = model
            .initial_state(self.initial_displacement, guess)
            .unwrap_or_else(|e| panic!("{e}"));
        let integ = Integrator::new(model, self.method, self.dt).unwrap_or_else(|e| panic!("{e}"));
        (state, integ)
    }
}
