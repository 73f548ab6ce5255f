//! Optimiser and strategy state as plain values: what a trainer hands to a
//! checkpoint and takes back on `--resume` (the file format is
//! [`crate::io::checkpoint`]).

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
) -> crate::Result<Vec<f32>> {
    let g = groups.iter().find(|g| g.name == name).ok_or_else(|| {
        crate::Error::invalid(format!(
            "the checkpoint has no {name} (not a {model} training?)"
        ))
    })?;
    if g.m.len() != len {
        return Err(crate::Error::invalid(format!(
            "{name} holds {} values, expected {len}",
            g.m.len()
        )));
    }
    Ok(g.m.clone())
}
