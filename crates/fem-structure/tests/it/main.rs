//! Integration tests of fem-structure: modes against closed forms, Craig–Bampton against
//! the full model, the files and their errors.

mod beam_export;
mod chain;
mod files;
mod frame;
mod long_beam;
mod reduction;
