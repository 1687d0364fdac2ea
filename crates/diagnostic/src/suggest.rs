//! "Did you mean": the valid names nearest to a name the user wrote, by edit distance — the
//! one helper behind every suggestion (unknown fields of a file, `--set` paths, figure
//! names).
//!
//! ```text
//! d(a, b) = Levenshtein distance by characters (insert, delete, substitute: cost 1 each)
//! kept: d <= max(3, chars(name) / 2), at most 3, closest first (ties in name order)
//! ```

/// The edit (Levenshtein) distance between `a` and `b`, by characters.
pub fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let up = row[j + 1];
            row[j + 1] = (diag + usize::from(ca != *cb)).min(row[j] + 1).min(up + 1);
            diag = up;
        }
    }
    row[b.len()]
}

/// The (at most 3) `candidates` nearest to `name`, closest first (ties in name order,
/// duplicates once), each within `max(3, chars(name) / 2)` edits; `name` itself is never
/// suggested.
pub fn nearest<I, S>(name: &str, candidates: I) -> Vec<String>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    scored(name, candidates)
        .into_iter()
        .take(3)
        .map(|(_, c)| c)
        .collect()
}

/// The [`nearest`] candidates at the smallest distance only (a typo of one name names that
/// one: `gear_ratoi` is `gear_ratio`, not also `gear_friction`).
pub fn closest<I, S>(name: &str, candidates: I) -> Vec<String>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let scored = scored(name, candidates);
    let best = scored.first().map(|(d, _)| *d);
    scored
        .into_iter()
        .take_while(|(d, _)| Some(*d) == best)
        .take(3)
        .map(|(_, c)| c)
        .collect()
}

/// The candidates within reach of `name`, with their distances, closest first.
fn scored<I, S>(name: &str, candidates: I) -> Vec<(usize, String)>
where
    I: IntoIterator<Item = S>,
    S: Into<String>,
{
    let limit = (name.chars().count() / 2).max(3);
    let mut scored: Vec<(usize, String)> = candidates
        .into_iter()
        .map(Into::into)
        .filter(|c| c != name)
        .map(|c| (levenshtein(name, &c), c))
        .filter(|(d, _)| *d <= limit)
        .collect();
    scored.sort();
    scored.dedup();
    scored
}

/// ` (did you mean `a`?)`, ` (did you mean `a` or `b`?)`; empty when there is no name.
pub fn did_you_mean(names: &[String]) -> String {
    match names {
        [] => String::new(),
        [one] => format!(" (did you mean `{one}`?)"),
        [first @ .., last] => {
            let first: Vec<String> = first.iter().map(|n| format!("`{n}`")).collect();
            format!(" (did you mean {} or `{last}`?)", first.join(", "))
        }
    }
}

/// An "unknown field `x`, expected one of `a`, `b`" message (serde's, or one written in the
/// same words) with the closest expected names appended ([`closest`], [`did_you_mean`]); any other
/// message, or one that already suggests, unchanged.
pub fn suggest_field(message: &str) -> String {
    if message.contains("did you mean") {
        return message.to_string();
    }
    let Some(at) = message.find("unknown field `") else {
        return message.to_string();
    };
    let rest = &message[at + "unknown field `".len()..];
    let Some((field, rest)) = rest.split_once('`') else {
        return message.to_string();
    };
    let Some((_, list)) = rest.split_once("expected") else {
        return message.to_string();
    };
    let expected = list.split('`').skip(1).step_by(2);
    format!("{message}{}", did_you_mean(&closest(field, expected)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distances_are_the_textbook_ones() {
        assert_eq!(levenshtein("kitten", "sitting"), 3);
        assert_eq!(levenshtein("", "abc"), 3);
        assert_eq!(levenshtein("flaw", "lawn"), 2);
        assert_eq!(levenshtein("same", "same"), 0);
    }

    #[test]
    fn the_nearest_names_are_close_sorted_and_few() {
        let c = ["load_resistance", "armature_resistance", "gear_ratio", "kt"];
        assert_eq!(nearest("load_resistanc", c), vec!["load_resistance"]);
        assert_eq!(nearest("gear_ratoi", c), vec!["gear_ratio"]);
        assert!(nearest("zzzzzzzz", c).is_empty());
        // Ties in name order, at most 3.
        assert_eq!(nearest("b", ["d", "c", "a", "e"]), vec!["a", "c", "d"]);
        // The closest only: one typo, one name.
        let c = ["gear_ratio", "gear_friction"];
        assert_eq!(
            nearest("gear_ratoi", c),
            vec!["gear_ratio", "gear_friction"]
        );
        assert_eq!(closest("gear_ratoi", c), vec!["gear_ratio"]);
    }

    #[test]
    fn unknown_field_messages_get_the_nearest_expected_name() {
        let m = "unknown field `element`, expected one of `length`, `elements`, `width`";
        assert_eq!(suggest_field(m), format!("{m} (did you mean `elements`?)"));
        let m = "unknown field `widht`, expected `width` or `height`";
        assert_eq!(suggest_field(m), format!("{m} (did you mean `width`?)"));
        let m = "unknown field `qqqqqqqqqq`, expected `width` or `height`";
        assert_eq!(suggest_field(m), m);
        assert_eq!(suggest_field("must be positive"), "must be positive");
        assert_eq!(
            did_you_mean(&["a".into(), "b".into(), "c".into()]),
            " (did you mean `a`, `b` or `c`?)"
        );
    }
}
