//! Built-in procedural scenes, addressed as `builtin:NAME?param=value&…`.
//!
//! The procedural scenes ([`PROCEDURAL`]):
//! - `cornell`: the Cornell box (walls, area light as two triangles, short and tall block);
//! - `sphereflake`, `mount`, `tetra`: Eric Haines' Standard Procedural Databases (SPD, 1987)
//!   tessellated to triangles, in SPD's own coordinates (Z up);
//! - `soup`: random small triangles in the unit cube;
//! - `teapot`, `teapot-stadium`: the Utah teapot (Newell's 32 bicubic Bezier patches)
//!   alone, or in the middle of a huge, coarse stadium ("teapot in a stadium");
//! - `hairball`, `crown`: stand-ins for the irregular-grids paper's Hairball (2.9M triangles
//!   of long, thin, intertwined tubes) and Crown (a detailed object of 3.5M triangles)
//!   (Pérard-Gayot et al. 2017, §6);
//! - `explode`, `deform`: animated teapots (a `frame` parameter) for that paper's dynamic
//!   scenes (§6.3, Table 4);
//! - `arena`, `city`: stand-ins for the sparse-boxes paper's scenes (Havran and Bittner 2007),
//!   a tiered stadium bowl with seats and a roof, and a city of blocks seen from street level.
//!
//! Every scene is deterministic (fixed seeds where random), reads all its parameters through
//! [`Params`], refuses more than [`MAX_TRIANGLES`] triangles, and comes with a default
//! [`crate::View`]: a 256x256 camera (row order), a point light, and an AO distance of 4% of
//! the bounding-box diagonal. Stress scenes (`builtin:stress/NAME`) live in [`crate::stress`].

use crate::error::SceneError;
pub use crate::procedural::{BuiltinInfo, Params};
use crate::scene::Scene;

mod animated;
mod arena;
mod city;
mod common;
mod cornell;
mod crown;
mod hairball;
mod soup;
mod spd;
mod teapot;

