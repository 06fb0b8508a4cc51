//! 64-bit FNV-1a, the hash behind argument fingerprints (`ffi::agree`) and
//! checkpoint digests (`io::checkpoint`). Each byte step (xor, then multiply
//! by an odd constant) is a bijection of the state, so two inputs of the
//! same length that differ in any one byte always hash differently: a
//! single flipped bit is always detected.

/// The FNV-1a offset basis (the starting state).
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// 64-bit FNV-1a of `bytes`, continued from the state `h` (start with
/// [`FNV_OFFSET`]).
pub fn fnv1a(mut h: u64, bytes: &[u8]) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_single_bit_flip_changes_the_hash() {
        let data: Vec<u8> = (0..64u8).collect();
        let h0 = fnv1a(FNV_OFFSET, &data);
        for byte in 0..data.len() {
            for bit in 0..8 {
                let mut d = data.clone();
                d[byte] ^= 1 << bit;
                assert_ne!(fnv1a(FNV_OFFSET, &d), h0, "byte {byte} bit {bit}");
            }
        }
        // The published test vector of FNV-1a 64 for "a".
        assert_eq!(fnv1a(FNV_OFFSET, b"a"), 0xaf63_dc4c_8601_ec8c);
    }
}
