//! The operation-count table of `damper generate --stats`: one row per generated function
//! (adds, muls, divs, funcs, negs, total) and a final `all` row with the sums.

use std::fmt::Write as _;

use mbs_symbolic::expr::OpCount;

/// Longest function name shown in the `--stats` table; longer ones (point names can be
/// arbitrarily long) are truncated with an ellipsis.
pub const STATS_NAME_WIDTH: usize = 60;

/// The `--stats` table: one row per function and a final `all` row with the sums.
pub fn stats_table(stats: &[(String, OpCount)]) -> String {
    let shown = |name: &str| diagnostic::truncate(name, STATS_NAME_WIDTH);
    let width = stats
        .iter()
        .map(|(name, _)| shown(name).chars().count())
        .chain([8])
        .max()
        .unwrap_or(8);
    let mut out = String::new();
    let mut row = |name: &str, c: &OpCount| {
        let name = shown(name);
        let _ = writeln!(
            out,
            "{name:<width$}  {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}",
            c.adds,
            c.muls,
            c.divs,
            c.funcs,
            c.negs,
            c.total()
        );
    };
    let mut all = OpCount::default();
    for (name, c) in stats {
        row(name, c);
        all = all + *c;
    }
    row("all", &all);
    format!(
        "{:<width$}  {:>6} {:>6} {:>6} {:>6} {:>6} {:>6}\n{out}",
        "function", "adds", "muls", "divs", "funcs", "negs", "total"
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_table_has_a_header_one_row_per_function_and_the_sums() {
        let c = |adds, muls| OpCount {
            adds,
            muls,
            divs: 1,
            funcs: 2,
            negs: 0,
        };
        let t = stats_table(&[("mass_matrix".into(), c(6, 13)), ("f".into(), c(1, 2))]);
        let lines: Vec<Vec<&str>> = t.lines().map(|l| l.split_whitespace().collect()).collect();
        assert_eq!(
            lines,
            vec![
                vec!["function", "adds", "muls", "divs", "funcs", "negs", "total"],
                vec!["mass_matrix", "6", "13", "1", "2", "0", "22"],
                vec!["f", "1", "2", "1", "2", "0", "6"],
                vec!["all", "7", "15", "2", "4", "0", "28"],
            ]
        );
    }

    /// `{name:<width$}` panics ("Formatting argument out of range") for widths over 65,535:
    /// a point name of 70,000 characters must give a truncated row, not a panic.
    #[test]
    fn stats_table_with_a_name_over_65535_chars_truncates_instead_of_panicking() {
        let long = format!("point_{}", "x".repeat(70_000));
        let t = stats_table(&[(long.clone(), OpCount::default())]);
        let row = t.lines().nth(1).unwrap();
        let name = row.split_whitespace().next().unwrap();
        assert_eq!(name.chars().count(), STATS_NAME_WIDTH + 1, "{name}"); // and the ellipsis
        assert!(long.starts_with(name.trim_end_matches('…')));
        assert!(t.len() < 1000);
    }
}
