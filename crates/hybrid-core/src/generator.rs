//! The DC generator used as the damper (docs/theory.md section 7).
//!
//! The generator sits on one joint of the mechanism (the crank) through a gear of ratio `n`:
//! motor speed `w_m = n q'`, EMF `e = k_e w_m`, circuit `L i' + (R_a + R_L) i = e`, torque on
//! the joint `tau = -n k_t i`, which enters the paper's `Q^b` (eq. 13) as `+n k_t i`. With
//! `L = 0`, `tau = -c_g q'` with `c_g = n^2 k_t k_e / (R_a + R_L)`. The rotor inertia adds
//! `n^2 J_r` to the joint's diagonal entry of `M^b`. Dissipated power `(R_a + R_L) i^2`, of
//! which `R_L i^2` is harvested in the load.
//!
//! # Gearbox loss
//!
//! The gearbox loss is a friction torque on the motor side of the gear (motor speed
//! `w = n q'`), opposing the motor's motion:
//!
//! ```text
//! tau_g(w) = tau_c tanh(w / w_s) + (b + b_eta) w,        b_eta = (1/eta - 1) k_t k_e / (R_a + R_L)
//! ```
//!
//! - `tau_c` the Coulomb friction, regularised by the smooth sign `tanh(w / w_s)` (`w_s` the
//!   smoothing speed, default [`DEFAULT_SMOOTHING_SPEED`]: below it the friction grows
//!   linearly, far above it it is `tau_c sign(w)`);
//! - `b` the viscous friction;
//! - `b_eta` the efficiency `eta` of the gear as the loss of quasi-static generation: with
//!   `L = 0` the current is `i = k_e w / (R_a + R_L)`, the motor's electromagnetic torque
//!   `k_t i`, and the joint must supply `k_t i / eta`: the difference `(1/eta - 1) k_t i =
//!   b_eta w` is lost in the gear. Taken as a viscous term (at the quasi-static current, also
//!   with inductance), the loss is linear, smooth, never negative whatever the direction of
//!   the power flow (a load-dependent friction `(1/eta - 1) |k_t i| sign(w)` would be
//!   negative while the inductance drives the rotor, and has no slope at rest), and `eta` is
//!   exactly the gear's efficiency of quasi-static generation: the joint's damping becomes
//!   `c_g / eta`. An open circuit carries no load, so `b_eta = 0` there.
//!
//! It adds `+n tau_g(n q')` to `Q^b` (paper sign, like `c q'`), and the power it takes from
//! the joint, `n tau_g q' = tau_g w = tau_c w tanh(w/w_s) + (b + b_eta) w^2 >= 0`, is
//! dissipated (the energy account's gearbox term). The power the generator takes from the
//! joint (its mechanical input) is `P_m = (n k_t i + n tau_g) q' = k_t i w + tau_g w`; with
//! `k_t = k_e` (SI, the ideal machine) `k_t i w = e i = (R_a + R_L) i^2 + d(L i^2 / 2)/dt`,
//! so `P_m` = copper loss `R_a i^2` + load power `R_L i^2` + gearbox loss + the change of
//! the magnetic energy (the rotor's kinetic energy `n^2 J_r q'^2 / 2` is the mechanism's).
//! A machine whose datasheet constants differ (`k_t != k_e`, rounding) loses `(k_t - k_e)
//! i w` more in the conversion, which the energy account counts as a dissipation of its own.
//!
//! Linearised about rest (`w = 0`), `tau_g` is the viscous `(tau_c / w_s + b + b_eta) w`: the
//! Coulomb part enters with its slope at 0, `tau_c / w_s`, which is the regularised model's
//! small-amplitude behaviour (amplitudes well above `w_s` see less, `tau_c / |w|`).

use serde::{Deserialize, Serialize};

/// Parameters of the DC generator and its electrical load.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeneratorSpec {
    /// Torque constant `k_t`, N m / A.
    pub kt: f64,
    /// EMF constant `k_e`, V s / rad.
    pub ke: f64,
    /// Armature resistance `R_a`, ohm.
    pub armature_resistance: f64,
    /// Load resistance `R_L`, ohm.
    pub load_resistance: f64,
    /// Armature inductance `L`, H (0: the current follows the speed instantly).
    #[serde(default)]
    pub inductance: f64,
    /// Gear ratio `n` (motor speed / joint speed; 1 = direct drive).
    #[serde(default = "one")]
    pub gear_ratio: f64,
    /// Rotor inertia `J_r`, kg m^2.
    #[serde(default)]
    pub rotor_inertia: f64,
    /// Whether the circuit is closed. An open circuit carries no current (no damping); the
    /// rotor still turns with the mechanism.
    #[serde(default = "yes")]
    pub connected: bool,
    /// Efficiency `eta` of the gear in quasi-static generation, `0 < eta <= 1` (1: no
    /// efficiency loss; see the module documentation).
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub gear_efficiency: f64,
    /// Coulomb and viscous friction of the gear on the motor side.
    #[serde(default, skip_serializing_if = "GearFriction::is_none")]
    pub gear_friction: GearFriction,
}

/// Friction of the gear on the motor side (see the module documentation):
/// `tau_c tanh(w / w_s) + b w` at motor speed `w`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GearFriction {
    /// Coulomb friction torque `tau_c`, N m (motor side).
    #[serde(default)]
    pub coulomb: f64,
    /// Viscous friction `b`, N m s/rad (motor side).
    #[serde(default)]
    pub viscous: f64,
    /// Smoothing speed `w_s` of the Coulomb friction's sign, rad/s (motor side).
    #[serde(default = "default_smoothing_speed")]
    pub smoothing_speed: f64,
}

