//! The scene: triangles with what the loader knows about them, and a built-in scene's view.

use crate::camera::Camera;
use tb_core::{Aabb, Ray, Triangle, Vec3};

/// A default view for a scene: camera, optional point light, AO distance.
#[derive(Clone, Debug, PartialEq)]
pub struct View {
    /// The camera of the default view.
    pub camera: Camera,
    /// Point light for shadow rays; `None` means the scene has no light (shadow rays skipped).
    pub light: Option<Vec3>,
    /// Maximum AO ray length.
    pub ao_distance: f32,
}

/// Triangles to trace, with what the loader knows about them.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The source string it was loaded from (`builtin:…` or the path as given).
    pub source: String,
    /// All triangles (polygons triangulated, all groups, objects and glTF nodes merged, node
    /// transforms applied). Degenerate triangles are kept.
    pub triangles: Vec<Triangle>,
    /// Bounds of all vertices.
    pub bounds: Aabb,
    /// A default view, for built-in scenes (files have none; configs give one).
    pub view: Option<View>,
    /// Stress scenes come with their own rays, built to hit the case they test (closest-hit
    /// queries, traced as ray kind `stress`).
    pub own_rays: Vec<Ray>,
    /// What the loader left out of the file, one line each naming where (e.g. faces of fewer
    /// than three vertices); the run prints them as notes.
    pub notes: Vec<String>,
}

impl Scene {
    /// A scene from triangles, computing bounds.
    pub fn from_triangles(source: impl Into<String>, triangles: Vec<Triangle>) -> Self {
        let bounds = triangles
            .iter()
            .fold(Aabb::EMPTY, |b, t| b.union(&t.bounds()));
        Scene {
            source: source.into(),
            triangles,
            bounds,
            view: None,
            own_rays: Vec::new(),
            notes: Vec::new(),
        }
    }

    /// Number of triangles with zero area, computed in f64 so that a scene scaled to 1e-30
    /// (whose f32 cross products underflow) or to 1e30 (overflow) counts as its unscaled self.
    pub fn degenerate_count(&self) -> usize {
        self.triangles
            .iter()
            .filter(|t| {
                let (a, b, c) = (t.v0.as_dvec3(), t.v1.as_dvec3(), t.v2.as_dvec3());
                (b - a).cross(c - a) == glam::DVec3::ZERO
            })
            .count()
    }

    /// The length of the bounds' diagonal, in f64 (finite for a scene at 1e30, not zero at
    /// 1e-30, where the f32 length overflows or underflows).
    pub fn diagonal(&self) -> f64 {
        if self.bounds.is_empty() {
            return 0.0;
        }
        (self.bounds.max.as_dvec3() - self.bounds.min.as_dvec3()).length()
    }

    /// Bytes of the triangle array.
    pub fn memory_bytes(&self) -> usize {
        std::mem::size_of_val(self.triangles.as_slice())
    }

    /// Insert a copy of the scene inside itself, scaled by `scale` about the centre of its
    /// bounds and moved so that this centre lands on `at` (the scene's own centre when `None`):
    /// the "scene in scene" case of Pérard-Gayot et al. 2017 (§6.2, Figure 8: "a scaled down
    /// copy of the San Miguel scene inside itself"), a teapot in a stadium made of any scene.
    /// The copy's triangles follow the original's; the view and the own rays are kept.
    /// `scale` must be in (0, 1) and `at` finite (else a message saying which).
    pub fn inset(&mut self, scale: f32, at: Option<Vec3>) -> Result<(), String> {
        if !(scale > 0.0 && scale < 1.0) {
            return Err(format!("scale must be in (0, 1), got {scale}"));
        }
        if at.is_some_and(|p| !p.is_finite()) {
            return Err("`at` must be finite".into());
        }
        let c = self.bounds.center();
        let to = at.unwrap_or(c);
        let map = |p: Vec3| to + (p - c) * scale;
        let n = self.triangles.len();
        self.triangles.reserve(n);
        for i in 0..n {
            let t = self.triangles[i];
            let copy = Triangle::new(map(t.v0), map(t.v1), map(t.v2));
            self.bounds = self.bounds.union(&copy.bounds());
            self.triangles.push(copy);
        }
        Ok(())
    }

