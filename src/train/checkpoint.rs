//! Optimiser state as bytes, for checkpoint folders (the op writes them
//! through `io`): a small header, then per parameter group its name, length,
//! first and second moments (f32 little-endian).
//!
//! Layout: magic `SPKADAM1`, u64 step, u32 group count; per group: u32 name
//! length, the UTF-8 name, u64 length n, n × f32 m, n × f32 v.

use crate::{Error, Result};

const MAGIC: &[u8; 8] = b"SPKADAM1";

/// One group's saved moments.
#[derive(Clone, Debug, PartialEq)]
pub struct GroupState {
    pub name: String,
    pub m: Vec<f32>,
    pub v: Vec<f32>,
}

impl GroupState {
    /// A non-optimiser array (densification statistics) stored as a group:
    /// the values in `m`, zeros in `v`.
    pub fn values(name: &str, m: Vec<f32>) -> GroupState {
        GroupState {
            name: name.into(),
            v: vec![0.0; m.len()],
            m,
        }
    }
}

/// The values of the [`GroupState::values`] group `name` among `groups`,
/// which must hold `len` of them; `model` names the run kind in the error.
pub fn find_values(
    groups: &[GroupState],
    name: &str,
    len: usize,
    model: &str,
) -> Result<Vec<f32>, String> {
    let g = groups
        .iter()
        .find(|g| g.name == name)
        .ok_or_else(|| format!("the checkpoint has no {name} (not a {model} training?)"))?;
    if g.m.len() != len {
        return Err(format!("{name} holds {} values, expected {len}", g.m.len()));
    }
    Ok(g.m.clone())
}

/// Encodes the step and the groups.
pub fn encode(step: u64, groups: &[GroupState]) -> Vec<u8> {
    let total: usize = groups
        .iter()
        .map(|g| 8 * g.m.len() + g.name.len() + 12)
        .sum();
    let mut out = Vec::with_capacity(20 + total);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&step.to_le_bytes());
    out.extend_from_slice(&(groups.len() as u32).to_le_bytes());
    for g in groups {
        out.extend_from_slice(&(g.name.len() as u32).to_le_bytes());
        out.extend_from_slice(g.name.as_bytes());
        out.extend_from_slice(&(g.m.len() as u64).to_le_bytes());
        for x in g.m.iter().chain(&g.v) {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    out
}

/// Decodes [`encode`]'s bytes; `name` is the file for errors. Lengths are
/// checked against the bytes left before anything is allocated; a moment
/// that is NaN or infinite, or a negative second moment, is refused with its
/// byte offset, group and element.
pub fn decode(name: &str, b: &[u8]) -> Result<(u64, Vec<GroupState>)> {
    let bad = |at: usize, what: &str| Error::format(name, format!("byte {at}: {what}"));
    if b.len() < 20 || &b[..8] != MAGIC {
        return Err(bad(0, "not a splatkit optimiser state (magic SPKADAM1)"));
    }
    let u64_at = |o: usize| u64::from_le_bytes(b[o..o + 8].try_into().expect("8 bytes"));
    let u32_at = |o: usize| u32::from_le_bytes(b[o..o + 4].try_into().expect("4 bytes"));
    let step = u64_at(8);
    let count = u32_at(16) as usize;
    let mut o = 20;
    let mut groups = Vec::new();
    for gi in 0..count {
        if o + 4 > b.len() {
            return Err(bad(o, &format!("group {gi} is cut short")));
        }
        let nl = u32_at(o) as usize;
        o += 4;
        if nl > 256 || o + nl + 8 > b.len() {
            return Err(bad(o, &format!("group {gi}: bad name length {nl}")));
        }
        let gname = std::str::from_utf8(&b[o..o + nl])
            .map_err(|_| bad(o, "group name is not UTF-8"))?
            .to_string();
        o += nl;
        let n = u64_at(o) as usize;
        o += 8;
        if n > (b.len() - o) / 8 {
            return Err(bad(
                o,
                &format!("group {gname} declares {n} values, more than the file holds"),
            ));
        }
        let read = |from: usize| -> Vec<f32> {
            b[from..from + 4 * n]
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes")))
                .collect()
        };
        let (m, v) = (read(o), read(o + 4 * n));
        // a NaN or infinite moment turns its parameter into NaN at the first
        // step, and so does a negative second moment (Adam takes √v)
        for (what, vals, at) in [
            ("m (first moment)", &m, o),
            ("v (second moment)", &v, o + 4 * n),
        ] {
            if let Some(i) = vals.iter().position(|x| !x.is_finite()) {
                return Err(bad(
                    at + 4 * i,
                    &format!(
                        "group {gname}: element {i} of {what} is {}, not a finite number",
                        vals[i]
                    ),
                ));
            }
        }
        if let Some(i) = v.iter().position(|&x| x < 0.0) {
            return Err(bad(
                o + 4 * n + 4 * i,
                &format!(
                    "group {gname}: element {i} of v (second moment) is {}, below 0",
                    v[i]
                ),
            ));
        }
        groups.push(GroupState { name: gname, m, v });
        o += 8 * n;
    }
    if o != b.len() {
        return Err(bad(o, "trailing bytes after the last group"));
    }
    Ok((step, groups))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Round trip, and truncations are errors (never panics or huge
    /// allocations).
    #[test]
    fn round_trip_and_truncation() {
        let g = vec![
            GroupState {
                name: "a".into(),
                m: vec![1.0, -2.5],
                v: vec![0.5, 3.0],
            },
            GroupState {
                name: "vertices".into(),
                m: vec![],
                v: vec![],
            },
        ];
        let b = encode(42, &g);
        assert_eq!(decode("x", &b).unwrap(), (42, g));
        for cut in 0..b.len() {
            assert!(decode("x", &b[..cut]).is_err());
        }
    }

    /// A NaN or infinite moment, or a negative second moment, is refused
    /// with the byte, the group and the element (it would make its
    /// parameter NaN at the first step).
    #[test]
    fn non_finite_moments_are_refused() {
        let g = vec![GroupState {
            name: "sh_dc".into(),
            m: vec![0.1, 0.2, 0.3],
            v: vec![0.01, 0.02, 0.03],
        }];
        // group header: 20 + 4 + 5 + 8 bytes, then m (3 × 4), then v
        let m0 = 20 + 4 + 5 + 8;
        let cases = [
            (
                m0 + 4,
                f32::NAN,
                "byte 41: group sh_dc: element 1 of m (first moment) is NaN",
            ),
            (
                m0 + 12 + 8,
                f32::INFINITY,
                "byte 57: group sh_dc: element 2 of v (second moment) is inf",
            ),
            (
                m0 + 12,
                -1.0,
                "byte 49: group sh_dc: element 0 of v (second moment) is -1, below 0",
            ),
        ];
        for (at, x, want) in cases {
            let mut b = encode(3, &g);
            b[at..at + 4].copy_from_slice(&x.to_le_bytes());
            let e = decode("ck/optimizer.bin", &b).unwrap_err().to_string();
            assert!(e.starts_with("ck/optimizer.bin"), "{e}");
            assert!(e.contains(want), "{e}");
        }
    }
}
