//! A scene of any kind, as [`crate::io::any::load`] returns it: the one
//! type every command receives its input as, so that each command states
//! which kinds it accepts and refuses the others the same way.

use super::{Gaussians, Mesh, PointCloud, Surfels, TriangleSoup};

/// The kinds of scene a file can hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SceneKind {
    /// 3D Gaussian splats (a 3DGS PLY).
    Gaussians,
    /// 2DGS surfels (a 2DGS PLY: two scales per splat).
    Surfels,
    /// Triangle splats (a Triangle Splatting checkpoint or soup PLY).
    TriangleSoup,
    /// A triangle mesh (PLY with faces, OBJ, OFF, glTF/GLB).
    Mesh,
    /// Points, optionally oriented and coloured (PLY without faces).
    PointCloud,
}

impl SceneKind {
    /// Lower-case name, as `info` prints it (`gaussians`, `surfels`,
    /// `triangle-soup`, `mesh`, `point-cloud`).
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Gaussians => "gaussians",
            SceneKind::Surfels => "surfels",
            SceneKind::TriangleSoup => "triangle-soup",
            SceneKind::Mesh => "mesh",
            SceneKind::PointCloud => "point-cloud",
        }
    }

    /// The kind in a sentence: "Gaussians", "a triangle-splat soup", …
    pub fn phrase(self) -> &'static str {
        match self {
            SceneKind::Gaussians => "Gaussian splats",
            SceneKind::Surfels => "2DGS surfels",
            SceneKind::TriangleSoup => "a triangle-splat soup",
            SceneKind::Mesh => "a mesh",
            SceneKind::PointCloud => "a point cloud",
        }
    }

    /// "a mesh or a point cloud" for a list of kinds.
    pub fn list(kinds: &[SceneKind]) -> String {
        let words: Vec<&str> = kinds.iter().map(|k| k.phrase()).collect();
        match words.as_slice() {
            [] => "nothing".into(),
            [one] => one.to_string(),
            [init @ .., last] => format!("{} or {last}", init.join(", ")),
        }
    }
}

/// A loaded scene of one of the [`SceneKind`]s.
#[derive(Clone, Debug, PartialEq)]
pub enum Scene {
    Gaussians(Gaussians),
    Surfels(Surfels),
    TriangleSoup(TriangleSoup),
    Mesh(Mesh),
    PointCloud(PointCloud),
}

impl Scene {
    /// What this scene is.
    pub fn kind(&self) -> SceneKind {
        match self {
            Scene::Gaussians(_) => SceneKind::Gaussians,
            Scene::Surfels(_) => SceneKind::Surfels,
            Scene::TriangleSoup(_) => SceneKind::TriangleSoup,
            Scene::Mesh(_) => SceneKind::Mesh,
            Scene::PointCloud(_) => SceneKind::PointCloud,
        }
    }

    /// The points of a point cloud, or the vertices of a mesh (with their
    /// normals and colours, alpha dropped) as a point cloud; `None` for splats.
    pub fn into_points(self) -> Option<PointCloud> {
        match self {
            Scene::PointCloud(p) => Some(p),
            Scene::Mesh(m) => Some(PointCloud {
                colors: m
                    .vertex_colors
                    .map(|c| c.into_iter().map(|[r, g, b, _]| [r, g, b]).collect()),
                positions: m.vertices,
                normals: m.normals,
                extras: Default::default(),
            }),
            Scene::Gaussians(_) | Scene::Surfels(_) | Scene::TriangleSoup(_) => None,
        }
    }
}

impl From<Gaussians> for Scene {
    fn from(g: Gaussians) -> Self {
        Scene::Gaussians(g)
    }
}
impl From<Surfels> for Scene {
    fn from(s: Surfels) -> Self {
        Scene::Surfels(s)
    }
}
impl From<TriangleSoup> for Scene {
    fn from(s: TriangleSoup) -> Self {
        Scene::TriangleSoup(s)
    }
}
impl From<Mesh> for Scene {
    fn from(m: Mesh) -> Self {
        Scene::Mesh(m)
    }
}
impl From<PointCloud> for Scene {
    fn from(p: PointCloud) -> Self {
        Scene::PointCloud(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kind_lists_read_as_a_sentence() {
        use SceneKind::*;
        assert_eq!(SceneKind::list(&[Mesh]), "a mesh");
        assert_eq!(
            SceneKind::list(&[Mesh, PointCloud]),
            "a mesh or a point cloud"
        );
        assert_eq!(
            SceneKind::list(&[Gaussians, TriangleSoup, Mesh]),
            "Gaussian splats, a triangle-splat soup or a mesh"
        );
        assert_eq!(
            SceneKind::list(&[Gaussians, Surfels]),
            "Gaussian splats or 2DGS surfels"
        );
    }

    #[test]
    fn mesh_vertices_become_points_with_normals_and_colours() {
        let mut m = Mesh::new(
            vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            vec![[0, 1, 2]],
        );
        m.normals = Some(vec![[0.0, 0.0, 1.0]; 3]);
        m.vertex_colors = Some(vec![[1, 2, 3, 4]; 3]);
        let p = Scene::Mesh(m.clone()).into_points().unwrap();
        assert_eq!(p.positions, m.vertices);
        assert_eq!(p.normals, m.normals);
        assert_eq!(p.colors, Some(vec![[1, 2, 3]; 3]));
        assert!(
            Scene::Gaussians(Gaussians::default())
                .into_points()
                .is_none()
        );
    }
}
