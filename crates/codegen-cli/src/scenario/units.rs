//! Physical quantities as a datasheet writes them: `"25.5 mNm/A"`, `"374 rpm/V"`,
//! `"10.2 g cm^2"` — a number, then a unit made of symbols with SI prefixes — converted to
//! SI and checked against the dimension a field expects.
//!
//! # Units
//!
//! A unit is a product of factors separated by spaces, `·`, `⋅` or `*`; a factor after `/`
//! is divided by (`rad/s/V` = rad s^-1 V^-1, `N m s/rad` = N m s rad^-1: the slash applies
//! to the one factor after it). A factor is a symbol with an optional prefix and an optional
//! exponent `^2`, `^-1`, `²` or `³` (the prefix is raised too: `cm^2` = 1e-4 m^2).
//!
//! | symbol | meaning | SI |
//! |---|---|---|
//! | `m`, `g`, `s`, `A` | metre, gram (1e-3 kg), second, ampere | |
//! | `min` | minute | 60 s |
//! | `N`, `Nm` | newton, newton metre | kg m s^-2, kg m^2 s^-2 |
//! | `V` | volt | kg m^2 s^-3 A^-1 |
//! | `ohm`, `Ohm`, `Ω` | ohm | kg m^2 s^-3 A^-2 |
//! | `H` | henry | kg m^2 s^-2 A^-2 |
//! | `rad`, `rev` | radian, revolution | 1, 2π |
//! | `rpm` | revolution per minute | 2π/60 s^-1 = π/30 rad/s |
//! | `%` | per cent | 1e-2 |
//!
//! Prefixes: `G` 1e9, `M` 1e6, `k` 1e3, `c` 1e-2, `m` 1e-3, `u`, `µ`, `μ` 1e-6, `n` 1e-9
//! (`mm` is a millimetre, `min` a minute, `mNm` a millinewton metre, `kg` a kilogram).
//! Angles are dimensionless (SI): `N m/A` and `V s/rad` are the same dimension, so a
//! torque constant and an EMF constant convert to the same SI number for an ideal machine,
//! and a speed constant `k_n` in rpm/V is the EMF constant `k_e = 60 / (2π k_n)` V s/rad
//! inverted.
//!
//! # Exactness
//!
//! The number is read as an integer mantissa and a power of ten (`"10.2"` = 102 × 10^-1),
//! multiplied by the product of the non-decimal factors (2π, 60, ...) and then by, or
//! divided by, the exact power of ten of its own exponent, the prefixes and the gram:
//! `"10.2 g cm^2"` is `102 / 10^8`, the double nearest to 1.02e-6. Conversions through
//! rpm carry a few roundings of π/30 (relative error below 1e-15).

use std::f64::consts::PI;

/// Exponents of kg, m, s, A.
type Exponents = [i32; 4];

/// The dimension a field expects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dimension {
    /// Torque per current, N m/A (= V s/rad: torque and EMF constants).
    TorquePerCurrent,
    /// Speed per voltage, rad/s/V (speed constants).
    SpeedPerVoltage,
    /// Resistance, ohm.
    Resistance,
    /// Inductance, H.
    Inductance,
    /// Moment of inertia, kg m^2.
    Inertia,
    /// Torque, N m.
    Torque,
    /// Rotational damping, N m s/rad.
    RotationalDamping,
    /// Angular speed, rad/s.
    AngularSpeed,
    /// A pure number.
    Dimensionless,
}

impl Dimension {
    const ALL: [Dimension; 9] = [
        Dimension::TorquePerCurrent,
        Dimension::SpeedPerVoltage,
        Dimension::Resistance,
        Dimension::Inductance,
        Dimension::Inertia,
        Dimension::Torque,
        Dimension::RotationalDamping,
        Dimension::AngularSpeed,
        Dimension::Dimensionless,
    ];

    fn exponents(self) -> Exponents {
        match self {
            Dimension::TorquePerCurrent => [1, 2, -2, -1],
            Dimension::SpeedPerVoltage => [-1, -2, 2, 1],
            Dimension::Resistance => [1, 2, -3, -2],
            Dimension::Inductance => [1, 2, -2, -2],
            Dimension::Inertia => [1, 2, 0, 0],
            Dimension::Torque => [1, 2, -2, 0],
            Dimension::RotationalDamping => [1, 2, -1, 0],
            Dimension::AngularSpeed => [0, 0, -1, 0],
            Dimension::Dimensionless => [0, 0, 0, 0],
        }
    }

