//! Built-in procedural scenes, addressed as `builtin:NAME?param=value&…`.
//!
//! The procedural scenes ([`PROCEDURAL`]):
//! - `cornell`: the Cornell box (walls, area light as two triangles, short and tall block);
//! - `sphereflake`, `mount`, `tetra`: Eric Haines' Standard Procedural Databases (SPD, 1987)
//!   tessellated to triangles, in SPD's own coordinates (Z up);
//! - `soup`: random small triangles in the unit cube;
//! - `teapot`, `teapot-stadium`: the Utah teapot (Newell's 32 bicubic Bezier patches)
//!   alone, or in the middle of a huge, coarse stadium ("teapot in a stadium").
//!
//! Every scene is deterministic (fixed seeds where random), reads all its parameters through
//! [`Params`], refuses more than [`MAX_TRIANGLES`] triangles, and comes with a default
//! [`crate::View`]: a 256x256 camera (row order), a point light, and an AO distance of 4% of
//! the bounding-box diagonal. Stress scenes (`builtin:stress/NAME`) live in [`crate::stress`].

use crate::{Scene, SceneError};
use std::collections::BTreeMap;

pub(crate) mod common;
mod cornell;
mod soup;
mod spd;
mod teapot;

/// Largest triangle count a procedural scene may generate; larger parameters are an error
/// (about 1.8 GB of triangles, before any acceleration structure).
pub const MAX_TRIANGLES: u64 = 50_000_000;

/// One built-in scene as listed by `trace-bench scenes`.
#[derive(Clone, Copy, Debug)]
pub struct BuiltinInfo {
    /// Name after `builtin:` (e.g. `sphereflake`, `stress/axis-planes`).
    pub name: &'static str,
    /// One line: what it is and where it comes from.
    pub doc: &'static str,
    /// Parameters as `name=default: meaning`, one per entry.
    pub params: &'static [&'static str],
}

/// The `?k=v&k=v` part of a builtin source, with typed getters. Every key must be consumed:
/// [`Params::finish`] reports the first unknown one.
#[derive(Clone, Debug)]
pub struct Params {
    spec: String,
    values: BTreeMap<String, String>,
    used: std::cell::RefCell<Vec<String>>,
}

impl Params {
    /// Split `NAME?k=v&k=v` into the name and its parameters.
    pub fn parse(spec: &str) -> Result<(String, Params), SceneError> {
        let (name, query) = match spec.split_once('?') {
            Some((n, q)) => (n, q),
            None => (spec, ""),
        };
        let mut values = BTreeMap::new();
        for kv in query.split('&').filter(|s| !s.is_empty()) {
            let Some((k, v)) = kv.split_once('=') else {
                return Err(SceneError::Builtin {
                    spec: spec.into(),
                    message: format!("parameter `{kv}` is not of the form key=value"),
                });
            };
            values.insert(k.trim().to_string(), v.trim().to_string());
        }
        Ok((
            name.to_string(),
            Params {
                spec: spec.into(),
                values,
                used: Default::default(),
            },
        ))
    }

    fn err(&self, message: String) -> SceneError {
        SceneError::Builtin {
            spec: self.spec.clone(),
            message,
        }
    }

    fn get<T: std::str::FromStr>(&self, key: &str, default: T) -> Result<T, SceneError> {
        self.used.borrow_mut().push(key.to_string());
        match self.values.get(key) {
            None => Ok(default),
            Some(v) => v.parse().map_err(|_| {
                self.err(format!(
                    "parameter `{key}`: cannot parse `{v}` as {}",
                    std::any::type_name::<T>()
                ))
            }),
        }
    }

    pub fn f32(&self, key: &str, default: f32) -> Result<f32, SceneError> {
        let v = self.get(key, default)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(format!("parameter `{key}` must be finite")))
        }
    }

    pub fn u32(&self, key: &str, default: u32) -> Result<u32, SceneError> {
        self.get(key, default)
    }

    pub fn u64(&self, key: &str, default: u64) -> Result<u64, SceneError> {
        self.get(key, default)
    }

    /// Error on a key no getter asked for (call after reading all parameters).
    pub fn finish(&self) -> Result<(), SceneError> {
        let used = self.used.borrow();
        match self.values.keys().find(|k| !used.contains(k)) {
            Some(k) => Err(self.err(format!("unknown parameter `{k}`"))),
            None => Ok(()),
        }
    }

    /// A range check with a clear message.
    pub fn check(&self, ok: bool, message: &str) -> Result<(), SceneError> {
        if ok {
            Ok(())
        } else {
            Err(self.err(message.to_string()))
        }
    }
}

