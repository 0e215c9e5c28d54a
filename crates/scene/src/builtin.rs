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