    /// What it is, with its SI unit and a datasheet example: `a torque per current (N m/A,
    /// e.g. "25.5 mNm/A")`.
    pub fn describe(self) -> &'static str {
        match self {
            Dimension::TorquePerCurrent => {
                "a torque per current (N m/A = V s/rad, e.g. \"25.5 mNm/A\" or \"2.67 V/krpm\")"
            }
            Dimension::SpeedPerVoltage => "a speed per voltage (rad/s/V, e.g. \"374 rpm/V\")",
            Dimension::Resistance => "a resistance (ohm, e.g. \"1.5 ohm\" or \"820 mOhm\")",
            Dimension::Inductance => "an inductance (H, e.g. \"0.2 mH\")",
            Dimension::Inertia => "a moment of inertia (kg m^2, e.g. \"10.2 g cm^2\")",
            Dimension::Torque => "a torque (N m, e.g. \"0.5 mNm\")",
            Dimension::RotationalDamping => {
                "a rotational damping (N m s/rad, e.g. \"1e-6 Nm s/rad\" or \"0.01 mNm/krpm\")"
            }
            Dimension::AngularSpeed => "an angular speed (rad/s, e.g. \"10 rpm\")",
            Dimension::Dimensionless => "a pure number",
        }
    }

    /// The SI unit a value of this dimension is held in (`N m/A`, `ohm`, ...; `-` for a pure
    /// number): what an axis or a column of it reads in.
    pub fn si_unit(self) -> &'static str {
        match self {
            Dimension::TorquePerCurrent => "N m/A",
            Dimension::SpeedPerVoltage => "rad/s/V",
            Dimension::Resistance => "ohm",
            Dimension::Inductance => "H",
            Dimension::Inertia => "kg m^2",
            Dimension::Torque => "N m",
            Dimension::RotationalDamping => "N m s/rad",
            Dimension::AngularSpeed => "rad/s",
            Dimension::Dimensionless => "-",
        }
    }

    fn short(self) -> &'static str {
        match self {
            Dimension::TorquePerCurrent => "a torque per current",
            Dimension::SpeedPerVoltage => "a speed per voltage",
            Dimension::Resistance => "a resistance",
            Dimension::Inductance => "an inductance",
            Dimension::Inertia => "a moment of inertia",
            Dimension::Torque => "a torque",
            Dimension::RotationalDamping => "a rotational damping",
            Dimension::AngularSpeed => "an angular speed",
            Dimension::Dimensionless => "a pure number",
        }
    }
}

/// Units of the scenario fields that are neither generator nor beam-segment fields, by the
/// field's name.
const OTHER_FIELD_UNITS: [(&str, &str); 14] = [
    ("half_angle_deg", "deg"),
    ("angle_deg", "deg"),
    ("t_end", "s"),
    ("dt", "s"),
    ("output_step", "s"),
    ("max_step", "s"),
    ("displacement", "m"),
    ("x", "m"),
    ("frequency", "Hz"),
    ("ratio", "-"),
    ("elements", "-"),
    ("every", "-"),
    ("max_condition", "-"),
    ("alpha", "-"),
];

/// The SI unit of a numeric scenario field by its `--set` PATH (`generator.load_resistance`
/// → `ohm`, `mechanism.half_angle_deg` → `deg`, `beam.segment[0].length` → `m`), from the
/// field's last name: the generator's fields by their dimension, the beam segments' by
/// `fem_beam::PHYSICAL_RANGES`, a few others by a table. `None` where the unit depends on
/// the context (an excitation's `amplitude`, a spring's `k`) or the name is unknown.
pub fn field_unit(path: &str) -> Option<&'static str> {
    let last = path.rsplit('.').next().unwrap_or(path);
    let name = last.split('[').next().unwrap_or(last);
    if let Some(d) = super::hybrid::generator::field_dimension(name) {
        return Some(d.si_unit());
    }
    fem_beam::PHYSICAL_RANGES
        .iter()
        .find(|r| r.0 == name)
        .map(|r| r.3)
        .or_else(|| {
            OTHER_FIELD_UNITS
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, u)| *u)
        })
}

/// An axis label for a swept field: its PATH and, where known, its unit in brackets
/// (`generator.load_resistance [ohm]`), as the figures' columns read.
pub fn field_label(path: &str) -> String {
    match field_unit(path) {
        Some(unit) => format!("{path} [{unit}]"),
        None => path.to_string(),
    }
}

