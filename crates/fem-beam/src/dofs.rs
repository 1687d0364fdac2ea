//! Numbering of the degrees of freedom: full (eq. 42, nodal ordering) and reduced (eq. 44,
//! locked DOFs removed).
//!
//! ```text
//!   full index of (node, dof) = 2 node + (0 transverse | 1 rotation)
//!   reduced indices: the free full indices, renumbered in increasing order
//! ```
//!
//! Removing rows and columns keeps the order, so the reduced matrices keep the
//! half-bandwidth 3 of the full ones.

use crate::spec::Dof;

/// The map between full and reduced DOF indices.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DofMap {
    /// Reduced index per full index, [`LOCKED`] for locked DOFs (4 bytes per DOF: the map
    /// is read by every element-wise pass, so it is kept small).
    full_to_reduced: Vec<u32>,
    reduced_to_full: Vec<usize>,
}

/// Marker of a locked DOF in `full_to_reduced`.
const LOCKED: u32 = u32::MAX;

impl DofMap {
    /// Builds the map from per-node locks (`[transverse, rotation]`).
    pub fn new(locked: impl IntoIterator<Item = [bool; 2]>) -> Self {
        let mut full_to_reduced = Vec::new();
        let mut reduced_to_full = Vec::new();
        for l in locked {
            for is_locked in l {
                if is_locked {
                    full_to_reduced.push(LOCKED);
                } else {
                    // A beam with 2^32 DOFs would need > 100 GB for its matrices alone.
                    full_to_reduced.push(u32::try_from(reduced_to_full.len()).unwrap_or(LOCKED));
                    reduced_to_full.push(full_to_reduced.len() - 1);
                }
            }
        }
        Self {
            full_to_reduced,
            reduced_to_full,
        }
    }

    /// Number of nodes.
    pub fn node_count(&self) -> usize {
        self.full_to_reduced.len() / 2
    }

    /// Number of DOFs before elimination (2 per node).
    pub fn full_len(&self) -> usize {
        self.full_to_reduced.len()
    }

    /// Number of free DOFs (size of the reduced matrices).
    pub fn reduced_len(&self) -> usize {
        self.reduced_to_full.len()
    }

    /// Full index of a node's DOF.
    pub fn full_index(node: usize, dof: Dof) -> usize {
        2 * node + dof.offset()
    }

    /// Reduced index of a node's DOF; `None` when it is locked or the node does not exist.
    pub fn reduced(&self, node: usize, dof: Dof) -> Option<usize> {
        self.reduced_of_full(Self::full_index(node, dof))
    }

    /// Reduced index of a full index; `None` when locked or out of range.
    pub fn reduced_of_full(&self, full: usize) -> Option<usize> {
        match self.full_to_reduced.get(full) {
            Some(&r) if r != LOCKED => Some(r as usize),
            _ => None,
        }
    }

    /// The node and DOF of a reduced index; `None` when out of range.
    pub fn node_dof(&self, reduced: usize) -> Option<(usize, Dof)> {
        let f = *self.reduced_to_full.get(reduced)?;
        Some((
            f / 2,
            if f % 2 == 0 {
                Dof::Transverse
            } else {
                Dof::Rotation
            },
        ))
    }

    /// Full indices of the free DOFs, in reduced order.
    pub fn free_dofs(&self) -> &[usize] {
        &self.reduced_to_full
    }

    /// Expands a reduced vector to the full one (locked DOFs zero), into the caller's buffer.
    ///
    /// # Panics
    /// If the lengths are not [`reduced_len`](Self::reduced_len) and
    /// [`full_len`](Self::full_len).
    pub fn expand_into(&self, reduced: &[f64], full: &mut [f64]) {
        assert_eq!(
            reduced.len(),
            self.reduced_len(),
            "DofMap::expand_into: reduced vector has the wrong length"
        );
        assert_eq!(
            full.len(),
            self.full_len(),
            "DofMap::expand_into: full vector has the wrong length"
        );
        full.fill(0.0);
        for (r, &f) in self.reduced_to_full.iter().enumerate() {
            full[f] = reduced[r];
        }
    }

    /// Expands a reduced vector to a new full vector.
    pub fn expand(&self, reduced: &[f64]) -> Vec<f64> {
        let mut full = vec![0.0; self.full_len()];
        self.expand_into(reduced, &mut full);
        full
    }

    /// Restricts a full vector to the free DOFs, into the caller's buffer.
    ///
    /// # Panics
    /// If the lengths are not [`full_len`](Self::full_len) and
    /// [`reduced_len`](Self::reduced_len).
    pub fn restrict_into(&self, full: &[f64], reduced: &mut [f64]) {
        assert_eq!(
            full.len(),
            self.full_len(),
            "DofMap::restrict_into: full vector has the wrong length"
        );
        assert_eq!(
            reduced.len(),
            self.reduced_len(),
            "DofMap::restrict_into: reduced vector has the wrong length"
        );
        for (r, &f) in self.reduced_to_full.iter().enumerate() {
            reduced[r] = full[f];
        }
    }

    /// Restricts a full vector to a new reduced vector.
    pub fn restrict(&self, full: &[f64]) -> Vec<f64> {
        let mut reduced = vec![0.0; self.reduced_len()];
        self.restrict_into(full, &mut reduced);
        reduced
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamped_first_node() {
        let m = DofMap::new([[true, true], [false, false], [true, false]]);
        assert_eq!(m.full_len(), 6);
        assert_eq!(m.reduced_len(), 3);
        assert_eq!(m.reduced(0, Dof::Transverse), None);
        assert_eq!(m.reduced(1, Dof::Rotation), Some(1));
        assert_eq!(m.reduced(2, Dof::Rotation), Some(2));
        assert_eq!(m.reduced(3, Dof::Rotation), None);
        assert_eq!(m.node_dof(2), Some((2, Dof::Rotation)));
        assert_eq!(m.node_dof(3), None);
        let full = m.expand(&[1.0, 2.0, 3.0]);
        assert_eq!(full, vec![0.0, 0.0, 1.0, 2.0, 0.0, 3.0]);
        assert_eq!(m.restrict(&full), vec![1.0, 2.0, 3.0]);
    }
}
