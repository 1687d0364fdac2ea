//! The DC generator used as the damper (THEORY.md section 7).
//!
//! The generator sits on one joint of the mechanism (the crank) through a gear of ratio `n`:
//! motor speed `w_m = n q'`, EMF `e = k_e w_m`, circuit `L i' + (R_a + R_L) i = e`, torque on
//! the joint `tau = -n k_t i`, which enters the paper's `Q^b` (eq. 13) as `+n k_t i`. With
//! `L = 0`, `tau = -c_g q'` with `c_g = n^2 k_t k_e / (R_a + R_L)`. The rotor inertia adds
//! `n^2 J_r` to the joint's diagonal entry of `M^b`. Dissipated power `(R_a + R_L) i^2`, of
//! which `R_L i^2` is harvested in the load.

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
}

fn one() -> f64 {
    1.0
}

fn yes() -> bool {
    true
}

impl GeneratorSpec {
    /// Total circuit resistance `R_a + R_L`.
    pub fn resistance(&self) -> f64 {
        self.armature_resistance + self.load_resistance
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
    pub fn reflected_inertia(&self) -> f64 {
        self.gear_ratio.powi(2) * self.rotor_inertia
    }

    /// Whether the current is a state of its own (inductance > 0 and connected).
    pub fn has_current_state(&self) -> bool {
        self.connected && self.inductance > 0.0
    }

    /// Adds the generator to the mechanism's equations on joint `joint` — the one place it
    /// is added: the reflected rotor inertia `n^2 J_r` on the diagonal of `M^b` (eq. 11) and
    /// the torque for `current`, paper sign `+n k_t i`, to `Q^b` (eq. 13). With zero
    /// inductance and the quasi-static current this is the viscous damper `c_g q'`.
    pub fn add_to_equations(
        &self,
        joint: usize,
        current: f64,
        m: &mut nalgebra::DMatrix<f64>,
        q: &mut nalgebra::DVector<f64>,
    ) {
        m[(joint, joint)] += self.reflected_inertia();
        q[joint] += self.q_term(current);
    }

    /// The current when the inductance is zero: `i = k_e n q' / (R_a + R_L)`.
    pub fn quasi_static_current(&self, joint_speed: f64) -> f64 {
        if self.connected {
            self.ke * self.gear_ratio * joint_speed / self.resistance()
        } else {
            0.0
        }
    }

    /// The generator's contribution to `Q^b` of its joint, paper sign: `+n k_t i`.
    pub fn q_term(&self, current: f64) -> f64 {
        self.gear_ratio * self.kt * current
    }

    /// Every problem with the values, in field order (empty when the generator is usable).
    pub fn problems(&self) -> Vec<GeneratorError> {
        let checks = [
            (GeneratorField::Kt, self.kt, false),
            (GeneratorField::Ke, self.ke, false),
            (
                GeneratorField::ArmatureResistance,
                self.armature_resistance,
                true,
            ),
            (GeneratorField::LoadResistance, self.load_resistance, true),
            (GeneratorField::Inductance, self.inductance, true),
            (GeneratorField::GearRatio, self.gear_ratio, false),
            (GeneratorField::RotorInertia, self.rotor_inertia, true),
        ];
        let mut out = vec![];
        for (field, value, zero_ok) in checks {
            if !value.is_finite() || value < 0.0 || (!zero_ok && value == 0.0) {
                out.push(GeneratorError::Invalid {
                    field,
                    value,
                    zero_ok,
                });
            }
        }
        if out.is_empty() && self.resistance() <= 0.0 {
            out.push(GeneratorError::NoResistance);
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
}

impl GeneratorField {
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
        }
    }
}

/// A generator value the model cannot use.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum GeneratorError {
    /// A field out of its range.
    #[error(
        "generator.{} must be a finite {} number (got {value})",
        field.name(),
        if *zero_ok { "non-negative" } else { "positive" }
    )]
    Invalid {
        /// The field.
        field: GeneratorField,
        /// Its value.
        value: f64,
        /// Whether 0 is allowed.
        zero_ok: bool,
    },
    /// `R_a + R_L` is zero.
    #[error("generator: armature_resistance + load_resistance must be positive")]
    NoResistance,
}

impl GeneratorError {
    /// The field concerned, when it is one field.
    pub fn field(&self) -> Option<GeneratorField> {
        match self {
            GeneratorError::Invalid { field, .. } => Some(*field),
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
}
