//! The bundled mechanisms compiled into this binary (hybrid-core generates them at build time
//! from `models/double_bar.toml`, `models/four_bar.toml` and `models/slider_crank.toml`), for
//! `damper eval --backend generated`.
//!
//! A model file given on the command line is matched against them by its FNV-1a content
//! hash ([`mbs_symbolic::model::SourceInfo::hash`]): only a byte-identical copy of a bundled
//! model uses the compiled code, so an edited model can never be evaluated with stale
//! equations.

pub use hybrid_core::generated::{double_bar, four_bar, slider_crank};

/// One of the mechanisms compiled into the binary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bundled {
    /// `models/double_bar.toml` ([`double_bar::DoubleBar`]).
    DoubleBar,
    /// `models/four_bar.toml` ([`four_bar::FourBar`]).
    FourBar,
    /// `models/slider_crank.toml` ([`slider_crank::SliderCrank`]).
    SliderCrank,
}

impl Bundled {
    /// Every compiled-in model, in the order they are listed to the user.
    pub const ALL: [Bundled; 3] = [Bundled::DoubleBar, Bundled::FourBar, Bundled::SliderCrank];

    /// The model's file stem under `models/`.
    pub fn name(self) -> &'static str {
        match self {
            Bundled::DoubleBar => "double_bar",
            Bundled::FourBar => "four_bar",
            Bundled::SliderCrank => "slider_crank",
        }
    }

    /// FNV-1a 64 hash of the model file the code was generated from.
    pub fn hash(self) -> &'static str {
        match self {
            Bundled::DoubleBar => double_bar::SOURCE_HASH,
            Bundled::FourBar => four_bar::SOURCE_HASH,
            Bundled::SliderCrank => slider_crank::SOURCE_HASH,
        }
    }

    /// The compiled-in model whose source file has this content hash.
    pub fn from_hash(hash: &str) -> Option<Bundled> {
        Bundled::ALL.into_iter().find(|b| b.hash() == hash)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashes_match_the_bundled_files() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models");
        for b in Bundled::ALL {
            let model = mbs_symbolic::model::load(&root.join(format!("{}.toml", b.name())))
                .unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(Bundled::from_hash(&model.source.hash), Some(b));
        }
        assert_eq!(Bundled::from_hash("0000000000000000"), None);
    }
}