/// The default smoothing speed `w_s` of the gear's Coulomb friction: 1 rad/s at the motor
/// (about 10 rpm, a few thousandths of a small motor's rated speed).
pub const DEFAULT_SMOOTHING_SPEED: f64 = 1.0;

fn default_smoothing_speed() -> f64 {
    DEFAULT_SMOOTHING_SPEED
}

impl Default for GearFriction {
    fn default() -> Self {
        GearFriction {
            coulomb: 0.0,
            viscous: 0.0,
            smoothing_speed: DEFAULT_SMOOTHING_SPEED,
        }
    }
}

impl GearFriction {
    /// Whether there is no friction (zero Coulomb and viscous parts, default smoothing).
    pub fn is_none(&self) -> bool {
        *self == GearFriction::default()
    }
}

fn one() -> f64 {
    1.0
}

fn is_one(x: &f64) -> bool {
    *x == 1.0
}

fn yes() -> bool {
    true
}

/// A generator's powers at one end of a step ([`GeneratorSpec::step_powers`]), W.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EndPowers {
    /// Dissipated: the circuit's `(R_a + R_L) i^2` plus the gear's loss.
    pub dissipated: f64,
    /// Taken from the joint: `(n k_t i + n tau_g(n q')) q'`.
    pub mechanical: f64,
    /// The gear's loss `tau_g(n q') n q'` (0 without one).
    pub gear_loss: f64,
}

impl GeneratorSpec {
    /// Total circuit resistance `R_a + R_L`.
    #[inline]
    pub fn resistance(&self) -> f64 {
        self.armature_resistance + self.load_resistance
    }

    /// The load's part `R_L / (R_a + R_L)` of an energy or power `dissipated` in the circuit
    /// (`(R_a + R_L) i^2`): what is harvested (0 for a circuit without resistance).
    pub fn load_part(&self, dissipated: f64) -> f64 {
        let r = self.resistance();
        if r > 0.0 {
            dissipated * self.load_resistance / r
        } else {
            0.0
        }
    }

    /// Equivalent rotational damping `c_g = n^2 k_t k_e / (R_a + R_L)` on the joint (0 when
    /// disconnected).
    pub fn damping_coefficient(&self) -> f64 {
        if self.connected {
            self.gear_ratio.powi(2) * self.kt * self.ke / self.resistance()
        } else {
            0.0
        }
    }

    /// Rotor inertia seen at the joint, `n^2 J_r`.
    #[inline]
    pub fn reflected_inertia(&self) -> f64 {
        self.gear_ratio.powi(2) * self.rotor_inertia
    }

    /// Whether the gear loses energy (efficiency below 1, or friction): without it the
    /// generator's equations and energy account are exactly those without a gearbox model.
    ///
    /// `efficiency != 1.0 || coulomb != 0.0 || viscous != 0.0` tested on the bits (it is
    /// on every evaluation of the equations): only `1.0` has `1.0`'s bits (a NaN has
    /// others), and `x != 0.0` is "a bit other than the sign set" (a NaN has some).
    #[inline]
    pub fn has_gear_loss(&self) -> bool {
        let f = &self.gear_friction;
        self.gear_efficiency.to_bits() != 1.0f64.to_bits()
            || (f.coulomb.to_bits() | f.viscous.to_bits()) << 1 != 0
    }

    /// The viscous equivalent of the gear's efficiency on the motor side,
    /// `b_eta = (1/eta - 1) k_t k_e / (R_a + R_L)` (0 when disconnected).
    pub fn efficiency_damping(&self) -> f64 {
        if self.connected && self.gear_efficiency != 1.0 {
            (1.0 / self.gear_efficiency - 1.0) * self.kt * self.ke / self.resistance()
        } else {
            0.0
        }
    }

    /// The gear's friction torque on the motor side at motor speed `w`,
    /// `tau_c tanh(w / w_s) + (b + b_eta) w` (N m).
    pub fn gear_torque(&self, motor_speed: f64) -> f64 {
        let f = &self.gear_friction;
        let coulomb = if f.coulomb != 0.0 {
            f.coulomb * (motor_speed / f.smoothing_speed).tanh()
        } else {
            0.0
        };
        coulomb + (f.viscous + self.efficiency_damping()) * motor_speed
    }

    /// The gear's loss power at joint speed `q'`, `tau_g(n q') n q' >= 0` (W).
    pub fn gear_loss_power(&self, joint_speed: f64) -> f64 {
        if !self.has_gear_loss() {
            return 0.0;
        }
        let w = self.gear_ratio * joint_speed;
        self.gear_torque(w) * w
    }

    /// The gear's viscous slope at rest on the joint, `n^2 (tau_c / w_s + b + b_eta)`
    /// (N m s/rad): the linearisation of `n tau_g(n q')` about `q' = 0`.
    pub fn gear_damping_at_rest(&self) -> f64 {
        let f = &self.gear_friction;
        self.gear_ratio.powi(2)
            * (f.coulomb / f.smoothing_speed + f.viscous + self.efficiency_damping())
    }

    /// The generator's whole contribution to `Q^b` of its joint at joint speed `q'` and
    /// current `i` (paper sign): `n k_t i + n tau_g(n q')`.
    pub fn joint_term(&self, joint_speed: f64, current: f64) -> f64 {
        let mut q = self.q_term(current);
        if self.has_gear_loss() {
            q += self.gear_ratio * self.gear_torque(self.gear_ratio * joint_speed);
        }
        q
    }

    /// The power the generator takes from its joint, `(n k_t i + n tau_g) q'` (W): the
    /// mechanical input of the energy split (module documentation).
    pub fn mechanical_power(&self, joint_speed: f64, current: f64) -> f64 {
        self.joint_term(joint_speed, current) * joint_speed
    }

