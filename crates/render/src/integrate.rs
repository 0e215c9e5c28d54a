//! Progressive integrators for the error-against-time experiments: ambient occlusion and
//! diffuse path tracing, every ray batch traced through a [`Tracer`] (so through any structure
//! and on any device).
//!
//! Both are one-channel (grey): no materials are loaded.
//! - [`Integrator::Ao`]: per sample, a primary ray jittered uniformly in the pixel, then one
//!   cosine-distributed any-hit ray of length `distance` from the hit; the sample is 1 when it
//!   is unoccluded, else 0. Primary misses count 1 (white background). The pixel value is the
//!   ambient-occlusion visibility `(1/π)∫ V(ω) cos θ dω`, as the irregular-grid paper's AO
//!   rays (Table 4) estimate it.
//! - [`Integrator::Path`]: implicit diffuse path tracing as in the multi-kd-tree paper (no light
//!   sampling): every surface is Lambertian with albedo `albedo`, rays that miss the scene see
//!   a uniform white environment of radiance 1, and paths end after `bounces` diffuse bounces.
//!   With cosine-weighted sampling the throughput is multiplied by the albedo at each bounce
//!   (`f cos θ / p = (ρ/π) cos θ / (cos θ/π) = ρ`).
//!
//! Secondary rays start at the offset hit points of [`tb_scene::rays::hit_frame`], like the
//! benchmark's ray batches. Sample `j` of pixel `p` draws all of its numbers from its own
//! generator `ray_rng(seed, tag, j·2³² + p)`, so an image depends on the seed and the sample
//! count only, not on the pass sizes, the thread count or the structure (up to ties between
//! structures that report different hits at equal distance).

use crate::trace::Tracer;
use rand::Rng;
use rand_pcg::Pcg64;
use tb_core::{HitRecord, Query, Ray, Triangle};
use tb_scene::rays::{cosine_direction, hit_frame, ray_rng};
use tb_scene::Camera;

/// Seed tag of the integrators' sample generators.
const TAG_INTEGRATOR: u64 = 0x494e_5445_4752;

/// What a progressive render estimates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    /// Ambient-occlusion visibility within `distance` (scene units).
    Ao {
        /// Largest distance at which an occluder counts (scene units).
        distance: f32,
    },
    /// Diffuse path tracing with `bounces` bounces, grey albedo `albedo`, white environment.
    Path {
        /// Number of diffuse bounces after the primary hit.
        bounces: u32,
        /// Grey reflectance of every surface.
        albedo: f32,
    },
}

impl Integrator {
    /// Name in results: `ao` or `path`.
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::Ao { .. } => "ao",
            Integrator::Path { .. } => "path",
        }
    }

    /// Every parameter, exactly (floats as bit patterns), for content hashes.
    pub fn key(&self) -> String {
        match *self {
            Integrator::Ao { distance } => format!("ao;distance={:08x}", distance.to_bits()),
            Integrator::Path { bounces, albedo } => {
                format!("path;bounces={bounces};albedo={:08x}", albedo.to_bits())
            }
        }
    }
}

/// One path (or AO sample) in flight: its pixel, generator and throughput.
struct Sample {
    pixel: u32,
    rng: Pcg64,
    throughput: f32,
}

/// A progressive render: passes add samples to a running per-pixel sum.
pub struct Progressive<'a> {
    tris: &'a [Triangle],
    camera: Camera,
    integrator: Integrator,
    seed: u64,
    sum: Vec<f64>,
    spp: u32,
}

impl<'a> Progressive<'a> {
    /// An empty render of `tris` seen by `camera` (its pixel order is ignored: images are
    /// row-major).
    pub fn new(tris: &'a [Triangle], camera: Camera, integrator: Integrator, seed: u64) -> Self {
        Progressive {
            tris,
            camera,
            integrator,
            seed,
            sum: vec![0.0; camera.width as usize * camera.height as usize],
            spp: 0,
        }
    }

