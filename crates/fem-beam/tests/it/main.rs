//! The one integration-test binary of `fem-beam` (STYLE.md rule 7): one module per
//! area, built and linked once.

mod beam;
