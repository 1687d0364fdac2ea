//! CSV time histories (the `csv` crate) of a closed-loop mechanism: its output rows with one
//! column per coordinate and velocity, written row by row to any writer — a [`super::stream::StreamFile`] in a run, so the
//! history is never held in memory.

use std::fmt::Write as _;
use std::io::Write;

use mbs_symbolic::runtime::CoordinateUnit;

use hybrid_core::closed_loop::OutputRow;

/// A closed-loop mechanism's CSV, filled row by row: `t [s]`, every coordinate
/// (`<name> [rad]` or `[m]`), every velocity (`<name>_dot [rad/s]` or `[m/s]`),
/// `kinetic_energy [J]`, `potential_energy [J]`, `total_energy [J]`,
/// `constraint_residual_norm [m]`, `cond_jv [-]`. Numbers in shortest round-trip form (scientific
/// outside [1e-4, 1e15), no negative zero); an empty cell when unknown or not finite.
pub struct MechanismCsv<W: Write = Vec<u8>> {
    w: csv::Writer<W>,
    /// One cell's text, the buffer reused by every cell.
    cell: String,
    rows: usize,
}

impl MechanismCsv {
    /// A CSV in memory with the header for these coordinate names and units.
    pub fn new(names: &[String], units: &[CoordinateUnit]) -> Result<MechanismCsv, csv::Error> {
        MechanismCsv::to_writer(names, units, Vec::new())
    }

    /// The CSV text.
    pub fn into_bytes(self) -> Result<Vec<u8>, csv::Error> {
        self.into_inner()
    }
}

impl<W: Write> MechanismCsv<W> {
    /// A CSV writing to `out`, starting with the header for these coordinate names and
    /// units.
    ///
    /// # Panics
    ///
    /// When `names` and `units` have different lengths.
    pub fn to_writer(
        names: &[String],
        units: &[CoordinateUnit],
        out: W,
    ) -> Result<MechanismCsv<W>, csv::Error> {
        assert_eq!(names.len(), units.len(), "one unit per coordinate");
        let mut w = csv::Writer::from_writer(out);
        let header = mechanism_header(names, units);
        w.write_record(&header)?;
        Ok(MechanismCsv {
            w,
            cell: String::with_capacity(32),
            rows: 0,
        })
    }

    /// Appends one output row.
    pub fn push(&mut self, r: &OutputRow) -> Result<(), csv::Error> {
        // `t` always as a number (`write_number`), the others empty when not finite or
        // unknown; field by field into one buffer, as `write_record` would write them.
        let mut field = |x: f64, t: bool| {
            self.cell.clear();
            if t {
                write_number(x, &mut self.cell);
            } else {
                write_cell(x, &mut self.cell);
            }
            self.w.write_field(self.cell.as_bytes())
        };
        field(r.t, true)?;
        for v in r.q.iter().chain(&r.qd) {
            field(*v, false)?;
        }
        field(r.kinetic_energy, false)?;
        field(r.potential_energy.unwrap_or(f64::NAN), false)?;
        field(r.total_energy().unwrap_or(f64::NAN), false)?;
        field(r.residual_norm, false)?;
        field(r.cond_jv, false)?;
        self.rows += 1;
        self.w.write_record(None::<&[u8]>)
    }

    /// Rows written.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Flushes and returns the writer.
    pub fn into_inner(self) -> Result<W, csv::Error> {
        self.w.into_inner().map_err(|e| e.into_error().into())
    }
}

/// The header of a closed-loop mechanism's time history (see [`MechanismCsv`]).
pub fn mechanism_header(names: &[String], units: &[CoordinateUnit]) -> Vec<String> {
    let mut header = vec!["t [s]".to_string()];
    header.extend(
        names
            .iter()
            .zip(units)
            .map(|(n, u)| format!("{n} [{}]", u.symbol())),
    );
    header.extend(
        names
            .iter()
            .zip(units)
            .map(|(n, u)| format!("{n}_dot [{}]", u.rate())),
    );
    header.extend(
        [
            "kinetic_energy [J]",
            "potential_energy [J]",
            "total_energy [J]",
            "constraint_residual_norm [m]",
            "cond_jv [-]",
        ]
        .map(String::from),
    );
    header
}