    /// The energy account's powers at the two ends of a step, `ends` = `[(q', i)]` of the
    /// old and the new state: per end the circuit's dissipation with the gear's
    /// (`JointForce::dissipated_power` of a generator), the mechanical input
    /// ([`GeneratorSpec::mechanical_power`]) and the gear's loss
    /// ([`GeneratorSpec::gear_loss_power`]), the same numbers bit for bit, with
    /// [`GeneratorSpec::has_gear_loss`] (returned) and the resistance read once for both
    /// ends instead of once per power and end, and the gear's torque once per end (for
    /// the joint's torque, the dissipation and the gear's own account).
    #[inline]
    pub fn step_powers(&self, ends: [(f64, f64); 2]) -> (bool, [EndPowers; 2]) {
        let loss = self.has_gear_loss();
        let r = self.resistance();
        let n = self.gear_ratio;
        let powers = ends.map(|(w, i)| {
            let circuit = r * i * i;
            let mut torque = self.q_term(i);
            let (dissipated, gear_loss) = if loss {
                // One gear torque at the motor speed `n q'` for both (a pure function of it).
                let m = n * w;
                let tau = self.gear_torque(m);
                torque += n * tau;
                let gear = tau * m;
                (circuit + gear, gear)
            } else {
                (circuit, 0.0)
            };
            EndPowers {
                dissipated,
                mechanical: torque * w,
                gear_loss,
            }
        });
        (loss, powers)
    }

    /// Whether the current is a state of its own (inductance > 0 and connected).
    #[inline]
    pub fn has_current_state(&self) -> bool {
        self.connected && self.inductance > 0.0
    }

    /// Adds the generator to the mechanism's equations on joint `joint` — the one place it
    /// is added: the reflected rotor inertia `n^2 J_r` on the diagonal of `M^b` (eq. 11) and
    /// the torque for `current` and joint speed `joint_speed`, paper sign
    /// `+n k_t i + n tau_g(n q')` ([`GeneratorSpec::joint_term`]), to `Q^b` (eq. 13). With
    /// zero inductance, the quasi-static current and no gear loss this is the viscous damper
    /// `c_g q'`.
    #[inline]
    pub fn add_to_equations(
        &self,
        joint: usize,
        joint_speed: f64,
        current: f64,
        m: &mut nalgebra::DMatrix<f64>,
        q: &mut nalgebra::DVector<f64>,
    ) {
        m[(joint, joint)] += self.reflected_inertia();
        q[joint] += self.q_term(current);
        if self.has_gear_loss() {
            q[joint] += self.gear_ratio * self.gear_torque(self.gear_ratio * joint_speed);
        }
    }

    /// The current when the inductance is zero: `i = k_e n q' / (R_a + R_L)`.
    #[inline]
    pub fn quasi_static_current(&self, joint_speed: f64) -> f64 {
        if self.connected {
            self.ke * self.gear_ratio * joint_speed / self.resistance()
        } else {
            0.0
        }
    }

    /// The generator's contribution to `Q^b` of its joint, paper sign: `+n k_t i`.
    #[inline]
    pub fn q_term(&self, current: f64) -> f64 {
        self.gear_ratio * self.kt * current
    }

    /// Every problem with the values, in field order (empty when the generator is usable):
    /// first each field on its own (finite and within its physical range,
    /// [`GeneratorField::range`]), then — when every
    /// field is in range — the total resistance, and then the derived quantities the
    /// equations use ([`DerivedQuantity`]): each must be finite, and the three coefficients
    /// that enter the coupled equations must stay within [`MAX_COEFFICIENT`]. A derived
    /// quantity whose formula holds a field already blamed for an earlier one is skipped.
    pub fn problems(&self) -> Vec<GeneratorError> {
        let mut out = vec![];
        for field in GeneratorField::ALL {
            let value = field.value(self);
            let (min, max) = field.range();
            if !(value.is_finite() && min <= value && value <= max) {
                out.push(GeneratorError::Invalid { field, value });
            }
        }
        if !out.is_empty() {
            return out;
        }
        if self.resistance() <= 0.0 {
            out.push(GeneratorError::NoResistance);
            return out;
        }
        let mut blamed: Vec<GeneratorField> = vec![];
        for quantity in DerivedQuantity::ALL {
            // One problem per mistyped field: a quantity built on a field already blamed
            // would only repeat it (or print 0 * inf = NaN).
            if quantity.fields().iter().any(|f| blamed.contains(f)) {
                continue;
            }
            let value = quantity.value(self);
            let field = quantity.dominant_field(self);
            if !value.is_finite() || quantity.limit().is_some_and(|limit| value > limit) {
                blamed.push(field);
            }
            if !value.is_finite() {
                out.push(GeneratorError::NotFinite {
                    quantity,
                    value,
                    field,
                });
            } else if quantity.limit().is_some_and(|limit| value > limit) {
                out.push(GeneratorError::Implausible {
                    quantity,
                    value,
                    field,
                });
            }
        }
        out
    }

    /// Checks the values: the first of [`GeneratorSpec::problems`], if any.
    pub fn validate(&self) -> Result<(), GeneratorError> {
        match self.problems().into_iter().next() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

/// A numeric field of [`GeneratorSpec`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeneratorField {
    /// `kt`.
    Kt,
    /// `ke`.
    Ke,
    /// `armature_resistance`.
    ArmatureResistance,
    /// `load_resistance`.
    LoadResistance,
    /// `inductance`.
    Inductance,
    /// `gear_ratio`.
    GearRatio,
    /// `rotor_inertia`.
    RotorInertia,
    /// `gear_efficiency`.
    GearEfficiency,
    /// `gear_friction.coulomb`.
    GearCoulomb,
    /// `gear_friction.viscous`.
    GearViscous,
    /// `gear_friction.smoothing_speed`.
    GearSmoothing,
}

impl GeneratorField {
    /// Every field, in the order of a generator description.
    pub const ALL: [GeneratorField; 11] = [
        GeneratorField::Kt,
        GeneratorField::Ke,
        GeneratorField::ArmatureResistance,
        GeneratorField::LoadResistance,
        GeneratorField::Inductance,
        GeneratorField::GearRatio,
        GeneratorField::RotorInertia,
        GeneratorField::GearEfficiency,
        GeneratorField::GearCoulomb,
        GeneratorField::GearViscous,
        GeneratorField::GearSmoothing,
    ];

