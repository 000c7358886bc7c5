//! Random edits of valid inputs, for the parsers' property tests: a valid file, a few bits flipped, bytes
//! overwritten, inserted or deleted, or the file cut short — the damage real files suffer in transfer and storage.

use proptest::prelude::*;

/// One edit: `(kind, where, byte)`; kind 0 flips a bit, 1 overwrites, 2 inserts, 3 deletes, 4 truncates.
pub type Edit = (u8, prop::sample::Index, u8);

/// One to seven edits.
pub fn edits() -> impl Strategy<Value = Vec<Edit>> {
    prop::collection::vec((0u8..5, any::<prop::sample::Index>(), any::<u8>()), 1..8)
}

/// `bytes` after `edits`, in order.
pub fn mutate(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for (kind, at, byte) in edits {
        let i = at.index(bytes.len() + 1);
        match kind {
            0 if i < bytes.len() => bytes[i] ^= 1 << (byte % 8),
            1 if i < bytes.len() => bytes[i] = *byte,
            2 => bytes.insert(i, *byte),
            3 if i < bytes.len() => drop(bytes.remove(i)),
            4 => bytes.truncate(i),
            _ => {}
        }
    }
    bytes
}