/// The numbers of one output row under [`mechanism_header`] (NaN where unknown: an empty
/// cell of the CSV).
pub fn mechanism_cells(r: &OutputRow, out: &mut Vec<f64>) {
    out.clear();
    out.push(r.t);
    out.extend(r.q.iter().chain(&r.qd));
    out.push(r.kinetic_energy);
    out.push(r.potential_energy.unwrap_or(f64::NAN));
    out.push(r.total_energy().unwrap_or(f64::NAN));
    out.push(r.residual_norm);
    out.push(r.cond_jv);
}

/// A number in shortest round-trip form (scientific notation outside [1e-4, 1e15), no
/// negative zero).
fn number(x: f64) -> String {
    let mut out = String::new();
    write_number(x, &mut out);
    out
}

/// Appends a number to `out` as [`number`] prints it: the shortest digits that read back to
/// `x`, plain in [1e-4, 1e15) (`0.5`, `12`, `0.000123`), scientific outside (`1e-5`,
/// `2.5e15`), `0` for either zero, `NaN`, `inf`, `-inf`: `core::fmt`'s `{}` in [1e-4, 1e15)
/// and `{:e}` outside, byte for byte.
///
/// The digits are Żmij's (the `zmij` crate, `serde_json`'s, about 180 instructions a
/// number against Ryū's 310 and some 1,500 through `core::fmt`) where they are
/// `core::fmt`'s: both give the shortest digits that read back to `x` and, among those, the
/// closest to `x`; they differ only where two are equally close (Żmij and Ryū take the even
/// one, `core::fmt` the larger one, e.g. 2^-25 = 2.98023223876953125e-8: `...312e-8` and
/// `...313e-8`), which needs the exact value of `x` to end in a 5 within 18 significant
/// digits ([`may_be_a_tie`]): those numbers (few: dyadic fractions such as 0.5, integers
/// ending in 5) are printed by `core::fmt`. Żmij's form is adapted: `12.0` -> `12`,
/// `1e+300` -> `1e300`, plain in [1e-5, 1e-4) and [1e15, 1e16) -> scientific. The test
/// `numbers_are_written_as_core_fmt_prints_them` holds it to `core::fmt` over edge cases,
/// short exact values and two million random bit patterns.
pub(crate) fn write_number(x: f64, out: &mut String) {
    let x = x + 0.0;
    let a = x.abs();
    let plain = (1e-4..1e15).contains(&a);
    if x == 0.0 {
        out.push('0');
    } else if !a.is_finite() || may_be_a_tie(a) {
        let _ = if plain {
            write!(out, "{x}")
        } else {
            write!(out, "{x:e}")
        };
    } else {
        let mut b = zmij::Buffer::new();
        let s = b.format_finite(x);
        if plain {
            // Żmij's plain form ([1e-5, 1e16)), without its `.0` after an integer.
            out.push_str(s.strip_suffix(".0").unwrap_or(s));
        } else if !(1e-5..1e16).contains(&a) {
            // Żmij's scientific form, `d.ddde-N` / `d.ddde+N`, without the `+`, as `{:e}`
            // (the `e` found from the end: at most five bytes).
            match s.bytes().rposition(|c| c == b'e') {
                Some(e) if s.as_bytes().get(e + 1) == Some(&b'+') => {
                    out.push_str(&s[..=e]);
                    out.push_str(&s[e + 2..]);
                }
                _ => out.push_str(s),
            }
        } else {
            // [1e-5, 1e-4) and [1e15, 1e16): plain for Żmij (`0.0000123`,
            // `1234567890123456.5`), scientific here. The shortest digits lie in the same
            // decade as `x` (a decimal below 1e-4 cannot read back to a double at or above
            // the double 1e-4, and so on), so the exponent is that decade's.
            push_scientific(s, if a < 1e-4 { "e-5" } else { "e15" }, out);
        }
    }
}

