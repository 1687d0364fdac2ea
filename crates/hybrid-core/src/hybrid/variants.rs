//! The comparison variants of any hybrid system, the baselines a damper is judged against:
//!
//! - [`HybridModel::generators_disconnected`]: every generator's circuit open — no current,
//!   no electrical damping; the mechanisms and the rotor inertias (through their gear
//!   ratios) stay on the beam, so near a toggle the frequency falls far below the bare
//!   beam's;
//! - [`HybridModel::bare_beam`]: the beam alone — no mechanism, no attachment, no force
//!   element; the excitations on beam points and of the supports kept.

use super::model::{ExcitationTarget, ForceKind, HybridModel};

impl HybridModel {
    /// The same system with every generator disconnected (`connected = false`: no current,
    /// no electrical damping; the rotor inertia stays attached, the inductance plays no
    /// part). Every other force element, mechanism and excitation is kept.
    pub fn generators_disconnected(&self) -> HybridModel {
        let mut m = self.clone();
        for f in &mut m.forces {
            if let ForceKind::Generator(g) = &mut f.kind {
                g.connected = false;
            }
        }
        m
    }

    /// The beam alone: the same beam, the excitations on beam points and the supports'
    /// motion, without the
    /// mechanisms, attachments, force elements and excitations on joints; `None` when the
    /// system has no beam. Its state is the beam part of this system's state.
    pub fn bare_beam(&self) -> Option<HybridModel> {
        let structure = self.structure.clone()?;
        let excitations = self
            .excitations
            .iter()
            .filter(|e| {
                matches!(
                    e.target,
                    ExcitationTarget::Beam(_) | ExcitationTarget::Base { .. }
                )
            })
            .cloned()
            .collect();
        // Valid by construction: the beam-point excitations were checked with this beam, and
        // nothing else is left to refer to.
        Some(HybridModel {
            structure: Some(structure),
            mechanisms: vec![],
            attachments: vec![],
            forces: vec![],
            excitations,
        })
    }
}