/// All built-in scenes, procedural then stress.
pub fn list() -> Vec<BuiltinInfo> {
    let mut v: Vec<BuiltinInfo> = PROCEDURAL.to_vec();
    v.extend_from_slice(crate::stress::LIST);
    v
}

/// The procedural scenes, with their parameters (`name=default: meaning`).
pub const PROCEDURAL: &[BuiltinInfo] = &[
    BuiltinInfo {
        name: "cornell",
        doc: "Cornell box (classic 0..555 dimensions): 5 walls, ceiling area light (2 triangles), \
              short and tall rotated blocks; 32 triangles; point light just below the area light",
        params: &["scale=1: multiply all coordinates (e.g. 0.0018 for a unit box)"],
    },
    BuiltinInfo {
        name: "sphereflake",
        doc: "SPD 'balls' (Haines 1987): sphere with 9 children of 1/3 radius, recursively, on a \
              square floor; triangles = 20*4^tess * (9^(size+1)-1)/8 + 2 (defaults: 65,602)",
        params: &[
            "size=3: recursion depth; (9^(size+1)-1)/8 spheres (SPD's size factor), 0..=10",
            "tess=1: icosphere subdivisions per sphere, 20*4^tess triangles each, 0..=12",
        ],
    },
    BuiltinInfo {
        name: "mount",
        doc: "SPD 'mount' (Haines 1987) terrain: fractal mountain by midpoint displacement \
              (diamond-square, fractal dimension 2.2) over a 2^size grid; 2*4^size triangles \
              (default 8,192); SPD's glass spheres omitted",
        params: &[
            "size=6: subdivision levels, 2*4^size triangles, 0..=12",
            "seed=1: random seed of the displacements",
        ],
    },
    BuiltinInfo {
        name: "tetra",
        doc: "SPD 'tetra' (Haines 1987): recursive (Sierpinski) tetrahedron, 4^size tetrahedra \
              of 4 triangles, 4^(size+1) triangles (default 4,096; SPD size factor = size+1)",
        params: &["size=5: recursion depth, 4^(size+1) triangles, 0..=11"],
    },
    BuiltinInfo {
        name: "soup",
        doc: "random triangle soup in the unit cube: each triangle's vertices uniform in a cube \
              of edge `size` around a uniform random centre (default 10,000 triangles)",
        params: &[
            "count=10000: number of triangles, 1..=50000000",
            "size=0.05: edge of the cube each triangle lies in, (0, 1]",
            "seed=1: random seed",
        ],
    },
    BuiltinInfo {
        name: "teapot",
        doc: "Utah teapot (Newell's 32 bicubic Bezier patches, with bottom), K x K grid per \
              patch; 64*K^2 - 8*K triangles (pole triangles dropped; default 16,256), Y up",
        params: &["tess=16: grid resolution per patch edge, 1..=880"],
    },
    BuiltinInfo {
        name: "teapot-stadium",
        doc: "teapot in a stadium: the dense teapot on a ground square of 2 triangles inside a \
              ring of coarse stands (4 triangles per segment) of radius `stadium` teapot sizes; \
              camera close to the teapot (default 16,386 triangles)",
        params: &[
            "teapot_tess=16: teapot grid resolution per patch edge (64*K^2 - 8*K triangles)",
            "stadium=1000: stadium inner radius in teapot sizes (largest teapot extent), (0, 1e6]",
            "segments=32: segments of the stand ring, 3..=1000000",
        ],
    },
];

/// Load `NAME?params` (the part after `builtin:`).
pub fn load(spec: &str) -> Result<Scene, SceneError> {
    let (name, params) = Params::parse(spec)?;
    let mut scene = if let Some(stress) = name.strip_prefix("stress/") {
        crate::stress::load(stress, &params)?
    } else {
        load_procedural(&name, &params)?
    };
    params.finish()?;
    scene.source = format!("builtin:{spec}");
    Ok(scene)
}

fn load_procedural(name: &str, params: &Params) -> Result<Scene, SceneError> {
    match name {
        "cornell" => cornell::cornell(params),
        "sphereflake" => spd::sphereflake(params),
        "mount" => spd::mount(params),
        "tetra" => spd::tetra(params),
        "soup" => soup::soup(params),
        "teapot" => teapot::teapot(params),
        "teapot-stadium" => teapot::teapot_stadium(params),
        _ => Err(SceneError::Builtin {
            spec: name.into(),
            message: format!(
                "unknown built-in scene `{name}` (run `trace-bench scenes` for the list)"
            ),
        }),
    }
}