/// Whether the exact value of `a` (positive, finite) has at most 18 significant digits, the
/// last a 5: the only numbers whose shortest round-trip digits can be a tie (exactly halfway
/// between two candidates of 17 digits or fewer, `d5` with `d` the candidates' common
/// digits). `a = m 2^e` with `m` odd: for `e < 0`, its digits are those of `m 5^-e` (which
/// ends in 5); for `e >= 0`, those of the integer `m 2^e` without its trailing zeros (its
/// factors 10 take a 5 from `m`).
fn may_be_a_tie(a: f64) -> bool {
    const LIMIT: u128 = 1_000_000_000_000_000_000; // 10^18
    let bits = a.to_bits();
    let biased = (bits >> 52) as i32;
    let fraction = bits & ((1 << 52) - 1);
    let (m, e) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1 << 52), biased - 1075)
    };
    let t = m.trailing_zeros();
    let (m, e) = (u128::from(m >> t), e + t as i32);
    if e < 0 {
        // 5^27 > 10^18.
        e >= -26 && m * 5u128.pow(e.unsigned_abs()) < LIMIT
    } else {
        // The factors 10 of m 2^e: one 5 of m and one 2 each.
        let mut fives = 0;
        let mut odd = m;
        while odd % 5 == 0 && fives < e {
            odd /= 5;
            fives += 1;
        }
        // What is left: odd 2^(e - fives), its digits the significant ones.
        let shift = e - fives;
        shift < 64 && odd << shift < LIMIT && (odd << shift) % 10 == 5
    }
}

/// Appends a plain form of a number (`-0.0000123`, `1234567890123456.5`, `1e15` as
/// `1000000000000000.0`) in scientific form with this exponent (`e-5`): its significant
/// digits (the leading and trailing zeros dropped) as `d.ddd`, or `d` alone.
fn push_scientific(plain: &str, exponent: &str, out: &mut String) {
    let (sign, body) = match plain.strip_prefix('-') {
        Some(body) => ("-", body),
        None => ("", plain),
    };
    // The digits `a` then `b` (before and after the point), the zeros at either end off.
    let (mut a, mut b) = body.split_once('.').unwrap_or((body, ""));
    b = b.trim_end_matches('0');
    if b.is_empty() {
        a = a.trim_end_matches('0');
    }
    a = a.trim_start_matches('0');
    if a.is_empty() {
        b = b.trim_start_matches('0');
    }
    // The first digit, then the others after a point.
    let (first, a, b) = match (a.get(..1), b.get(..1)) {
        (Some(d), _) => (d, &a[1..], b),
        (None, Some(d)) => (d, "", &b[1..]),
        (None, None) => ("0", "", ""),
    };
    out.push_str(sign);
    out.push_str(first);
    if !a.is_empty() || !b.is_empty() {
        out.push('.');
        out.push_str(a);
        out.push_str(b);
    }
    out.push_str(exponent);
}

/// A number; an empty cell when unknown or not finite.
pub(crate) fn cell(x: Option<f64>) -> String {
    x.filter(|x| x.is_finite()).map(number).unwrap_or_default()
}