/// Why a quantity cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UnitError {
    /// No number at the start.
    #[error("{text:?} does not start with a number (expected e.g. \"25.5 mNm/A\")")]
    NoNumber {
        /// The text.
        text: String,
    },
    /// A unit symbol not in the table.
    #[error(
        "unknown unit {symbol:?} in {text:?} (known: m g s min A N Nm V ohm Ω H rad rev rpm %, \
         with prefixes G M k c m u µ n)"
    )]
    UnknownUnit {
        /// The symbol.
        symbol: String,
        /// The text.
        text: String,
    },
    /// A malformed unit expression (empty factor, bad exponent).
    #[error("malformed unit in {text:?}")]
    Malformed {
        /// The text.
        text: String,
    },
    /// The unit is of another dimension than the field's.
    #[error("{text:?} is {found}, expected {}", expected.describe())]
    WrongDimension {
        /// The text.
        text: String,
        /// What it is.
        found: String,
        /// What the field expects.
        expected: Dimension,
    },
    /// The converted value is not finite.
    #[error("{text:?} is not a finite number")]
    NotFinite {
        /// The text.
        text: String,
    },
}

/// A unit symbol: its factor apart from powers of ten, its power of ten, its dimension.
fn symbol(s: &str) -> Option<(f64, i32, Exponents)> {
    Some(match s {
        "m" => (1.0, 0, [0, 1, 0, 0]),
        "g" => (1.0, -3, [1, 0, 0, 0]),
        "s" => (1.0, 0, [0, 0, 1, 0]),
        "min" => (60.0, 0, [0, 0, 1, 0]),
        "A" => (1.0, 0, [0, 0, 0, 1]),
        "N" => (1.0, 0, [1, 1, -2, 0]),
        "Nm" => (1.0, 0, [1, 2, -2, 0]),
        "V" => (1.0, 0, [1, 2, -3, -1]),
        "ohm" | "Ohm" | "\u{3a9}" | "\u{2126}" => (1.0, 0, [1, 2, -3, -2]),
        "H" => (1.0, 0, [1, 2, -2, -2]),
        "rad" => (1.0, 0, [0; 4]),
        "rev" => (2.0 * PI, 0, [0; 4]),
        "rpm" => (PI / 30.0, 0, [0, 0, -1, 0]),
        "%" => (1.0, -2, [0; 4]),
        _ => return None,
    })
}

/// A symbol with an optional prefix (the symbol itself first: `min`, `mm` = milli-metre).
fn prefixed(s: &str) -> Option<(f64, i32, Exponents)> {
    if let Some(u) = symbol(s) {
        return Some(u);
    }
    let c = s.chars().next()?;
    let p = match c {
        'G' => 9,
        'M' => 6,
        'k' => 3,
        'c' => -2,
        'm' => -3,
        'u' | '\u{b5}' | '\u{3bc}' => -6,
        'n' => -9,
        _ => return None,
    };
    let (f, e, d) = symbol(&s[c.len_utf8()..])?;
    Some((f, e + p, d))
}

/// A quantity read from text: its SI value and dimension.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Quantity {
    value: f64,
    dims: Exponents,
}

/// Splits a factor into its symbol and exponent (`cm^2`, `cm²`, `s^-1`).
fn exponent(factor: &str) -> Option<(&str, i32)> {
    if let Some(base) = factor.strip_suffix('\u{b2}') {
        return Some((base, 2));
    }
    if let Some(base) = factor.strip_suffix('\u{b3}') {
        return Some((base, 3));
    }
    match factor.split_once('^') {
        Some((base, e)) => e
            .parse::<i32>()
            .ok()
            .filter(|e| e.abs() <= 9)
            .map(|e| (base, e)),
        None => Some((factor, 1)),
    }
}

/// A decimal number as an integer mantissa (exact below 2^53) and a power of ten:
/// `"10.2"` is `(102, -1)`, `"1.5e-3"` is `(15, -4)`; a mantissa of more than 15 digits is
/// rounded by the ordinary parse instead (power 0).
fn decimal_parts(s: &str) -> Option<(f64, i32)> {
    let (m, e) = match s.find(['e', 'E']) {
        Some(i) => (&s[..i], s[i + 1..].parse::<i32>().ok()?),
        None => (s, 0),
    };
    let (int, frac) = m.split_once('.').unwrap_or((m, ""));
    let (sign, int) = match int.strip_prefix('-') {
        Some(rest) => (-1.0, rest),
        None => (1.0, int.strip_prefix('+').unwrap_or(int)),
    };
    let digits = format!("{int}{frac}");
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    if digits.len() > 15 || e.abs() > 300 {
        return s.parse::<f64>().ok().map(|v| (v, 0));
    }
    let m: u64 = digits.parse().ok()?;
    Some((sign * m as f64, e - frac.len() as i32))
}

