//! The GPU programs of the grid traversals (`shaders/grid.wgsl` with `uniform.wgsl`,
//! `two_level.wgsl` or `irregular.wgsl`, on tb-gpu's prelude; contract in `tb_core::gpu`):
//! `uniform-grid/dda`, `two-level-grid/dda` and `irregular-grid/walk`. Construction stays on
//! the CPU (the paper builds on the GPU, §4; here the built arrays are uploaded unchanged); the
//! kernels repeat the CPU walks step for step, with positions and plane distances in `f64` as
//! the CPU computes them ([`crate::common`]), so hits and per-ray counters equal the CPU's ray
//! for ray. That needs `SHADER_F64`: the programs set [`GpuProgram::needs_f64`], and tb-gpu
//! refuses them on adapters without it (one line, the row's note).
//!
//! Buffers (bindings 5 to 8): the lattice as 16 `f64` words (min, size, 1/size, resolution,
//! delta, mag) and one word more (uniform: 1 with macro regions; irregular: the deepest octree
//! level), then each grid's arrays exactly as built.

use crate::common::Lattice;
use crate::{IrregularGrid, TwoLevelGrid, UniformGrid};
use std::borrow::Cow;
use tb_core::{GpuBuffer, GpuProgram};

/// Little-endian bytes of `w` (the GPU's words).
fn words(w: impl IntoIterator<Item = u32>) -> Cow<'static, [u8]> {
    Cow::Owned(w.into_iter().flat_map(u32::to_le_bytes).collect())
}

/// The header buffer: `lat` as 16 `f64` words, then `extra`.
fn header(what: &'static str, lat: &Lattice, extra: f64) -> GpuBuffer<'static> {
    let w: Vec<f64> = lat
        .min
        .iter()
        .chain(&lat.size)
        .chain(&lat.inv_size)
        .copied()
        .chain(lat.res.map(f64::from))
        .chain(lat.delta)
        .chain([lat.mag, extra])
        .collect();
    GpuBuffer {
        what,
        bytes: Cow::Owned(w.into_iter().flat_map(f64::to_le_bytes).collect()),
    }
}

fn program<'a>(
    name: &'static str,
    source: &'static str,
    triangles: &'a [tb_core::Triangle],
    buffers: Vec<GpuBuffer<'a>>,
) -> GpuProgram<'a> {
    buffers
        .into_iter()
        .fold(
            GpuProgram::new(name, source, Cow::Borrowed(triangles)),
            |p, b| p.buffer(b.what, b.bytes),
        )
        .in_f64()
}

impl UniformGrid {
    /// `uniform-grid/dda`: the lattice (and whether macro regions are built), the cell
    /// ranges, the references, the macro regions (6 words per cell, or one unused word).
    pub(crate) fn gpu_dda(&self) -> GpuProgram<'_> {
        let (lat, macros) = (&self.lat, &self.macros);
        let macro_words = if macros.is_empty() {
            words([0])
        } else {
            words(macros.iter().flatten().copied())
        };
        program(
            "uniform-grid/dda",
            concat!(
                include_str!("../shaders/grid.wgsl"),
                include_str!("../shaders/uniform.wgsl")
            ),
            &self.tris,
            vec![
                header(
                    "the uniform grid's lattice",
                    lat,
                    (!macros.is_empty()) as u8 as f64,
                ),
                GpuBuffer {
                    what: "the uniform grid's cell ranges",
                    bytes: words(self.start.iter().copied()),
                },
                GpuBuffer {
                    what: "the uniform grid's references",
                    bytes: words(self.refs.iter().copied()),
                },
                GpuBuffer {
                    what: "the uniform grid's macro regions",
                    bytes: macro_words,
                },
            ],
        )
    }
}

impl TwoLevelGrid {
    /// `two-level-grid/dda`: the top lattice, the top cells (first leaf, resolution), the
    /// leaf ranges, the references.
    pub(crate) fn gpu_dda(&self) -> GpuProgram<'_> {
        program(
            "two-level-grid/dda",
            concat!(
                include_str!("../shaders/grid.wgsl"),
                include_str!("../shaders/two_level.wgsl")
            ),
            &self.tris,
            vec![
                header("the two-level grid's top lattice", &self.top, 0.0),
                GpuBuffer {
                    what: "the two-level grid's top cells",
                    bytes: words(self.tops.iter().flat_map(|t| [t.first_leaf, t.res])),
                },
                GpuBuffer {
                    what: "the two-level grid's leaf ranges",
                    bytes: words(self.start.iter().copied()),
                },
                GpuBuffer {
                    what: "the two-level grid's references",
                    bytes: words(self.refs.iter().copied()),
                },
            ],
        )
    }
}

impl IrregularGrid {
    /// `irregular-grid/walk`: the base lattice and the deepest octree level, the voxel map,
    /// the cells (lo, begin, hi, end), the references.
    pub(crate) fn gpu_walk(&self) -> GpuProgram<'_> {
        program(
            "irregular-grid/walk",
            concat!(
                include_str!("../shaders/grid.wgsl"),
                include_str!("../shaders/irregular.wgsl")
            ),
            &self.tris,
            vec![
                header(
                    "the irregular grid's base lattice",
                    &self.base,
                    self.dmax as f64,
                ),
                GpuBuffer {
                    what: "the irregular grid's voxel map",
                    bytes: words(self.map.iter().copied()),
                },
                GpuBuffer {
                    what: "the irregular grid's cells",
                    bytes: words(self.cells.iter().flat_map(|c| {
                        [
                            c.lo[0], c.lo[1], c.lo[2], c.begin, c.hi[0], c.hi[1], c.hi[2], c.end,
                        ]
                    })),
                },
                GpuBuffer {
                    what: "the irregular grid's references",
                    bytes: words(self.refs.iter().copied()),
                },
            ],
        )
    }
}
