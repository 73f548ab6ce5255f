//! Training checkpoints on disk, in one place: the folder layout, the
//! `state.json` every trainer writes, and the binary optimiser state.
//!
//! A run's output folder holds `checkpoint/` with
//! - [`MODEL`] (`model.ply`): the model, written by the op in its own
//!   format (triangle soup, 3DGS or bound-Gaussian PLY);
//! - [`OPTIMIZER`] (`optimizer.bin`): the optimiser and strategy state
//!   ([`GroupState`]s), encoded by [`encode`];
//! - [`STATE`] (`state.json`): `format`, `iteration`, the run's
//!   `settings` (a resume must match them) and the held-out `evals`; a
//!   `train` checkpoint also names its `model`.
//!
//! `optimizer.bin` layout: magic `SPKADAM1`, u64 step, u32 group count; per
//! group: u32 name length, the UTF-8 name, u64 length n, n × f32 m, n × f32
//! v (little-endian).

use std::path::{Path, PathBuf};

use serde_json::Value;

use crate::io::source::{read_file, werr};
use crate::io::write_output;
pub use crate::model::optim_state::GroupState;
use crate::{Error, Result};

/// The checkpoint folder inside a run's output folder.
pub const DIR: &str = "checkpoint";
/// The model file in [`DIR`].
pub const MODEL: &str = "model.ply";
/// The optimiser state in [`DIR`].
pub const OPTIMIZER: &str = "optimizer.bin";
/// The run state in [`DIR`].
pub const STATE: &str = "state.json";

/// A checkpoint read back for `--resume`.
#[derive(Clone, Debug)]
pub struct Saved {
    /// The model file (not read here: its format is the op's).
    pub model: PathBuf,
    /// `state.json`'s path, for messages.
    pub state_file: PathBuf,
    /// `state.json`.
    pub state: Value,
    /// The optimiser step.
    pub step: u64,
    /// The optimiser and strategy state.
    pub groups: Vec<GroupState>,
}

/// Reads `run_dir/checkpoint/`'s `state.json` and `optimizer.bin` (the
/// model file is left to the caller). The folder is noted as one the run
/// may replace: a resumed run advances this checkpoint, often in the same
/// output folder. Errors name the file.
pub fn read(run_dir: &Path) -> Result<Saved> {
    let ck = run_dir.join(DIR);
    crate::io::transaction::note_replaceable(&ck);
    let state_file = ck.join(STATE);
    let state = read_json(&state_file)?;
    let opt_path = ck.join(OPTIMIZER);
    let (step, groups) = decode(&opt_path.display().to_string(), &read_file(&opt_path)?)?;
    Ok(Saved {
        model: ck.join(MODEL),
        state_file,
        state,
        step,
        groups,
    })
}

/// Writes `run_dir/checkpoint/`'s `optimizer.bin` and `state.json`
/// (`state` as pretty JSON); the caller writes [`MODEL`] beside them.
pub fn write(run_dir: &Path, step: u64, groups: &[GroupState], state: &Value) -> Result<()> {
    let ck = run_dir.join(DIR);
    std::fs::create_dir_all(&ck).map_err(|e| Error::io(ck.display(), e))?;
    write_bytes(&ck.join(OPTIMIZER), &encode(step, groups))?;
    write_json(&ck.join(STATE), state)
}

/// A JSON file, decoded; errors name the file.
pub fn read_json(path: &Path) -> Result<Value> {
    let b = read_file(path)?;
    serde_json::from_slice(&b)
        .map_err(|e| Error::format(path.display(), format!("not valid JSON: {e}")))
}

/// Writes `value` as pretty JSON to `path` (through [`write_output`]).
pub fn write_json(path: &Path, value: &Value) -> Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| Error::invalid(format!("{}: {e}", path.display())))?;
    write_bytes(path, text.as_bytes())
}

/// Writes `bytes` to `path` (through [`write_output`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<()> {
    write_output(path, |w| w.write_all(bytes).map_err(werr))
}

const MAGIC: &[u8; 8] = b"SPKADAM1";

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