    /// Samples per pixel so far.
    pub fn spp(&self) -> u32 {
        self.spp
    }

    /// The current estimate, row-major (all zero before the first pass).
    pub fn image(&self) -> Vec<f32> {
        let n = self.spp.max(1) as f64;
        self.sum.iter().map(|&s| (s / n) as f32).collect()
    }

    /// Add `spp` samples per pixel, tracing every batch with `tracer`.
    pub fn pass(&mut self, tracer: &dyn Tracer, spp: u32) {
        let (w, h) = (self.camera.width, self.camera.height);
        let npix = w as u64 * h as u64;
        let mut samples = Vec::with_capacity((npix * spp as u64) as usize);
        let mut rays = Vec::with_capacity(samples.capacity());
        for j in self.spp..self.spp + spp {
            for p in 0..npix {
                let mut rng = ray_rng(self.seed, TAG_INTEGRATOR, ((j as u64) << 32) | p);
                let (x, y) = ((p % w as u64) as f32, (p / w as u64) as f32);
                let (jx, jy): (f32, f32) = (rng.gen(), rng.gen());
                rays.push(self.camera.ray_at(x + jx, y + jy));
                samples.push(Sample {
                    pixel: p as u32,
                    rng,
                    throughput: 1.0,
                });
            }
        }
        match self.integrator {
            Integrator::Ao { distance } => self.ao(tracer, samples, rays, distance),
            Integrator::Path { bounces, albedo } => {
                self.path(tracer, samples, rays, bounces, albedo)
            }
        }
        self.spp += spp;
    }

    fn ao(&mut self, tracer: &dyn Tracer, samples: Vec<Sample>, rays: Vec<Ray>, distance: f32) {
        let mut hits = vec![HitRecord::MISS; rays.len()];
        tracer.trace(Query::Closest, &rays, &mut hits);
        let mut ao_rays = Vec::with_capacity(rays.len());
        let mut ao_pixels = Vec::with_capacity(rays.len());
        for ((mut s, r), h) in samples.into_iter().zip(&rays).zip(&hits) {
            if !h.is_hit() {
                self.sum[s.pixel as usize] += 1.0;
                continue;
            }
            if let Some((o, n)) = hit_frame(self.tris, r, h) {
                let d = cosine_direction(n, &mut s.rng);
                ao_rays.push(Ray::segment(o, d, 0.0, distance));
                ao_pixels.push(s.pixel);
            }
        }
        let mut occ = vec![HitRecord::MISS; ao_rays.len()];
        tracer.trace(Query::Any, &ao_rays, &mut occ);
        for (p, h) in ao_pixels.iter().zip(&occ) {
            if !h.is_hit() {
                self.sum[*p as usize] += 1.0;
            }
        }
    }

    fn path(
        &mut self,
        tracer: &dyn Tracer,
        mut samples: Vec<Sample>,
        mut rays: Vec<Ray>,
        bounces: u32,
        albedo: f32,
    ) {
        for bounce in 0..=bounces {
            if rays.is_empty() {
                break;
            }
            let mut hits = vec![HitRecord::MISS; rays.len()];
            tracer.trace(Query::Closest, &rays, &mut hits);
            let mut next_samples = Vec::with_capacity(samples.len());
            let mut next_rays = Vec::with_capacity(rays.len());
            for ((mut s, r), h) in samples.into_iter().zip(&rays).zip(&hits) {
                if !h.is_hit() {
                    // The white environment, radiance 1.
                    self.sum[s.pixel as usize] += s.throughput as f64;
                    continue;
                }
                if bounce == bounces {
                    continue;
                }
                if let Some((o, n)) = hit_frame(self.tris, r, h) {
                    let d = cosine_direction(n, &mut s.rng);
                    s.throughput *= albedo;
                    next_rays.push(Ray::new(o, d));
                    next_samples.push(s);
                }
            }
            samples = next_samples;
            rays = next_rays;
        }
    }
}

