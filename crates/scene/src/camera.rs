//! The pinhole camera of the configs.

use serde::{Deserialize, Serialize};
use tb_core::geom::unit;
use tb_core::{Ray, Vec3};

/// Order in which primary rays are generated (and stored).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PixelOrder {
    /// Scanline order, row 0 at the top.
    #[default]
    Row,
    /// Morton (Z-order) over the pixel grid, for coherent batches.
    Morton,
}

/// Pinhole camera: eye, target, up, vertical field of view in degrees, resolution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// Position of the pinhole.
    pub eye: Vec3,
    /// Point the camera looks at (the image centre).
    pub target: Vec3,
    /// Up direction of the image (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub fov: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Order in which [`Camera::pixels`] visits the pixels (and primary rays come).
    #[serde(default)]
    pub order: PixelOrder,
}

impl Camera {
    /// Pixel coordinates in generation order (x, y), row 0 at the top.
    pub fn pixels(&self) -> Vec<(u32, u32)> {
        let (w, h) = (self.width, self.height);
        match self.order {
            PixelOrder::Row => (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).collect(),
            PixelOrder::Morton => {
                let mut p: Vec<(u32, u32)> =
                    (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).collect();
                p.sort_by_key(|&(x, y)| morton2(x, y));
                p
            }
        }
    }

    /// The primary ray through the centre of pixel `(x, y)`, direction normalised.
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        self.ray_at(x as f32 + 0.5, y as f32 + 0.5)
    }

    /// The primary ray through the continuous image point `(fx, fy)` in pixel units (`(0, 0)`
    /// the top-left corner of the image, `(x + 0.5, y + 0.5)` the centre of pixel `(x, y)`);
    /// progressive renderers jitter within the pixel with it.
    pub fn ray_at(&self, fx: f32, fy: f32) -> Ray {
        // Scale-free (`unit`): a camera at 1e30 or 1e-30 makes the same rays as one at 1.
        let forward = unit(self.target - self.eye);
        let right = unit(forward.cross(self.up));
        let up = right.cross(forward);
        let half_h = (self.fov.to_radians() * 0.5).tan();
        let half_w = half_h * self.width as f32 / self.height as f32;
        let sx = (fx / self.width as f32) * 2.0 - 1.0;
        let sy = 1.0 - (fy / self.height as f32) * 2.0;
        let dir = (forward + right * (sx * half_w) + up * (sy * half_h)).normalize();
        Ray::new(self.eye, dir)
    }

    /// Check the camera can produce rays: distinct eye and target, `up` not parallel to the
    /// view direction, positive resolution and 0 < fov < 180.
    pub fn check(&self) -> Result<(), String> {
        let f = self.target - self.eye;
        if f == Vec3::ZERO || !f.is_finite() {
            return Err("eye and target must differ and be finite".into());
        }
        // Scale-free: eye and target 1e-30 apart differ, and 1e30 apart do not overflow.
        if unit(f).cross(unit(self.up)).length_squared() < 1e-12 {
            return Err("up must not be parallel to target - eye".into());
        }
        if self.width == 0 || self.height == 0 {
            return Err("width and height must be positive".into());
        }
        if !(self.fov > 0.0 && self.fov < 180.0) {
            return Err(format!("fov must be in (0, 180) degrees, got {}", self.fov));
        }
        Ok(())
    }
}

/// Interleave the bits of x and y (x in the even bits).
pub fn morton2(x: u32, y: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = v as u64;
        v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
        v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        v = (v | (v << 1)) & 0x5555_5555_5555_5555;
        v
    }
    spread(x) | (spread(y) << 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A camera at 1e30 or 1e-30 passes the check (no false "parallel" or
    /// "must differ") and makes the directions of the same camera at 1, and where the squares
    /// are in range its directions are `normalize()`'s bit for bit.
    #[test]
    fn scale_free_at_extremes() {
        let at = |s: f32| Camera {
            eye: Vec3::new(0.3, 0.3, 2.0) * s,
            target: Vec3::new(0.3, 0.3, 0.0) * s,
            up: Vec3::Y,
            fov: 45.0,
            width: 8,
            height: 8,
            order: PixelOrder::Row,
        };
        let one = at(1.0);
        for s in [1e-30f32, 1e30] {
            let c = at(s);
            c.check().unwrap_or_else(|e| panic!("scale {s}: {e}"));
            for (x, y) in [(0, 0), (3, 5), (7, 7)] {
                let (a, b) = (c.ray(x, y).dir, one.ray(x, y).dir);
                assert!((a - b).length() < 1e-6, "scale {s}: {a} vs {b}");
            }
        }
        let f = one.target - one.eye;
        assert_eq!(
            unit(f).to_array().map(f32::to_bits),
            f.normalize().to_array().map(f32::to_bits)
        );
        assert!(at(1.0).check().is_ok());
        let mut same = at(1e-30);
        same.target = same.eye;
        assert!(same.check().is_err());
    }

    #[test]
    fn centre_ray_looks_at_target() {
        let c = Camera {
            eye: Vec3::ZERO,
            target: Vec3::new(0.0, 0.0, -5.0),
            up: Vec3::Y,
            fov: 60.0,
            width: 3,
            height: 3,
            order: PixelOrder::Row,
        };
        let r = c.ray(1, 1);
        assert!((r.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Top-left pixel looks up and left.
        let r = c.ray(0, 0);
        assert!(r.dir.x < 0.0 && r.dir.y > 0.0);
        assert_eq!(c.pixels().len(), 9);
        let m = Camera {
            order: PixelOrder::Morton,
            ..c
        };
        let mut a = m.pixels();
        a.sort();
        let mut b = c.pixels();
        b.sort();
        assert_eq!(a, b);
    }
}
