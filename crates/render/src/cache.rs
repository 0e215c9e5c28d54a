//! The reference-image cache.
//!
//! A reference (a render with many samples per pixel) is rendered once per scene, camera,
//! integrator and sample count, and stored as `<dir>/<integrator>-<key>.exr` (one channel `Y`),
//! where `key` is the first 16 hex digits of a SHA-256 content hash ([`reference_key`]) over:
//! a format tag, every triangle's vertex coordinates (bit patterns), the camera (eye, target,
//! up, fov, resolution), the integrator and all its parameters ([`Integrator::key`]), the
//! sample count and the seed. Any change to one of them gives a new file; stale files are
//! never read, only left behind (delete the directory to reclaim the space).

use crate::error::RenderError;
use crate::image::Channels;
use crate::integrate::Integrator;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use tb_core::Triangle;
use tb_scene::Camera;

/// Bump when the integrators change what they compute, so old references are not reused.
const FORMAT: &[u8] = b"tb-render reference v1";

/// The content hash of a reference render, 16 hex digits.
pub fn reference_key(
    tris: &[Triangle],
    camera: &Camera,
    integrator: &Integrator,
    spp: u32,
    seed: u64,
) -> String {
    let mut h = Sha256::new();
    h.update(FORMAT);
    h.update((tris.len() as u64).to_le_bytes());
    for t in tris {
        for v in [t.v0, t.v1, t.v2] {
            for c in v.to_array() {
                h.update(c.to_bits().to_le_bytes());
            }
        }
    }
    for v in [camera.eye, camera.target, camera.up] {
        for c in v.to_array() {
            h.update(c.to_bits().to_le_bytes());
        }
    }
    h.update(camera.fov.to_bits().to_le_bytes());
    h.update(camera.width.to_le_bytes());
    h.update(camera.height.to_le_bytes());
    h.update(integrator.key().as_bytes());
    h.update(spp.to_le_bytes());
    h.update(seed.to_le_bytes());
    let d = h.finalize();
    d.iter().take(8).map(|b| format!("{b:02x}")).collect()
}

/// Where the reference of `integrator` with `key` lives in `dir`.
pub fn reference_path(dir: &Path, integrator: &Integrator, key: &str) -> PathBuf {
    dir.join(format!("{}-{key}.exr", integrator.name()))
}

/// Whether the reference came from the cache or was rendered now.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Read from the cache file.
    Cached,
    /// Rendered now and written to the cache.
    Rendered,
}

/// The reference at `path` (a `width x height` image, channel `Y`) if it is there and fits,
/// else `render()` written there first. A cached file of the wrong size or without `Y` is
/// rendered again and replaced.
pub fn load_or_render(
    path: &Path,
    width: u32,
    height: u32,
    render: impl FnOnce() -> Vec<f32>,
) -> Result<(Vec<f32>, Origin), RenderError> {
    if path.is_file() {
        if let Ok(c) = Channels::read_exr(path) {
            if (c.width, c.height) == (width, height) {
                if let Some(y) = c.get("Y") {
                    return Ok((y.to_vec(), Origin::Cached));
                }
            }
        }
    }
    let img = render();
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| RenderError::file(dir, e))?;
    }
    let mut c = Channels::new(width, height);
    c.push("Y", img.clone())?;
    // Write to a temporary name, then rename, so a concurrent or interrupted run never leaves
    // a torn reference under the final name.
    let tmp = path.with_extension(format!("tmp{}.exr", std::process::id()));
    c.write_exr(&tmp)?;
    std::fs::rename(&tmp, path).map_err(|e| RenderError::file(path, e))?;
    Ok((img, Origin::Rendered))
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::Vec3;
    use tb_scene::PixelOrder;

    #[test]
    fn key_changes_with_every_input_and_cache_round_trips() {
        let tris = vec![Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y)];
        let cam = Camera {
            eye: Vec3::Z,
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov: 40.0,
            width: 4,
            height: 2,
            order: PixelOrder::Row,
        };
        let ao = Integrator::Ao { distance: 1.0 };
        let k = reference_key(&tris, &cam, &ao, 64, 1);
        assert_eq!(k.len(), 16);
        assert_eq!(k, reference_key(&tris, &cam, &ao, 64, 1));
        let moved = vec![Triangle::new(
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(0.0, 1.0, 1e-7),
        )];
        assert_ne!(k, reference_key(&moved, &cam, &ao, 64, 1));
        let wide = Camera { width: 5, ..cam };
        assert_ne!(k, reference_key(&tris, &wide, &ao, 64, 1));
        let pt = Integrator::Path {
            bounces: 2,
            albedo: 0.7,
        };
        assert_ne!(k, reference_key(&tris, &cam, &pt, 64, 1));
        assert_ne!(k, reference_key(&tris, &cam, &ao, 65, 1));
        assert_ne!(k, reference_key(&tris, &cam, &ao, 64, 2));

        let dir = tempfile::tempdir().unwrap();
        let p = reference_path(dir.path(), &ao, &k);
        let (a, o) = load_or_render(&p, 4, 2, || vec![0.5; 8]).unwrap();
        assert_eq!((a, o), (vec![0.5; 8], Origin::Rendered));
        let (b, o) = load_or_render(&p, 4, 2, || unreachable!("cached")).unwrap();
        assert_eq!((b, o), (vec![0.5; 8], Origin::Cached));
        // A different size is rendered again.
        let (_, o) = load_or_render(&p, 2, 2, || vec![0.0; 4]).unwrap();
        assert_eq!(o, Origin::Rendered);
    }
}
