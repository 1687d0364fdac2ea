//! Coupled beam + mechanism + generator (filled by issue 5).