    /// The physical range `[min, max]` of the field (SI, [`GeneratorField::unit`]): every
    /// real machine lies well inside, and a value outside is a typing or unit mistake whose
    /// matrices would be finite but hopeless (issue 23: `inductance = 1e308` left the
    /// linearised system out of floating-point range).
    ///
    /// - `kt`, `ke` in `[1e-6, 1e4]`: coreless micromotors have about `1e-3` N m/A, the
    ///   largest direct-drive torque motors about `1e2`; `k_t = k_e` in SI units.
    /// - `armature_resistance` in `[0, 1e6]` ohm: milliohms for large machines, kilohms for
    ///   the finest windings (0: superconducting, or the resistance lumped into the load).
    /// - `load_resistance` in `[0, 1e9]` ohm: short circuit to an electrometer-grade input;
    ///   an open circuit is `connected = false`.
    /// - `inductance` in `[0, 1e3]` H: armature inductances are microhenries to about a
    ///   henry; 1e3 H is a time constant of minutes with an ohm of resistance.
    /// - `gear_ratio` in `[1e-3, 1e4]`: multi-stage reducers reach a few thousand, step-up
    ///   gears (ratio below 1) a few hundredths.
    /// - `rotor_inertia` in `[0, 1e4]` kg m^2: a megawatt generator's rotor is about `1e3`.
    /// - `gear_efficiency` in `[1e-2, 1]`: real gears have 0.4 to 0.98; below 0.01 the
    ///   gear would multiply the damping by more than 100.
    /// - `gear_friction.coulomb` in `[0, 1e4]` N m and `gear_friction.viscous` in
    ///   `[0, 1e4]` N m s/rad (motor side): a micromotor's gear has about `1e-3` N m.
    /// - `gear_friction.smoothing_speed` in `[1e-6, 1e6]` rad/s (motor side).
    pub fn range(self) -> (f64, f64) {
        match self {
            GeneratorField::Kt | GeneratorField::Ke => (1e-6, 1e4),
            GeneratorField::ArmatureResistance => (0.0, 1e6),
            GeneratorField::LoadResistance => (0.0, 1e9),
            GeneratorField::Inductance => (0.0, 1e3),
            GeneratorField::GearRatio => (1e-3, 1e4),
            GeneratorField::RotorInertia => (0.0, 1e4),
            GeneratorField::GearEfficiency => (1e-2, 1.0),
            GeneratorField::GearCoulomb | GeneratorField::GearViscous => (0.0, 1e4),
            GeneratorField::GearSmoothing => (1e-6, 1e6),
        }
    }

    /// The field's SI unit (empty for the gear ratio).
    pub fn unit(self) -> &'static str {
        match self {
            GeneratorField::Kt => " N m/A",
            GeneratorField::Ke => " V s/rad",
            GeneratorField::ArmatureResistance | GeneratorField::LoadResistance => " ohm",
            GeneratorField::Inductance => " H",
            GeneratorField::GearRatio | GeneratorField::GearEfficiency => "",
            GeneratorField::RotorInertia => " kg m^2",
            GeneratorField::GearCoulomb => " N m",
            GeneratorField::GearViscous => " N m s/rad",
            GeneratorField::GearSmoothing => " rad/s",
        }
    }

    /// The field's name as written in a generator description.
    pub fn name(self) -> &'static str {
        match self {
            GeneratorField::Kt => "kt",
            GeneratorField::Ke => "ke",
            GeneratorField::ArmatureResistance => "armature_resistance",
            GeneratorField::LoadResistance => "load_resistance",
            GeneratorField::Inductance => "inductance",
            GeneratorField::GearRatio => "gear_ratio",
            GeneratorField::RotorInertia => "rotor_inertia",
            GeneratorField::GearEfficiency => "gear_efficiency",
            GeneratorField::GearCoulomb => "gear_friction.coulomb",
            GeneratorField::GearViscous => "gear_friction.viscous",
            GeneratorField::GearSmoothing => "gear_friction.smoothing_speed",
        }
    }

    /// The field's value in `g`.
    pub fn value(self, g: &GeneratorSpec) -> f64 {
        match self {
            GeneratorField::Kt => g.kt,
            GeneratorField::Ke => g.ke,
            GeneratorField::ArmatureResistance => g.armature_resistance,
            GeneratorField::LoadResistance => g.load_resistance,
            GeneratorField::Inductance => g.inductance,
            GeneratorField::GearRatio => g.gear_ratio,
            GeneratorField::RotorInertia => g.rotor_inertia,
            GeneratorField::GearEfficiency => g.gear_efficiency,
            GeneratorField::GearCoulomb => g.gear_friction.coulomb,
            GeneratorField::GearViscous => g.gear_friction.viscous,
            GeneratorField::GearSmoothing => g.gear_friction.smoothing_speed,
        }
    }
}

