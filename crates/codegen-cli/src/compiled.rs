//! The bundled mechanisms compiled into this binary by `build.rs` (from
//! `models/double_bar.toml`, `models/four_bar.toml` and `models/slider_crank.toml`), for
//! `damper eval --backend generated`.
//!
//! A model file given on the command line is matched against them by its FNV-1a content
//! hash ([`mbs_symbolic::model::SourceInfo::hash`]): only a byte-identical copy of a bundled
//! model uses the compiled code, so an edited model can never be evaluated with stale
//! equations.
//!
//! The generated modules define more than the binary uses (size constants, name lists),
//! hence their `allow(dead_code)`.

/// `models/double_bar.toml`, generated at build time.
#[allow(dead_code)]
pub mod double_bar {
    include!(concat!(env!("OUT_DIR"), "/double_bar.rs"));
}
/// `models/four_bar.toml`, generated at build time.
#[allow(dead_code)]
pub mod four_bar {
    include!(concat!(env!("OUT_DIR"), "/four_bar.rs"));
}
/// `models/slider_crank.toml`, generated at build time.
#[allow(dead_code)]
pub mod slider_crank {
    include!(concat!(env!("OUT_DIR"), "/slider_crank.rs"));
}

/// Content hashes recorded by the build script.
mod hashes {
    include!(concat!(env!("OUT_DIR"), "/compiled_hashes.rs"));
}

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
            Bundled::DoubleBar => hashes::DOUBLE_BAR_HASH,
            Bundled::FourBar => hashes::FOUR_BAR_HASH,
            Bundled::SliderCrank => hashes::SLIDER_CRANK_HASH,
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
