//! Intel Embree 3.13 through the `embree3` crate: one triangle geometry, single rays.

use embree3::{
    BufferUsage, BuildQuality, Config, Device, Format, GeometryKind, IntersectContext, RayHit,
    Scene, SceneFlags,
};
use tb_core::params::ParamKind;
use tb_core::{
    build_with, AccelError, Family, HitRecord, MemoryReport, Query, Ray, Structure, Traversal,
    TraversalStats, Triangle,
};

/// Embree in the registry (feature `embree`).
pub static FAMILY: Family = Family::new::<EmbreePeer, EmbreeParams>(
    "peer: Intel Embree 3 single rays (feature `embree`)",
    |tris, set| build_with(set, |p: &EmbreeParams| EmbreePeer::build(tris, p)),
)
.with_method(1, tb_core::FIRST_METHOD);

tb_core::choice! {
    /// `RTC_BUILD_QUALITY_*`.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Quality {
        /// `RTC_BUILD_QUALITY_LOW`: Morton-code build.
        Low = "low",
        /// `RTC_BUILD_QUALITY_MEDIUM`: binned SAH.
        Medium = "medium",
        /// `RTC_BUILD_QUALITY_HIGH`: binned SAH with spatial splits (SBVH-like).
        High = "high",
    }
}

tb_core::params! {
    /// Embree build settings.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct EmbreeParams {
        /// RTC_BUILD_QUALITY (high: spatial splits)
        quality: Quality = Quality::High, ParamKind::Choice(Quality::NAMES);
        /// RTC_SCENE_FLAG_COMPACT: a more compact, somewhat slower layout
        compact: bool = false, ParamKind::Bool;
        /// RTC_SCENE_FLAG_ROBUST: robust traversal (no culling errors for edge cases)
        robust: bool = true, ParamKind::Bool;
        /// Embree build threads (0 = all; 1 compares with our single-threaded builders)
        build_threads: u32 = 1, ParamKind::Int { min: 0, max: 1024 };
        /// RTC_INTERSECT_CONTEXT_FLAG_COHERENT instead of INCOHERENT (a hint for coherent
        /// rays such as primary rays; Embree 3 documents it for ray streams)
        coherent: bool = false, ParamKind::Bool;
    }
}

/// A committed Embree scene of the triangles (one unindexed triangle geometry; `primID` is
/// the scene's triangle index).
pub struct EmbreePeer {
    // Field order: the scene must drop before the device.
    scene: Scene<'static>,
    _device: Device,
    triangles: usize,
    coherent: bool,
}

impl EmbreePeer {
    /// Build with `params`; `Err` carries Embree's error.
    pub fn build(tris: &[Triangle], params: &EmbreeParams) -> Result<Self, AccelError> {
        Self::build_embree(tris, params).map_err(|message| AccelError::Library {
            library: "embree",
            message,
        })
    }

    fn build_embree(tris: &[Triangle], params: &EmbreeParams) -> Result<Self, String> {
        let config = Config {
            threads: params.build_threads,
            ..Default::default()
        };
        let device = Device::with_config(config).map_err(|e| format!("embree device: {e:?}"))?;
        let mut scene = device
            .create_scene()
            .map_err(|e| format!("embree scene: {e:?}"))?;
        let quality = match params.quality {
            Quality::Low => BuildQuality::LOW,
            Quality::Medium => BuildQuality::MEDIUM,
            Quality::High => BuildQuality::HIGH,
        };
        scene.set_build_quality(quality);
        let mut flags = SceneFlags::NONE;
        if params.compact {
            flags |= SceneFlags::COMPACT;
        }
        if params.robust {
            flags |= SceneFlags::ROBUST;
        }
        scene.set_flags(flags);
        if !tris.is_empty() {
            let mut geom = device
                .create_geometry(GeometryKind::TRIANGLE)
                .map_err(|e| format!("embree geometry: {e:?}"))?;
            geom.set_build_quality(quality);
            {
                let mut v = geom
                    .set_new_buffer::<[f32; 3]>(
                        BufferUsage::VERTEX,
                        0,
                        Format::FLOAT3,
                        12,
                        tris.len() * 3,
                    )
                    .map_err(|e| format!("embree vertex buffer: {e:?}"))?;
                for (i, t) in tris.iter().enumerate() {
                    v[3 * i] = t.v0.to_array();
                    v[3 * i + 1] = t.v1.to_array();
                    v[3 * i + 2] = t.v2.to_array();
                }
            }
            {
                let mut ix = geom
                    .set_new_buffer::<[u32; 3]>(
                        BufferUsage::INDEX,
                        0,
                        Format::UINT3,
                        12,
                        tris.len(),
                    )
                    .map_err(|e| format!("embree index buffer: {e:?}"))?;
                for i in 0..tris.len() {
                    let b = 3 * i as u32;
                    ix[i] = [b, b + 1, b + 2];
                }
            }
            let geom = geom.commit();
            scene.attach_geometry(&geom);
        }
        scene.commit();
        Ok(EmbreePeer {
            scene,
            _device: device,
            triangles: tris.len(),
            coherent: params.coherent,
        })
    }
}

