//! The analyses' shared vocabulary (the layer between the scenario and the commands):
//! [`figures`], the catalogue of every figure a scenario can yield and the constraints on
//! them.

pub mod figures;
