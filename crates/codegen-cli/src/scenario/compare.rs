//! `[output] compare`: the comparison runs of a scenario, each run next to the scenario as
//! described with its own time history, summary block and plotted series.

use serde::{Deserialize, Serialize};

/// A comparison run, run next to the scenario as described.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Comparison {
    /// The same damper with the generator disconnected: the mechanism and the rotor inertia
    /// (through the gear ratio) stay attached to the beam, only the electrical damping is
    /// gone (near the toggle this lowers the first frequency a lot: not the bare beam).
    GeneratorDisconnected,
    /// The beam alone, without the mechanism: the structure before any damper.
    BareBeam,
    /// The `[structure]` alone, without the mechanisms, under the same loads, read at the
    /// attachments' nodes: `bare_beam`'s counterpart where the host is not a beam.
    BareStructure,
}

impl Comparison {
    /// Every comparison, in output order.
    pub const ALL: [Comparison; 3] = [
        Comparison::GeneratorDisconnected,
        Comparison::BareBeam,
        Comparison::BareStructure,
    ];

    /// The key in the scenario, the summary and the output file names.
    pub fn key(self) -> &'static str {
        match self {
            Comparison::GeneratorDisconnected => "generator_disconnected",
            Comparison::BareBeam => "bare_beam",
            Comparison::BareStructure => "bare_structure",
        }
    }

    /// The legend of its plotted series.
    pub fn legend(self) -> &'static str {
        match self {
            Comparison::GeneratorDisconnected => {
                "generator disconnected (mechanism + rotor inertia attached)"
            }
            Comparison::BareBeam => "bare beam (no mechanism)",
            Comparison::BareStructure => "bare structure (no mechanism)",
        }
    }
}