/// The largest coefficient the coupled equations accept from the generator, in SI units
/// (N m s/rad for the damping `c_g`, kg m^2 for the reflected inertia `n^2 J_r`, A s/rad for
/// the current per joint speed `k_e n / (R_a + R_L)`).
///
/// Real machines stay many orders below it: the paper's generator has `c_g = 2.8e-3`, a
/// large geared industrial generator (`n = 100`, `k_t = k_e = 10`, `R = 0.01`) about `1e8`.
/// Far above it the generator swamps the rest of the coupled system to round-off: in the
/// bundled damper scenario `c_g = 1.2e15` (`kt = 1e16`) still runs, `c_g = 1.2e17`
/// (`kt = 1e18`) diverges within 2 ms and ends as "cannot reach the beam point". The limit
/// keeps three decades of margin below that; a mechanism that must not move at all is
/// modelled without it, not with an enormous damper.
pub const MAX_COEFFICIENT: f64 = 1e12;

/// A quantity derived from the generator's fields that the equations use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DerivedQuantity {
    /// `n^2`, the gear ratio squared.
    GearRatioSquared,
    /// `c_g = k_t k_e n^2 / (R_a + R_L)`, the damping on the joint (docs/theory.md section 7).
    Damping,
    /// `k_e n / (R_a + R_L)`, the quasi-static current per unit joint speed.
    CurrentPerSpeed,
    /// `n k_t`, the joint torque per ampere.
    TorquePerCurrent,
    /// `n^2 J_r`, the rotor inertia seen at the joint (added to `M^b`, eq. 11).
    ReflectedInertia,
    /// `L / (R_a + R_L)`, the circuit's time constant.
    TimeConstant,
    /// `n^2 (tau_c / w_s + b + b_eta)`, the gear's damping at rest on the joint
    /// ([`GeneratorSpec::gear_damping_at_rest`]).
    GearDamping,
}

impl DerivedQuantity {
    /// Every derived quantity, in the order they are checked.
    pub const ALL: [DerivedQuantity; 7] = [
        DerivedQuantity::GearRatioSquared,
        DerivedQuantity::Damping,
        DerivedQuantity::CurrentPerSpeed,
        DerivedQuantity::TorquePerCurrent,
        DerivedQuantity::ReflectedInertia,
        DerivedQuantity::TimeConstant,
        DerivedQuantity::GearDamping,
    ];

    /// The formula, in the field names of a generator description.
    pub fn formula(self) -> &'static str {
        match self {
            DerivedQuantity::GearRatioSquared => "gear_ratio^2",
            DerivedQuantity::Damping => {
                "kt * ke * gear_ratio^2 / (armature_resistance + load_resistance)"
            }
            DerivedQuantity::CurrentPerSpeed => {
                "ke * gear_ratio / (armature_resistance + load_resistance)"
            }
            DerivedQuantity::TorquePerCurrent => "gear_ratio * kt",
            DerivedQuantity::ReflectedInertia => "gear_ratio^2 * rotor_inertia",
            DerivedQuantity::TimeConstant => "inductance / (armature_resistance + load_resistance)",
            DerivedQuantity::GearDamping => {
                "gear_ratio^2 * (coulomb / smoothing_speed + viscous + (1/gear_efficiency - 1) \
                 * kt * ke / (armature_resistance + load_resistance))"
            }
        }
    }

    /// Its SI unit.
    pub fn unit(self) -> &'static str {
        match self {
            DerivedQuantity::GearRatioSquared => "",
            DerivedQuantity::Damping | DerivedQuantity::GearDamping => " N m s/rad",
            DerivedQuantity::CurrentPerSpeed => " A s/rad",
            DerivedQuantity::TorquePerCurrent => " N m/A",
            DerivedQuantity::ReflectedInertia => " kg m^2",
            DerivedQuantity::TimeConstant => " s",
        }
    }

    /// Its value for `g`, computed as the equations compute it (the damping as
    /// [`GeneratorSpec::damping_coefficient`] of the connected generator).
    pub fn value(self, g: &GeneratorSpec) -> f64 {
        match self {
            DerivedQuantity::GearRatioSquared => g.gear_ratio.powi(2),
            DerivedQuantity::Damping => g.gear_ratio.powi(2) * g.kt * g.ke / g.resistance(),
            DerivedQuantity::CurrentPerSpeed => g.ke * g.gear_ratio / g.resistance(),
            DerivedQuantity::TorquePerCurrent => g.gear_ratio * g.kt,
            DerivedQuantity::ReflectedInertia => g.reflected_inertia(),
            DerivedQuantity::TimeConstant => g.inductance / g.resistance(),
            DerivedQuantity::GearDamping => g.gear_damping_at_rest(),
        }
    }

    /// The upper limit of a physically sensible value ([`MAX_COEFFICIENT`] for the
    /// coefficients of the coupled equations), `None` when only finiteness is required.
    pub fn limit(self) -> Option<f64> {
        match self {
            DerivedQuantity::Damping
            | DerivedQuantity::CurrentPerSpeed
            | DerivedQuantity::ReflectedInertia
            | DerivedQuantity::GearDamping => Some(MAX_COEFFICIENT),
            DerivedQuantity::GearRatioSquared
            | DerivedQuantity::TorquePerCurrent
            | DerivedQuantity::TimeConstant => None,
        }
    }

    /// The fields of the formula.
    pub fn fields(self) -> &'static [GeneratorField] {
        use GeneratorField::*;
        match self {
            DerivedQuantity::GearRatioSquared => &[GearRatio],
            DerivedQuantity::Damping => &[Kt, Ke, GearRatio, ArmatureResistance, LoadResistance],
            DerivedQuantity::CurrentPerSpeed => {
                &[Ke, GearRatio, ArmatureResistance, LoadResistance]
            }
            DerivedQuantity::TorquePerCurrent => &[GearRatio, Kt],
            DerivedQuantity::ReflectedInertia => &[GearRatio, RotorInertia],
            DerivedQuantity::TimeConstant => &[Inductance, ArmatureResistance, LoadResistance],
            DerivedQuantity::GearDamping => &[
                GearRatio,
                GearCoulomb,
                GearSmoothing,
                GearViscous,
                GearEfficiency,
                Kt,
                Ke,
                ArmatureResistance,
                LoadResistance,
            ],
        }
    }

    /// The field of the formula furthest from 1 in orders of magnitude (the first of
    /// equals; zeros ignored) — the value most likely mistyped, where an error points.
    pub fn dominant_field(self, g: &GeneratorSpec) -> GeneratorField {
        let fields = self.fields();
        let mut best = fields[0];
        let mut best_mag = -1.0;
        for &f in fields {
            let v = f.value(g);
            if v > 0.0 && v.log10().abs() > best_mag {
                best_mag = v.log10().abs();
                best = f;
            }
        }
        best
    }
}