    /// Put the scene inside a closed box (12 triangles appended): the bounds of the scene and
    /// of `points` (the camera's eye, the light), grown on every side by `margin` times their
    /// diagonal, so that no ray leaves the scene (Torres et al. 2012 §6: "a bounding box
    /// enclosing BUNNY to prevent the rays from getting away from the scene").
    pub fn enclose(&mut self, points: &[Vec3], margin: f32) {
        let mut b = self.bounds;
        for p in points {
            b.grow(*p);
        }
        let pad = Vec3::splat(margin * b.diagonal());
        let (lo, hi) = (b.min - pad, b.max + pad);
        let corner = |i: usize| {
            Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            )
        };
        // Per face: four corners in cyclic order, two triangles.
        const FACES: [[usize; 4]; 6] = [
            [0, 2, 6, 4],
            [1, 5, 7, 3],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 1, 3, 2],
            [4, 6, 7, 5],
        ];
        for f in FACES {
            let [a, b, c, d] = f.map(corner);
            self.triangles.push(Triangle::new(a, b, c));
            self.triangles.push(Triangle::new(a, c, d));
        }
        self.bounds = Aabb::new(lo, hi);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The box holds the scene and the points with the margin, is closed (its 12 triangles'
    /// area is the box's surface) and keeps the scene's triangles first.
    #[test]
    fn enclose_adds_a_closed_box_around_scene_and_points() {
        let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
        let mut s = Scene::from_triangles("t", vec![t]);
        let eye = Vec3::new(0.5, 0.5, 3.0);
        s.enclose(&[eye], 0.1);
        assert_eq!(s.triangles.len(), 13);
        assert_eq!(s.triangles[0], t);
        let pad = 0.1 * Vec3::new(1.0, 1.0, 3.0).length();
        assert!((s.bounds.min.x + pad).abs() < 1e-6 && (s.bounds.max.z - 3.0 - pad).abs() < 1e-5);
        let area: f32 = s.triangles[1..].iter().map(|t| t.area()).sum();
        assert!(
            (area - s.bounds.area()).abs() < 1e-4 * area,
            "{area} {}",
            s.bounds.area()
        );
        let fresh = Scene::from_triangles("t", s.triangles.clone());
        assert_eq!(fresh.bounds, s.bounds);
    }

    /// The inset doubles the triangles, keeps the originals first, puts the copy's centre at
    /// `at` with its extent scaled, grows the bounds when `at` is outside, and refuses bad
    /// scales and points.
    #[test]
    fn inset_adds_a_scaled_copy_at_the_point() {
        let tris = vec![
            Triangle::new(
                Vec3::ZERO,
                Vec3::new(4.0, 0.0, 0.0),
                Vec3::new(0.0, 2.0, 0.0),
            ),
            Triangle::new(Vec3::new(0.0, 0.0, 8.0), Vec3::X, Vec3::Y),
        ];
        let mut s = Scene::from_triangles("t", tris.clone());
        s.inset(0.25, Some(Vec3::new(1.0, 1.0, 1.0))).unwrap();
        assert_eq!(s.triangles.len(), 4);
        assert_eq!(&s.triangles[..2], &tris[..]);
        let copy = Scene::from_triangles("c", s.triangles[2..].to_vec());
        assert!((copy.bounds.center() - Vec3::ONE).length() < 1e-6);
        assert!((copy.bounds.extent() - Vec3::new(1.0, 0.5, 2.0)).length() < 1e-6);
        assert_eq!(s.bounds, Scene::from_triangles("t", tris.clone()).bounds);
        let mut far = Scene::from_triangles("t", tris.clone());
        far.inset(0.5, Some(Vec3::new(0.0, 10.0, 0.0))).unwrap();
        assert_eq!(far.bounds.max.y, 10.5);
        let mut centred = Scene::from_triangles("t", tris.clone());
        centred.inset(0.1, None).unwrap();
        assert!(
            (Scene::from_triangles("c", centred.triangles[2..].to_vec())
                .bounds
                .center()
                - centred.bounds.center())
            .length()
                < 1e-6
        );
        let mut bad = Scene::from_triangles("t", tris);
        for scale in [0.0, 1.0, -0.5, f32::NAN] {
            assert!(bad.inset(scale, None).unwrap_err().contains("scale"));
        }
        assert!(bad
            .inset(0.5, Some(Vec3::new(f32::INFINITY, 0.0, 0.0)))
            .is_err());
        assert_eq!(bad.triangles.len(), 2);
    }
}

#[cfg(test)]
mod scale_tests {
    use super::*;
    use tb_core::Vec3;

    /// One triangle at 1e-30 and one at 1e30: neither is zero-area and the diagonals are the
    /// unscaled one's times the scale (in f32 the 1e-30 one has zero area and both
    /// diagonals are 0 or infinite).
    #[test]
    fn figures_are_scale_free() {
        for k in [1e-30f32, 1.0, 1e30] {
            let t = Triangle::new(Vec3::ZERO, Vec3::new(k, 0.0, 0.0), Vec3::new(0.0, k, 0.0));
            let s = Scene::from_triangles("t", vec![t]);
            assert_eq!(s.degenerate_count(), 0, "{k}");
            let d = s.diagonal() / k as f64;
            assert!((d - 2f64.sqrt()).abs() < 1e-6, "{k}: {d}");
        }
    }
}
