//! A small deterministic hasher for the DAG's hash-consing index and derivative memos.
//!
//! The keys are a few machine words (a [`super::Node`] is a tag and at most two ids or one
//! constant's bits), for which std's SipHash costs most of the generation time. This is
//! the multiply–rotate scheme of rustc's FxHash: no random seed, so the same input always
//! hashes the same. Nothing iterates over these maps (they are only looked up), so the
//! generated source does not depend on the hash function at all.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// A `HashMap` with [`FxHasher`].
pub(crate) type FxHashMap<K, V> = HashMap<K, V, BuildHasherDefault<FxHasher>>;

/// FxHash: `h = (rotl(h, 5) ^ word) * K` per word.
#[derive(Clone, Copy, Default)]
pub(crate) struct FxHasher {
    hash: u64,
}

const K: u64 = 0x51_7c_c1_b7_27_22_0a_95;

impl FxHasher {
    #[inline]
    fn word(&mut self, w: u64) {
        self.hash = (self.hash.rotate_left(5) ^ w).wrapping_mul(K);
    }
}

impl Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            let mut w = [0u8; 8];
            w.copy_from_slice(c);
            self.word(u64::from_le_bytes(w));
        }
        for &b in chunks.remainder() {
            self.word(u64::from(b));
        }
    }

    #[inline]
    fn write_u8(&mut self, i: u8) {
        self.word(u64::from(i));
    }

    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.word(u64::from(i));
    }

    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.word(i);
    }

    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.word(i as u64);
    }

    #[inline]
    fn write_isize(&mut self, i: isize) {
        self.word(i as u64);
    }

    #[inline]
    fn finish(&self) -> u64 {
        self.hash
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::hash::{BuildHasher, Hash};

    fn h<T: Hash>(x: &T) -> u64 {
        BuildHasherDefault::<FxHasher>::default().hash_one(x)
    }

    #[test]
    fn deterministic_and_distinguishes_nearby_keys() {
        use crate::expr::{Id, Node};
        // Same key, same hash, in every run and every map (no random state).
        assert_eq!(h(&Node::Add(Id(3), Id(4))), h(&Node::Add(Id(3), Id(4))));
        let keys = [
            Node::Add(Id(3), Id(4)),
            Node::Add(Id(4), Id(3)),
            Node::Mul(Id(3), Id(4)),
            Node::Sub(Id(3), Id(4)),
            Node::Const(1.0f64.to_bits()),
            Node::Const(2.0f64.to_bits()),
        ];
        for (i, a) in keys.iter().enumerate() {
            for b in &keys[i + 1..] {
                assert_ne!(h(a), h(b), "{a:?} {b:?}");
            }
        }
    }
}