/// A generator value the model cannot use.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeneratorError {
    /// A field not finite or out of its physical range ([`GeneratorField::range`]).
    #[error(
        "generator.{} = {} is outside its physical range [{}, {:e}]{}",
        field.name(),
        bound(*value),
        bound(field.range().0),
        field.range().1,
        field.unit()
    )]
    Invalid {
        /// The field.
        field: GeneratorField,
        /// Its value.
        value: f64,
    },
    /// `R_a + R_L` is zero.
    #[error("generator: armature_resistance + load_resistance must be positive")]
    NoResistance,
    /// A derived quantity overflows (or is 0 * inf) although every field is in range.
    #[error("generator: {} = {value:e} is not finite", quantity.formula())]
    NotFinite {
        /// The quantity.
        quantity: DerivedQuantity,
        /// Its value (inf or NaN).
        value: f64,
        /// The field most likely responsible ([`DerivedQuantity::dominant_field`]).
        field: GeneratorField,
    },
    /// A derived coefficient above its physically sensible limit ([`MAX_COEFFICIENT`]).
    #[error(
        "generator: {} = {value:.3e}{} is not physically sensible (at most {:e}; larger values \
         swamp the coupled equations to round-off)",
        quantity.formula(),
        quantity.unit(),
        quantity.limit().unwrap_or(f64::INFINITY)
    )]
    Implausible {
        /// The quantity.
        quantity: DerivedQuantity,
        /// Its value.
        value: f64,
        /// The field most likely responsible ([`DerivedQuantity::dominant_field`]).
        field: GeneratorField,
    },
}

/// A number as written in range messages: `0`, or scientific notation (`1e-6`, `inf`).
fn bound(x: f64) -> String {
    if x == 0.0 {
        "0".to_string()
    } else {
        format!("{x:e}")
    }
}