/// Largest triangle count a procedural scene may generate; larger parameters are an error
/// (about 1.8 GB of triangles, before any acceleration structure).
pub const MAX_TRIANGLES: u64 = 50_000_000;

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
    BuiltinInfo {
        name: "arena",
        doc: "stand-in for the 'arena' of Havran & Bittner 2007 (a stadium, 1.4M triangles): \
              tiered elliptical bowl of stands around a pitch, a seat on every step, roof \
              trusses and panels; camera in the stands (very high depth complexity, short \
              rays); 14*rows*seats + 208*roof + 2 triangles (default 1,399,314)",
        params: &[
            "rows=60: tiers of the stands, 1..=1000",
            "seats=1650: steps (and seats) per tier around the bowl, 8..=1000000",
            "roof=64: roof trusses, 3..=10000",
        ],
    },
    BuiltinInfo {
        name: "city",
        doc: "stand-in for the 'city' of Havran & Bittner 2007 (0.8M triangles): blocks x blocks \
              blocks between streets, four buildings each (random storeys, facades split into \
              storeys x 3 bays); camera at street level down an avenue (long rays); about \
              0.8M triangles by default",
        params: &[
            "blocks=28: blocks per side, 1..=2000",
            "storeys=18: most storeys of a building (uniform in 2..=storeys), 2..=1000",
            "seed=7: seed of the building heights",
        ],
    },
    BuiltinInfo {
        name: "hairball",
        doc: "stand-in for the Hairball of Pérard-Gayot et al. 2017 (2.9M triangles): long thin \
              open tubes along random wandering curves pulled back into a unit ball, crossing \
              and overlapping everywhere; 2*sides*segments*strands triangles (default \
              2,880,000); camera outside the ball",
        params: &[
            "strands=2400: number of tubes, 1..=10000000",
            "segments=100: segments per tube (centre line 3 ball radii long), 1..=100000",
            "sides=6: sides of each tube, 3..=64",
            "radius=0.006: tube radius in ball radii, (0, 0.1]",
            "seed=1: random seed of the curves",
        ],
    },
    BuiltinInfo {
        name: "crown",
        doc: "stand-in for the Crown of Pérard-Gayot et al. 2017 (3.5M triangles): a finely \
              tessellated band with carved relief and pointed teeth, rows of gems set into it, \
              a gem on every tip; 16384*tess^2 + 512*tess + 20*4^gem_tess*(gems + points) \
              triangles (default 3,512,832)",
        params: &[
            "tess=13: band resolution, 128*tess x 32*tess quads per surface, 1..=200",
            "points=16: teeth (each with a tip gem), 3..=1000",
            "gems=128: gems set into the band (two rows), 0..=100000",
            "gem_tess=4: icosphere subdivisions per gem, 20*4^gem_tess triangles, 0..=8",
        ],
    },
    BuiltinInfo {
        name: "explode",
        doc: "animated (Pérard-Gayot et al. 2017 §6.3): the teapot exploding, every triangle \
              flying out from the centre and spinning (seeded per triangle), at frame `frame` \
              of `frames`; 64*tess^2 - 8*tess triangles (default 253,512); frame 0 is intact",
        params: &[
            "tess=63: teapot grid resolution per patch edge, 1..=880",
            "frame=0: the frame, 0..frames",
            "frames=60: frames of the animation (time = frame/frames), 1..=1000000",
            "seed=1: seed of the directions, speeds and spins",
        ],
    },
    BuiltinInfo {
        name: "deform",
        doc: "animated (Pérard-Gayot et al. 2017 §6.3): the teapot twisting and bulging with a \
              wave travelling up it (a smooth per-vertex deformation, the mesh stays closed), at \
              frame `frame` of `frames`; 64*tess^2 - 8*tess triangles (default 1,637,120)",
        params: &[
            "tess=160: teapot grid resolution per patch edge, 1..=880",
            "frame=0: the frame, 0..frames",
            "frames=60: frames of the animation (time = frame/frames), 1..=1000000",
        ],
    },
];

/// What the shard planner assumes of a stress scene (`builtin:stress/…`): they are small.
pub const STRESS_TRIANGLES_ESTIMATE: u64 = 1000;

/// A triangle count as a function of the parameters (`p(key)`).
type TriangleFormula = fn(&dyn Fn(&str) -> f64) -> f64;

/// The triangle count of procedural scene `name` as a formula of its parameters (`p(key)`:
/// the value given, else the default of [`PROCEDURAL`]'s entry), as each entry's doc states it.
fn triangle_formula(name: &str) -> Option<TriangleFormula> {
    fn teapot(k: f64) -> f64 {
        64.0 * k * k - 8.0 * k
    }
    Some(match name {
        "cornell" => |_| 32.0,
        "sphereflake" => {
            |p| 20.0 * 4f64.powf(p("tess")) * (9f64.powf(p("size") + 1.0) - 1.0) / 8.0 + 2.0
        }
        "mount" => |p| 2.0 * 4f64.powf(p("size")),
        "tetra" => |p| 4f64.powf(p("size") + 1.0),
        "soup" => |p| p("count"),
        "teapot" => |p| teapot(p("tess")),
        "teapot-stadium" => |p| teapot(p("teapot_tess")) + 4.0 * p("segments") + 2.0,
        "arena" => |p| 14.0 * p("rows") * p("seats") + 208.0 * p("roof") + 2.0,
        // About 0.8M at 28 blocks and 18 storeys; grows with blocks^2 x storeys.
        "city" => |p| 8.0e5 * (p("blocks") / 28.0).powi(2) * p("storeys") / 18.0,
        "hairball" => |p| 2.0 * p("sides") * p("segments") * p("strands"),
        "crown" => |p| {
            16384.0 * p("tess").powi(2)
                + 512.0 * p("tess")
                + 20.0 * 4f64.powf(p("gem_tess")) * (p("gems") + p("points"))
        },
        "explode" | "deform" => |p| teapot(p("tess")),
        _ => return None,
    })
}

