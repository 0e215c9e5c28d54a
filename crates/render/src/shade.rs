//! Simple shading of primary hits: the grey level `|n·d|` of the geometric normal and the ray
//! direction (eye-light shading: surfaces facing the camera bright, grazing ones dark), misses
//! black. Enough to recognise a scene beside its heat maps; no materials are loaded.

use tb_core::{HitRecord, Ray, Triangle};

/// `|n·d|` per ray (`n` the unit geometric normal of the hit triangle, `d` the unit ray
/// direction), 0 for misses and degenerate triangles.
pub fn eye_light(tris: &[Triangle], rays: &[Ray], hits: &[HitRecord]) -> Vec<f32> {
    rays.iter()
        .zip(hits)
        .map(|(r, h)| {
            if !h.is_hit() {
                return 0.0;
            }
            let Some(t) = tris.get(h.prim as usize) else {
                return 0.0;
            };
            let n = t.normal().normalize_or_zero();
            let v = n.dot(r.dir.normalize_or_zero()).abs();
            if v.is_finite() {
                v
            } else {
                0.0
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::Vec3;

    #[test]
    fn facing_is_bright_grazing_dark_miss_black() {
        let tris = [Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)];
        let rays = [
            Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.0, 0.0, -1.0)),
            Ray::new(
                Vec3::new(0.2, 0.2, 1.0),
                Vec3::new(1.0, 0.0, -1.0).normalize(),
            ),
            Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::Z),
        ];
        let hit = HitRecord {
            t: 1.0,
            prim: 0,
            u: 0.2,
            v: 0.2,
        };
        let g = eye_light(&tris, &rays, &[hit, hit, HitRecord::MISS]);
        assert!((g[0] - 1.0).abs() < 1e-6);
        assert!((g[1] - std::f32::consts::FRAC_1_SQRT_2).abs() < 1e-6);
        assert_eq!(g[2], 0.0);
    }
}