fn parse(text: &str) -> Result<Quantity, UnitError> {
    let t = text.trim();
    let end = t
        .char_indices()
        .find(|&(_, c)| !(c.is_ascii_digit() || matches!(c, '+' | '-' | '.' | 'e' | 'E')))
        .map_or(t.len(), |(i, _)| i);
    let (mantissa, mut decimal) = decimal_parts(&t[..end]).ok_or_else(|| UnitError::NoNumber {
        text: text.to_string(),
    })?;
    let malformed = || UnitError::Malformed {
        text: text.to_string(),
    };
    let mut factor = 1.0;
    let mut dims: Exponents = [0; 4];
    let mut invert = false;
    let mut token = String::new();
    let mut factors: Vec<(String, bool)> = vec![];
    for c in t[end..].chars().chain(std::iter::once(' ')) {
        match c {
            ' ' | '\t' | '\u{b7}' | '\u{22c5}' | '*' | '/' => {
                if !token.is_empty() {
                    factors.push((std::mem::take(&mut token), invert));
                    invert = false;
                } else if invert {
                    return Err(malformed());
                }
                if c == '/' {
                    invert = true;
                }
            }
            c => token.push(c),
        }
    }
    for (f, inverted) in factors {
        let (base, e) = exponent(&f).ok_or_else(malformed)?;
        let (scale, dec, d) = prefixed(base).ok_or_else(|| UnitError::UnknownUnit {
            symbol: base.to_string(),
            text: text.to_string(),
        })?;
        let e = if inverted { -e } else { e };
        factor *= scale.powi(e);
        decimal += dec * e;
        for (x, y) in dims.iter_mut().zip(d) {
            *x += y * e;
        }
    }
    let mut value = mantissa * factor;
    // 10^k is exact up to k = 22; beyond, split the scaling (rare: an extreme exponent).
    while decimal != 0 {
        let k = decimal.clamp(-22, 22);
        if k > 0 {
            value *= 10f64.powi(k);
        } else {
            value /= 10f64.powi(-k);
        }
        decimal -= k;
    }
    if !value.is_finite() {
        return Err(UnitError::NotFinite {
            text: text.to_string(),
        });
    }
    Ok(Quantity { value, dims })
}