/// Appends the cell of a number to `out`: [`write_number`], nothing when not finite (as
/// [`cell`]).
pub(crate) fn write_cell(x: f64, out: &mut String) {
    if x.is_finite() {
        write_number(x, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_shortest_round_trip_without_negative_zero() {
        assert_eq!(number(-0.0), "0");
        assert_eq!(number(0.5), "0.5");
        assert_eq!(number(1e-5), "1e-5");
        assert_eq!(number(2e15), "2e15");
        assert_eq!(cell(Some(f64::NAN)), "");
        assert_eq!(cell(None), "");
    }

    /// The form before Żmij: `core::fmt`'s `{}` in [1e-4, 1e15), `{:e}` outside.
    fn number_by_fmt(x: f64) -> String {
        let x = x + 0.0;
        if x == 0.0 || (1e-4..1e15).contains(&x.abs()) {
            format!("{x}")
        } else {
            format!("{x:e}")
        }
    }

    /// A fixed-seed generator of 64-bit patterns (splitmix64).
    fn splitmix(state: &mut u64) -> u64 {
        *state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = *state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    #[test]
    fn numbers_are_written_as_core_fmt_prints_them() {
        let check = |x: f64| {
            assert_eq!(number(x), number_by_fmt(x), "{x:e} ({:#018x})", x.to_bits());
        };
        // Edge cases: zeros, the extremes, subnormals, every power of ten and of two, the
        // neighbours of each bound of the forms (1e-5, 1e-4, 1e15, 1e16), integers, short
        // decimals.
        let mut edges = vec![
            0.0,
            f64::MAX,
            f64::MIN_POSITIVE,
            f64::EPSILON,
            f64::from_bits(1),
            f64::from_bits(0x000f_ffff_ffff_ffff),
            0.1 + 0.2,
            1.0 / 3.0,
            2f64.powi(53),
            2f64.powi(53) + 2.0,
            f64::NAN,
            f64::INFINITY,
            5e-324,
            1.7976931348623157e308,
            123456789012345.6,
            999999999999999.9,
            9999999999999998.0,
        ];
        for e in -325..=309 {
            edges.push(format!("1e{e}").parse().unwrap());
            edges.push(format!("9.999999999999999e{e}").parse().unwrap());
            edges.push(format!("5e{e}").parse().unwrap());
        }
        for e in -1074..=1023 {
            edges.push(2f64.powi(e));
        }
        for b in [1e-5, 1e-4, 1e15, 1e16] {
            let mut x: f64 = b;
            for _ in 0..100 {
                x = f64::from_bits(x.to_bits() - 1);
            }
            for _ in 0..200 {
                edges.push(x);
                x = f64::from_bits(x.to_bits() + 1);
            }
        }
        for n in 0..20_000u32 {
            edges.push(f64::from(n));
            edges.push(f64::from(n) / 1000.0);
            edges.push(f64::from(n) * 1e-7);
            edges.push(f64::from(n) * 1e11);
        }
        for x in edges {
            check(x);
            check(-x);
        }
        // A fixed-seed sweep: random bit patterns (every exponent), and random significands
        // with exponents within and around the plain form's range.
        let mut s = 0x5eed_u64;
        // Short exact values, where the ties are: dyadic fractions m 2^-k and integers with
        // a 5 in their last digit (some 2^53 and above).
        for i in 0..200_000u64 {
            let m = (splitmix(&mut s) >> (24 + i % 40)) | 1;
            check(m as f64 * 2f64.powi(-((i % 70) as i32)));
            let n = (splitmix(&mut s) % 100_000_000_000_000_000) * 10 + 5;
            check(n as f64);
            check(n as f64 * 2f64.powi((i % 30) as i32));
        }
        for _ in 0..1_000_000 {
            let bits = splitmix(&mut s);
            check(f64::from_bits(bits));
            let e = 1023 - 20 + (bits >> 52) % 80; // 2^-20 .. 2^59
            check(f64::from_bits((bits & 0x800f_ffff_ffff_ffff) | (e << 52)));
        }
        let mut out = String::from("x");
        write_cell(f64::NAN, &mut out);
        write_cell(f64::NEG_INFINITY, &mut out);
        write_cell(-0.0, &mut out);
        write_cell(2.5e-7, &mut out);
        assert_eq!(out, "x02.5e-7");
    }
}
