//! The finiteness scan shared by the readers (`io`) and the training loops
//! (`train`), which may not import each other.

/// Index of the first value of `values` that is NaN or ±infinity, `None`
/// when all are finite. Scans blocks of 1024 without branching (the exponent
/// test vectorises, a few GB/s) and looks for the index only in a block
/// that holds one, so checking a whole model before optimising it is cheap.
pub fn first_non_finite(values: &[f32]) -> Option<usize> {
    const EXP: u32 = 0x7f80_0000;
    values.chunks(1024).enumerate().find_map(|(c, chunk)| {
        let bad = chunk
            .iter()
            .fold(false, |acc, v| acc | (v.to_bits() & EXP == EXP));
        if !bad {
            return None;
        }
        chunk
            .iter()
            .position(|v| !v.is_finite())
            .map(|i| c * 1024 + i)
    })
}