/// The default of parameter `key` of `info`, from its listing (`key=default: …`).
fn default_of(info: &BuiltinInfo, key: &str) -> Option<f64> {
    info.params.iter().find_map(|d| {
        let (k, v) = d.split_once(':')?.0.split_once('=')?;
        (k.trim() == key).then(|| v.trim().parse().ok()).flatten()
    })
}

/// The triangles of `builtin:SPEC` (the part after `builtin:`) estimated from its parameters
/// without generating it: the formula its listing states, with the listing's defaults; a
/// stress scene is [`STRESS_TRIANGLES_ESTIMATE`]; `None` for an unknown scene. The shard
/// planner prices work units by it.
pub fn estimate_triangles(spec: &str) -> Option<u64> {
    let (name, query) = spec.split_once('?').unwrap_or((spec, ""));
    if name.starts_with("stress/") {
        return Some(STRESS_TRIANGLES_ESTIMATE);
    }
    let info = PROCEDURAL.iter().find(|b| b.name == name)?;
    let formula = triangle_formula(name)?;
    let given: Vec<(&str, f64)> = query
        .split('&')
        .filter_map(|kv| kv.split_once('='))
        .filter_map(|(k, v)| v.parse::<f64>().ok().map(|v| (k, v)))
        .collect();
    let p = |k: &str| {
        given
            .iter()
            .find(|(g, _)| *g == k)
            .map(|(_, v)| *v)
            .or_else(|| default_of(info, k))
            .unwrap_or(0.0)
    };
    Some(formula(&p).max(1.0).round() as u64)
}

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
        "arena" => arena::arena(params),
        "city" => city::city(params),
        "hairball" => hairball::hairball(params),
        "crown" => crown::crown(params),
        "explode" => animated::explode(params),
        "deform" => animated::deform(params),
        _ => Err(SceneError::Builtin {
            spec: name.into(),
            message: format!(
                "unknown built-in scene `{name}` (run `trace-bench scenes` for the list)"
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimate is the count the generator makes, for every procedural scene: at its
    /// defaults where that is cheap, and at small parameters for the large ones (so the
    /// listing's defaults, the formulas and the generators agree). The city's is an
    /// approximation (random storeys): within 15 %.
    #[test]
    fn estimates_are_the_generated_counts() {
        let cases = [
            "cornell",
            "sphereflake",
            "sphereflake?size=1&tess=2",
            "mount",
            "tetra?size=3",
            "soup?count=777",
            "teapot",
            "teapot?tess=5",
            "teapot-stadium",
            "arena?rows=3&seats=40&roof=5",
            "hairball?strands=20&segments=10&sides=5",
            "crown?tess=1&points=5&gems=6&gem_tess=1",
            "explode?tess=8",
            "deform?tess=9",
        ];
        for spec in cases {
            let scene = load(spec).unwrap();
            let est = estimate_triangles(spec).unwrap();
            assert_eq!(est, scene.triangles.len() as u64, "{spec}");
        }
        let city = load("city?blocks=6").unwrap().triangles.len() as f64;
        let est = estimate_triangles("city?blocks=6").unwrap() as f64;
        assert!((est / city - 1.0).abs() < 0.15, "city: {est} vs {city}");
        // Every procedural scene has a formula; unknown ones none.
        for b in PROCEDURAL {
            assert!(estimate_triangles(b.name).unwrap() > 1, "{}", b.name);
        }
        assert_eq!(estimate_triangles("nosuch"), None);
        assert_eq!(
            estimate_triangles("stress/flat"),
            Some(STRESS_TRIANGLES_ESTIMATE)
        );
        // The defaults the docs state: the Hairball's 2.9M, not a fallback.
        assert_eq!(estimate_triangles("hairball"), Some(2_880_000));
        assert_eq!(estimate_triangles("crown"), Some(3_512_832));
    }
}