impl GeneratorError {
    /// The field concerned, when it is one field.
    pub fn field(&self) -> Option<GeneratorField> {
        match self {
            GeneratorError::Invalid { field, .. }
            | GeneratorError::NotFinite { field, .. }
            | GeneratorError::Implausible { field, .. } => Some(*field),
            GeneratorError::NoResistance => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn damping_coefficient_of_the_paper_generator() {
        let g = GeneratorSpec {
            kt: 0.0235,
            ke: 0.0235,
            armature_resistance: 1.5,
            load_resistance: 3.5,
            inductance: 0.0,
            gear_ratio: 5.0,
            rotor_inertia: 1e-6,
            connected: true,
            gear_efficiency: 1.0,
            gear_friction: GearFriction::default(),
        };
        let c = 25.0 * 0.0235 * 0.0235 / 5.0;
        assert!((g.damping_coefficient() - c).abs() < 1e-18);
        // With L = 0, Q = n k_t i = c_g q'.
        assert!((g.q_term(g.quasi_static_current(2.0)) - c * 2.0).abs() < 1e-15);
        assert!((g.reflected_inertia() - 25e-6).abs() < 1e-20);
        assert!(
            GeneratorSpec {
                kt: -1.0,
                ..g.clone()
            }
            .validate()
            .unwrap_err()
            .to_string()
            .contains("generator.kt")
        );
        assert_eq!(
            GeneratorSpec {
                connected: false,
                ..g
            }
            .damping_coefficient(),
            0.0
        );
    }

    /// The paper's generator behind a lossy gear of efficiency `eta` (Coulomb and viscous
    /// friction) with an inductance.
    fn lossy_gear(eta: f64) -> GeneratorSpec {
        GeneratorSpec {
            gear_efficiency: eta,
            gear_friction: GearFriction {
                coulomb: 5e-4,
                viscous: 2e-6,
                smoothing_speed: 0.5,
            },
            inductance: 1e-3,
            ..paper()
        }
    }

    /// `step_powers` gives the numbers of `dissipated_power` (through a `JointForce`),
    /// `mechanical_power` and `gear_loss_power` bit for bit, with and without gear loss,
    /// connected or not, at speeds and currents of both signs, zeros, a NaN and infinities.
    #[test]
    fn step_powers_are_the_separate_powers_bit_for_bit() {
        use crate::hybrid::{ForceKind, JointForce};
        let lossy = lossy_gear(0.8);
        let friction_only = GeneratorSpec {
            gear_friction: GearFriction {
                coulomb: 0.0,
                viscous: 3e-6,
                smoothing_speed: 1.0,
            },
            ..paper()
        };
        let open = GeneratorSpec {
            connected: false,
            ..lossy.clone()
        };
        let values = [
            0.0,
            -0.0,
            1.7,
            -3.25,
            1e-9,
            -2.5e3,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for g in [paper(), lossy, friction_only, open] {
            let force = JointForce {
                name: "g".into(),
                mechanism: 0,
                joint: 0,
                kind: ForceKind::Generator(g.clone()),
            };
            for (&w0, &i0) in values.iter().zip(values.iter().rev()) {
                for (&w1, &i1) in values.iter().zip(values.iter().cycle().skip(3)) {
                    let (loss, [old, new]) = g.step_powers([(w0, i0), (w1, i1)]);
                    assert_eq!(loss, g.has_gear_loss());
                    for (p, (w, i)) in [(old, (w0, i0)), (new, (w1, i1))] {
                        let same = |a: f64, b: f64| a.to_bits() == b.to_bits();
                        assert!(same(p.dissipated, force.dissipated_power(w, i)), "{w} {i}");
                        assert!(same(p.mechanical, g.mechanical_power(w, i)), "{w} {i}");
                        assert!(same(p.gear_loss, g.gear_loss_power(w)), "{w} {i}");
                    }
                }
            }
        }
    }

    /// `has_gear_loss` on the bits is the three float comparisons, for every combination
    /// of efficiencies and friction parts around the special values.
    #[test]
    fn has_gear_loss_is_the_three_comparisons() {
        let tiny = f64::from_bits(1);
        let specials = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1.0 + f64::EPSILON,
            1.0 - f64::EPSILON / 2.0,
            tiny,
            -tiny,
            0.8,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
        ];
        for &e in &specials {
            for &c in &specials {
                for &v in &specials {
                    let g = GeneratorSpec {
                        gear_efficiency: e,
                        gear_friction: GearFriction {
                            coulomb: c,
                            viscous: v,
                            smoothing_speed: 1.0,
                        },
                        ..paper()
                    };
                    assert_eq!(
                        g.has_gear_loss(),
                        e != 1.0 || c != 0.0 || v != 0.0,
                        "{e} {c} {v}"
                    );
                }
            }
        }
    }

    fn paper() -> GeneratorSpec {
        GeneratorSpec {
            kt: 0.0235,
            ke: 0.0235,
            armature_resistance: 1.5,
            load_resistance: 3.5,
            inductance: 0.0,
            gear_ratio: 5.0,
            rotor_inertia: 1e-6,
            connected: true,
            gear_efficiency: 1.0,
            gear_friction: GearFriction::default(),
        }
    }

    /// The gear model (module documentation): with `L = 0` the efficiency makes the joint's
    /// damping exactly `c_g / eta`; the loss power is never negative; the slope at rest is the
    /// joint term's derivative (central difference); without gear loss nothing changes.
    #[test]
    fn the_gear_loss_is_dissipative_and_its_slope_at_rest_is_the_derivative() {
        let eta = 0.8;
        let g = GeneratorSpec {
            gear_efficiency: eta,
            ..paper()
        };
        for w in [-3.0, -0.1, 0.02, 1.7] {
            let q = g.joint_term(w, g.quasi_static_current(w));
            let expected = paper().damping_coefficient() / eta * w;
            assert!(
                (q - expected).abs() <= 1e-15 * expected.abs(),
                "{q} vs {expected}"
            );
        }
        let g = lossy_gear(eta);
        assert!(g.has_gear_loss() && !paper().has_gear_loss());
        for k in -200..=200 {
            let w = k as f64 * 0.05;
            assert!(g.gear_loss_power(w) >= 0.0, "{w}");
            // Loss = gear part of the joint term times the joint speed.
            let gear = g.joint_term(w, 0.3) - g.q_term(0.3);
            assert!(
                (gear * w - g.gear_loss_power(w)).abs()
                    <= 1e-15 * g.gear_loss_power(w).max(1e-300) + 1e-18
            );
        }
        let h = 1e-7;
        let slope = (g.joint_term(h, 0.0) - g.joint_term(-h, 0.0)) / (2.0 * h);
        let n2 = 25.0;
        let b_eta = (1.0 / eta - 1.0) * 0.0235 * 0.0235 / 5.0;
        let exact = n2 * (5e-4 / 0.5 + 2e-6 + b_eta);
        assert!((g.gear_damping_at_rest() - exact).abs() <= 1e-15 * exact);
        assert!((slope - exact).abs() <= 1e-6 * exact, "{slope} vs {exact}");
        // Open circuit: no load, no efficiency loss; the friction stays.
        let open = GeneratorSpec {
            connected: false,
            ..g.clone()
        };
        assert_eq!(open.efficiency_damping(), 0.0);
        assert_eq!(open.gear_damping_at_rest(), n2 * (5e-4 / 0.5 + 2e-6));
        // Out of range: an efficiency of 0 or above 1.
        for bad in [0.0, 1.01] {
            let p = GeneratorSpec {
                gear_efficiency: bad,
                ..paper()
            }
            .problems();
            assert_eq!(p.len(), 1);
            assert_eq!(p[0].field(), Some(GeneratorField::GearEfficiency));
        }
    }

    #[test]
    fn the_paper_generator_has_no_problems() {
        assert_eq!(paper().problems(), vec![]);
    }

    #[test]
    fn overflowing_damping_is_not_finite_and_blames_the_tiny_resistance() {
        let g = GeneratorSpec {
            armature_resistance: 5e-324,
            load_resistance: 5e-324,
            ..paper()
        };
        let p = g.problems();
        assert_eq!(p.len(), 1, "{p:?}");
        assert_eq!(p[0].field(), Some(GeneratorField::ArmatureResistance));
        assert_eq!(
            p[0].to_string(),
            "generator: kt * ke * gear_ratio^2 / (armature_resistance + load_resistance) \
             = inf is not finite"
        );
    }

    #[test]
    fn huge_in_range_fields_make_an_implausible_damping_blaming_kt() {
        // Every field in range, the product c_g = 1e8 * 1e4 * 1e4 / 5 = 2e15 is not.
        let g = GeneratorSpec {
            kt: 1e4,
            ke: 1e4,
            gear_ratio: 1e4,
            ..paper()
        };
        let p = g.problems();
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(matches!(p[0], GeneratorError::Implausible { .. }), "{p:?}");
        assert_eq!(p[0].field(), Some(GeneratorField::Kt));
        let msg = p[0].to_string();
        assert!(msg.contains("= 2.000e15 N m s/rad"), "{msg}");
        assert!(msg.contains("at most 1e12"), "{msg}");
    }

    /// Issue 23 item 1: every field has a physical range, and a finite value outside it
    /// (a typing or unit mistake) is refused naming the field and the range; the bounds
    /// themselves are accepted.
    #[test]
    fn every_field_outside_its_range_is_refused_naming_field_and_range() {
        let table: [(GeneratorField, f64, &str); 9] = [
            (
                GeneratorField::Kt,
                1e300,
                "generator.kt = 1e300 is outside its physical range [1e-6, 1e4] N m/A",
            ),
            (
                GeneratorField::Ke,
                5e-324,
                "generator.ke = 5e-324 is outside its physical range [1e-6, 1e4] V s/rad",
            ),
            (
                GeneratorField::ArmatureResistance,
                -1.0,
                "generator.armature_resistance = -1e0 is outside its physical range [0, 1e6] ohm",
            ),
            (
                GeneratorField::LoadResistance,
                1e12,
                "generator.load_resistance = 1e12 is outside its physical range [0, 1e9] ohm",
            ),
            (
                GeneratorField::Inductance,
                1e308,
                "generator.inductance = 1e308 is outside its physical range [0, 1e3] H",
            ),
            (
                GeneratorField::Inductance,
                f64::INFINITY,
                "generator.inductance = inf is outside its physical range [0, 1e3] H",
            ),
            (
                GeneratorField::GearRatio,
                1e200,
                "generator.gear_ratio = 1e200 is outside its physical range [1e-3, 1e4]",
            ),
            (
                GeneratorField::GearRatio,
                0.0,
                "generator.gear_ratio = 0 is outside its physical range [1e-3, 1e4]",
            ),
            (
                GeneratorField::RotorInertia,
                1e5,
                "generator.rotor_inertia = 1e5 is outside its physical range [0, 1e4] kg m^2",
            ),
        ];
        for (field, value, message) in table {
            let mut g = paper();
            set(&mut g, field, value);
            let p = g.problems();
            assert_eq!(p.len(), 1, "{field:?} = {value}: {p:?}");
            assert_eq!(p[0].field(), Some(field));
            assert_eq!(p[0].to_string(), message);
        }
        for field in GeneratorField::ALL {
            let (min, max) = field.range();
            for value in [min, max] {
                let mut g = paper();
                set(&mut g, field, value);
                assert!(
                    !g.problems()
                        .iter()
                        .any(|e| matches!(e, GeneratorError::Invalid { .. })),
                    "{field:?} = {value}"
                );
            }
        }
        // Two fields out of range: both named, in field order.
        let g = GeneratorSpec {
            kt: -1.0,
            inductance: 1e308,
            ..paper()
        };
        let fields: Vec<_> = g.problems().iter().map(|e| e.field()).collect();
        assert_eq!(
            fields,
            vec![Some(GeneratorField::Kt), Some(GeneratorField::Inductance)]
        );
    }

    fn set(g: &mut GeneratorSpec, field: GeneratorField, value: f64) {
        let slot = match field {
            GeneratorField::Kt => &mut g.kt,
            GeneratorField::Ke => &mut g.ke,
            GeneratorField::ArmatureResistance => &mut g.armature_resistance,
            GeneratorField::LoadResistance => &mut g.load_resistance,
            GeneratorField::Inductance => &mut g.inductance,
            GeneratorField::GearRatio => &mut g.gear_ratio,
            GeneratorField::RotorInertia => &mut g.rotor_inertia,
            GeneratorField::GearEfficiency => &mut g.gear_efficiency,
            GeneratorField::GearCoulomb => &mut g.gear_friction.coulomb,
            GeneratorField::GearViscous => &mut g.gear_friction.viscous,
            GeneratorField::GearSmoothing => &mut g.gear_friction.smoothing_speed,
        };
        *slot = value;
    }

    #[test]
    fn the_limit_is_inclusive_and_a_subnormal_resistance_is_blamed_once() {
        // c_g exactly at the limit passes; just above it does not.
        let at = GeneratorSpec {
            kt: 1e4,
            ke: 1e4,
            armature_resistance: 1.0,
            load_resistance: 0.0,
            gear_ratio: 1e2,
            ..paper()
        };
        assert_eq!(DerivedQuantity::Damping.value(&at), MAX_COEFFICIENT);
        assert_eq!(at.problems(), vec![]);
        let above = GeneratorSpec {
            kt: 1e4 * 1.001,
            ..at.clone()
        };
        assert_eq!(above.problems().len(), 1);
        // In-range fields over a subnormal resistance: the damping (2e305) is implausible and
        // blames the resistance, so the current per speed and the time constant (which
        // overflow) are not reported again.
        let g = GeneratorSpec {
            inductance: 1e3,
            armature_resistance: 5e-324,
            load_resistance: 0.0,
            kt: 1e-6,
            ke: 1e-6,
            gear_ratio: 1e-3,
            ..paper()
        };
        let p: Vec<_> = g.problems().iter().map(|e| e.to_string()).collect();
        assert_eq!(p.len(), 1, "{p:?}");
        assert!(p[0].contains("kt * ke * gear_ratio^2"), "{p:?}");
    }
}