/// Embree's `RayK::valid()` (kernels/common/ray.h): every origin and direction component at
/// most `FLT_LARGE = 1.844e18` in magnitude, `tnear` and `tfar` not NaN. Debian's build
/// asserts it and aborts the process on a ray that fails (the `ray-limits` stress scene has
/// origins at 1e20), so such rays are answered as misses without calling Embree; the oracle
/// comparison then reports them.
fn embree_valid(r: &Ray) -> bool {
    const FLT_LARGE: f32 = 1.844e18;
    r.origin.abs().max_element() <= FLT_LARGE
        && r.dir.abs().max_element() <= FLT_LARGE
        && !r.tmin.is_nan()
        && !r.tmax.is_nan()
        && r.tmin >= 0.0
}

impl Structure for EmbreePeer {
    const NAME: &'static str = "embree";
    const TRAVERSALS: &'static [Traversal<Self>] = &[Traversal::cpu(
        crate::NATIVE.own_test("embree"),
        tb_core::kernel!(|e: &EmbreePeer, batch, out| {
            e.trace(batch.query, batch.rays, out.hits);
            if let Some(s) = out.stats {
                s.fill(TraversalStats::default());
            }
        }),
    )];

    /// Our vertex and index buffers only: Embree does not report its BVH's size.
    ///
    /// `structure_bytes` 0 (unknown, as `nodes`): the buffers are the scene's geometry.
    fn own_memory(&self) -> MemoryReport {
        MemoryReport {
            bytes: (self.triangles * (36 + 12)) as u64,
            structure_bytes: 0,
            nodes: 0,
            prim_refs: self.triangles as u64,
            node_bytes: 0,
        }
    }
}

impl EmbreePeer {
    fn trace(&self, query: Query, rays: &[Ray], hits: &mut [HitRecord]) {
        let mut ctx = if self.coherent {
            IntersectContext::coherent()
        } else {
            IntersectContext::incoherent()
        };
        for (r, h) in rays.iter().zip(hits.iter_mut()) {
            if !embree_valid(r) {
                *h = HitRecord::MISS;
                continue;
            }
            let er = embree3::Ray::segment(r.origin.to_array(), r.dir.to_array(), r.tmin, r.tmax);
            *h = match query {
                Query::Closest => {
                    let mut rh = RayHit::from(er);
                    self.scene.intersect(&mut ctx, &mut rh);
                    if rh.hit.is_valid() && rh.ray.tfar < r.tmax {
                        HitRecord {
                            t: rh.ray.tfar,
                            prim: rh.hit.primID,
                            u: rh.hit.u,
                            v: rh.hit.v,
                        }
                    } else {
                        HitRecord::MISS
                    }
                }
                Query::Any => {
                    let mut er = er;
                    if self.scene.occluded(&mut ctx, &mut er) {
                        HitRecord {
                            t: 0.0,
                            prim: 0,
                            u: 0.0,
                            v: 0.0,
                        }
                    } else {
                        HitRecord::MISS
                    }
                }
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::test_tris as tris;

    /// Embree's BVH size is unknown: `structure_bytes` 0, `bytes` our vertex and index
    /// buffers (three 12-byte vertices and three 4-byte indices a triangle).
    #[test]
    fn structure_bytes_are_unknown() {
        let tris = tris();
        let p = EmbreePeer::build(&tris, &EmbreeParams::default()).unwrap();
        let m = p.own_memory();
        assert_eq!(m.structure_bytes, 0);
        assert_eq!(m.bytes, 48 * tris.len() as u64);
    }
}
