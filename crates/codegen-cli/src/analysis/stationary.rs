//! The stationary random response of a loaded scenario ([`RandomRequest`] → [`random`] →
//! [`RandomReport`]), what `damper random` prints and Python's `Scenario.random` returns:
//! about the static equilibrium, under the scenario's random excitations
//! ([`crate::random`]: the Lyapunov equation `A P + P A^T + B W B^T = 0`, or the modal or
//! quadrature forms), the RMS of every output, every generator's RMS current and rotor
//! speed and its mean dissipated and load power.
//!
//! **Limits** ([`crate::budget`]): the memory and work of the modes (as the linearisation
//! estimates them) and, dense, of the Lyapunov equation (complex Schur form: about
//! `100 N^3` flops and `10` complex `N x N` matrices for `N` first-order states); above
//! 1 GiB or 1e12 flops the request is refused unless `allow_long`.

use crate::Error;
use crate::analysis::AnalysisError;
use crate::budget::{self, Quantity};
use crate::random::{DENSE_STATES, RandomMethod, RandomOptions, RandomReport, analyse};
use crate::scenario::Loaded;
use crate::setup::{Linearizable, tangents_for};
use hybrid_core::hybrid::EigenMethod;

/// What to compute: the stationary random response of a loaded scenario.
#[derive(Clone, Debug)]
pub struct RandomRequest {
    /// The scenario file as messages name it.
    pub file: String,
    /// The method, the modes and the outputs.
    pub options: RandomOptions,
    /// Run even above the limits of [`crate::budget`].
    pub allow_long: bool,
}

/// Checks the options of `req` that do not need the scenario.
pub fn check(req: &RandomRequest) -> Result<(), Error> {
    if req.options.modes == 0 {
        return Err(AnalysisError::argument("--modes", "--modes must be at least 1").into());
    }
    Ok(())
}

/// The stationary random response of the loaded scenario (its structure already within the
/// budget) as `req` asks ([`check`]ed); a problem of the scenario found by the lowering
/// names the file and the overrides the user wrote.
pub fn random(req: &RandomRequest, loaded: &Loaded) -> Result<RandomReport, Error> {
    let remap = |e: Error| match e {
        Error::Input(d) => Error::Input(loaded.remap(d)),
        e => e,
    };
    let input = tangents_for(&loaded.scenario).map_err(remap)?;
    let o = &req.options;
    check_work(&req.file, &input, o.method, o.modes, req.allow_long)?;
    analyse(&req.file, &loaded.scenario, o).map_err(remap)
}

/// Refuses the random response's solves (`method`, `modes`) estimated above the limits
/// unless `allow_long`.
pub fn check_work(
    file: &str,
    input: &Linearizable,
    method: RandomMethod,
    modes: usize,
    allow_long: bool,
) -> Result<(), Error> {
    let states = input.first_order_states();
    let dense = match method {
        RandomMethod::Auto => states <= DENSE_STATES,
        RandomMethod::Dense => true,
        _ => false,
    };
    let (mut bytes, mut flops) =
        budget::eigen_work(states, modes, EigenMethod::Auto.is_dense(states));
    if dense {
        let n = states as f64;
        bytes += 10.0 * 16.0 * n * n;
        flops += 100.0 * n * n * n;
    }
    budget::refuse_above(
        file,
        &[
            Quantity::bytes("memory", bytes, budget::MAX_MEMORY),
            Quantity::count("flops", flops, budget::MAX_FLOPS),
        ],
        &format!("{states} states: use --method modal or a coarser beam"),
        allow_long,
    )
}