/// Render `spp` samples per pixel in passes of at most about `max_rays` primary rays, e.g. a
/// reference image; returns the row-major estimate.
pub fn render(
    tris: &[Triangle],
    camera: Camera,
    integrator: Integrator,
    seed: u64,
    spp: u32,
    tracer: &dyn Tracer,
    max_rays: usize,
) -> Vec<f32> {
    let mut r = Progressive::new(tris, camera, integrator, seed);
    let npix = (camera.width as usize * camera.height as usize).max(1);
    let per_pass = (max_rays / npix).clamp(1, u32::MAX as usize) as u32;
    while r.spp() < spp {
        r.pass(tracer, per_pass.min(spp - r.spp()));
    }
    r.image()
}

#[cfg(test)]
mod tests {
    use super::*;
    use tb_core::{BruteForce, TriTestKind, Vec3};
    use tb_scene::PixelOrder;

    fn floor_scene() -> (Vec<Triangle>, Camera) {
        // A large floor quad at y = 0 seen from above: every primary ray hits it.
        let (a, b, c, d) = (
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, 10.0),
            Vec3::new(-10.0, 0.0, 10.0),
        );
        let tris = vec![Triangle::new(a, b, c), Triangle::new(a, c, d)];
        let cam = Camera {
            eye: Vec3::new(0.0, 5.0, 0.0),
            target: Vec3::ZERO,
            up: Vec3::Z,
            fov: 30.0,
            width: 8,
            height: 6,
            order: PixelOrder::Row,
        };
        (tris, cam)
    }

    #[test]
    fn open_floor_is_unoccluded_and_path_is_albedo() {
        let (tris, cam) = floor_scene();
        let bf = BruteForce::new(&tris);
        let tracer = crate::trace::AccelTracer {
            accel: &bf,
            traversal: 0,
            tri: TriTestKind::Watertight,
        };
        let ao = render(
            &tris,
            cam,
            Integrator::Ao { distance: 1.0 },
            1,
            4,
            &tracer,
            1000,
        );
        assert!(ao.iter().all(|&v| v == 1.0), "nothing above the floor");
        // One bounce off the floor into the sky: radiance = albedo exactly.
        let pt = Integrator::Path {
            bounces: 3,
            albedo: 0.5,
        };
        let img = render(&tris, cam, pt, 1, 2, &tracer, 1000);
        assert!(img.iter().all(|&v| (v - 0.5).abs() < 1e-6), "{img:?}");
    }

    #[test]
    fn pass_sizes_do_not_change_the_image() {
        let (mut tris, cam) = floor_scene();
        // A small roof so that AO varies.
        tris.push(Triangle::new(
            Vec3::new(-1.0, 0.5, -1.0),
            Vec3::new(1.0, 0.5, -1.0),
            Vec3::new(0.0, 0.5, 1.0),
        ));
        let bf = BruteForce::new(&tris);
        let tracer = |q: Query, r: &[Ray], h: &mut [HitRecord]| {
            let batch = tb_core::Batch::new(q, TriTestKind::Watertight, r);
            tb_core::Accel::trace(&bf, 0, batch, tb_core::Answers::hits(h))
        };
        let ao = Integrator::Ao { distance: 2.0 };
        let a = render(&tris, cam, ao, 7, 6, &tracer, 48);
        let b = render(&tris, cam, ao, 7, 6, &tracer, 1000);
        assert_eq!(a, b);
        let c = render(&tris, cam, ao, 8, 6, &tracer, 1000);
        assert_ne!(a, c, "another seed, other samples");
        assert!(a.iter().any(|&v| v < 1.0) && a.contains(&1.0));
        assert_eq!(Integrator::Ao { distance: 2.0 }.name(), "ao");
        assert_ne!(
            Integrator::Ao { distance: 2.0 }.key(),
            Integrator::Ao { distance: 2.5 }.key()
        );
    }
}
