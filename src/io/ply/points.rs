//! PLY ↔ [`PointCloud`]: element `vertex` with `x y z`, optional `nx ny nz`
//! (float) and `red green blue` (uchar); other vertex properties and other
//! elements are kept in `extras`.

use std::io::Write;

use super::common::{push_rgba, push_xyz, take_rgba, take_xyz};
use super::{Format, Ply, PlyReader, write_ply};
use crate::model::{Element, Extras, PointCloud};
use crate::{Error, Result};

/// Parses a point cloud (any PLY with a `vertex` element holding x y z).
pub fn parse_points(name: &str, bytes: &[u8]) -> Result<PointCloud> {
    let (mut ply, _) = PlyReader::new(name, bytes)?.read()?;
    let mut v = ply
        .take_element("vertex")
        .ok_or_else(|| Error::format(name, "no 'vertex' element"))?;
    let positions = take_xyz(name, &mut v, ["x", "y", "z"])?
        .ok_or_else(|| Error::format(name, "element 'vertex' has no x, y, z"))?;
    let normals = take_xyz(name, &mut v, ["nx", "ny", "nz"])?;
    let colors =
        take_rgba(name, &mut v)?.map(|c| c.into_iter().map(|p| [p[0], p[1], p[2]]).collect());
    Ok(PointCloud {
        positions,
        normals,
        colors,
        extras: Extras {
            item: v.properties,
            elements: ply.elements,
            comments: ply.comments,
            obj_info: ply.obj_info,
            ..Default::default()
        },
    })
}

/// The PLY structure of a point cloud.
pub fn points_to_ply(pc: &PointCloud, format: Format) -> Result<Ply> {
    let n = pc.len();
    let mut v = Element::new("vertex", n);
    push_xyz(&mut v, ["x", "y", "z"], &pc.positions);
    if let Some(nrm) = &pc.normals {
        check_len("normals", nrm.len(), n)?;
        push_xyz(&mut v, ["nx", "ny", "nz"], nrm);
    }
    if let Some(c) = &pc.colors {
        check_len("colours", c.len(), n)?;
        let rgba: Vec<[u8; 4]> = c.iter().map(|p| [p[0], p[1], p[2], 255]).collect();
        push_rgba(&mut v, &rgba);
    }
    v.properties.extend(pc.extras.item.iter().cloned());
    let mut elements = vec![v];
    elements.extend(pc.extras.elements.iter().cloned());
    Ok(Ply {
        format,
        comments: pc.extras.comments.clone(),
        obj_info: pc.extras.obj_info.clone(),
        elements,
    })
}

/// Writes a point cloud.
pub fn write_points(w: &mut dyn Write, pc: &PointCloud, format: Format) -> Result<()> {
    write_ply(w, &points_to_ply(pc, format)?, format)
}

fn check_len(what: &str, got: usize, want: usize) -> Result<()> {
    if got != want {
        return Err(Error::invalid(format!(
            "point cloud has {got} {what} for {want} points"
        )));
    }
    Ok(())
}