/// The SI value of `text` (a number and a unit), which must be of dimension `expected`.
pub fn convert(text: &str, expected: Dimension) -> Result<f64, UnitError> {
    let q = parse(text)?;
    if q.dims == expected.exponents() {
        return Ok(q.value);
    }
    let found = match Dimension::ALL.iter().find(|d| d.exponents() == q.dims) {
        Some(d) => d.short().to_string(),
        None => {
            let names = ["kg", "m", "s", "A"];
            let parts: Vec<String> = names
                .iter()
                .zip(q.dims)
                .filter(|&(_, e)| e != 0)
                .map(|(n, e)| {
                    if e == 1 {
                        n.to_string()
                    } else {
                        format!("{n}^{e}")
                    }
                })
                .collect();
            format!("in {}", parts.join(" "))
        }
    };
    Err(UnitError::WrongDimension {
        text: text.to_string(),
        found,
        expected,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn swept_fields_have_their_units() {
        use super::{field_label, field_unit};
        assert_eq!(field_unit("generator.load_resistance"), Some("ohm"));
        assert_eq!(field_unit("force[0].speed_constant"), Some("rad/s/V"));
        assert_eq!(field_unit("force[1].gear_friction.coulomb"), Some("N m"));
        assert_eq!(
            field_unit("mechanism[0].placement.half_angle_deg"),
            Some("deg")
        );
        assert_eq!(field_unit("beam.segment[0].youngs_modulus"), Some("Pa"));
        assert_eq!(field_unit("beam.segment[0].elements"), Some("-"));
        assert_eq!(field_unit("excitation[0].amplitude"), None);
        assert_eq!(
            field_label("generator.gear_ratio"),
            "generator.gear_ratio [-]"
        );
        assert_eq!(field_label("spring.k"), "spring.k");
    }

    use super::*;

    /// The datasheet forms against SI values computed by hand, to 1e-15 relative.
    #[test]
    fn datasheet_units_convert_to_si_exactly() {
        use Dimension::*;
        let rpm = PI / 30.0; // rad/s per rpm
        let table: &[(&str, Dimension, f64)] = &[
            ("25.5 mNm/A", TorquePerCurrent, 0.0255),
            ("0.0255 Nm/A", TorquePerCurrent, 0.0255),
            ("25.5 mN m/A", TorquePerCurrent, 0.0255),
            ("0.0255 N m/A", TorquePerCurrent, 0.0255),
            ("0.0255 N·m/A", TorquePerCurrent, 0.0255),
            ("0.0255 V s/rad", TorquePerCurrent, 0.0255),
            ("2.67 V/krpm", TorquePerCurrent, 2.67e-3 / rpm),
            ("2.67 mV/rpm", TorquePerCurrent, 2.67e-3 * 30.0 / PI),
            ("374 rpm/V", SpeedPerVoltage, 374.0 * 2.0 * PI / 60.0),
            ("39.2 rad/s/V", SpeedPerVoltage, 39.2),
            ("1.5 ohm", Resistance, 1.5),
            ("1.5 Ω", Resistance, 1.5),
            ("820 mOhm", Resistance, 0.82),
            ("2 kohm", Resistance, 2000.0),
            ("0.2 mH", Inductance, 2e-4),
            ("120 uH", Inductance, 1.2e-4),
            ("120 µH", Inductance, 1.2e-4),
            ("10.2 g cm^2", Inertia, 1.02e-6),
            ("10.2 g cm²", Inertia, 1.02e-6),
            ("1e-6 kg m^2", Inertia, 1e-6),
            ("1.02 kg mm^2", Inertia, 1.02e-6),
            ("0.5 mNm", Torque, 5e-4),
            ("0.5 N m", Torque, 0.5),
            ("1e-6 Nm s/rad", RotationalDamping, 1e-6),
            ("0.01 mNm/krpm", RotationalDamping, 1e-5 / (1000.0 * rpm)),
            ("10 rpm", AngularSpeed, 10.0 * rpm),
            ("2 rad/s", AngularSpeed, 2.0),
            ("85 %", Dimensionless, 0.85),
            ("85%", Dimensionless, 0.85),
            ("0.85", Dimensionless, 0.85),
        ];
        for &(text, dim, si) in table {
            let v = convert(text, dim).unwrap_or_else(|e| panic!("{text}: {e}"));
            assert!(
                ((v - si) / si).abs() <= 1e-15,
                "{text}: {v:e} against {si:e} ({:e})",
                (v - si) / si
            );
        }
        // Decimal prefixes alone are exact: the nearest double of the SI value.
        assert_eq!(convert("25.5 mNm/A", TorquePerCurrent).unwrap(), 0.0255);
        assert_eq!(convert("820 mOhm", Resistance).unwrap(), 0.82);
        assert_eq!(convert("10.2 g cm^2", Inertia).unwrap(), 1.02e-6);
        // The speed constant 374 rpm/V inverts to the EMF constant 60 / (2 pi 374).
        let kn = convert("374 rpm/V", SpeedPerVoltage).unwrap();
        let ke = 60.0 / (2.0 * PI * 374.0);
        assert!(((1.0 / kn - ke) / ke).abs() <= 1e-15);
    }

    #[test]
    fn a_unit_of_the_wrong_dimension_is_named_with_the_expected_one() {
        let cases: &[(&str, Dimension, &str)] = &[
            (
                "25.5 mNm",
                Dimension::TorquePerCurrent,
                "\"25.5 mNm\" is a torque, expected a torque per current (N m/A",
            ),
            (
                "374 rpm/V",
                Dimension::TorquePerCurrent,
                "is a speed per voltage, expected a torque per current",
            ),
            (
                "10.2 g cm",
                Dimension::Inertia,
                "is in kg m, expected a moment of inertia",
            ),
            (
                "1.5",
                Dimension::Resistance,
                "is a pure number, expected a resistance",
            ),
            (
                "3 mH",
                Dimension::Resistance,
                "is an inductance, expected a resistance",
            ),
        ];
        for &(text, dim, needle) in cases {
            let e = convert(text, dim).unwrap_err().to_string();
            assert!(e.contains(needle), "{text}: {e}");
        }
        assert!(matches!(
            convert("25.5 mNm/Q", Dimension::TorquePerCurrent),
            Err(UnitError::UnknownUnit { .. })
        ));
        assert!(matches!(
            convert("mNm/A", Dimension::TorquePerCurrent),
            Err(UnitError::NoNumber { .. })
        ));
        assert!(matches!(
            convert("1 N m//A", Dimension::TorquePerCurrent),
            Err(UnitError::Malformed { .. })
        ));
        assert!(matches!(
            convert("1 cm^x", Dimension::Inertia),
            Err(UnitError::Malformed { .. })
        ));
        assert!(matches!(
            convert("1e308 kNm/A", Dimension::TorquePerCurrent),
            Err(UnitError::NotFinite { .. })
        ));
    }
}
