//! The GPU programs of the grid traversals (`shaders/grid.wgsl` with `uniform.wgsl`,
//! `two_level.wgsl` or `irregular.wgsl`, on tb-gpu's prelude; contract in `tb_core::gpu`):
//! `uniform-grid/dda`, `two-level-grid/dda`, `irregular-grid/walk` and
//! `irregular-grid/walk-hagrid` (one source with `TIES` set). Construction stays on
//! the CPU (the paper builds on the GPU, §4; here the built arrays are uploaded unchanged); the
//! kernels repeat the CPU walks step for step, with positions and plane distances in the
//! grid's [`Precision`] (the source begins with `alias real = f32;` or `f64`). In `f32` (the
//! default, the paper's) the programs run on every adapter; in `f64` they set
//! [`GpuProgram::needs_f64`] (named `…-f64`), and tb-gpu refuses them on adapters without
//! `SHADER_F64` (one line, the row's note).
//!
//! Buffers (bindings 5 to 8): the header, a uniform buffer (the same for every ray, as the
//! authors' code keeps its grid in CUDA constant memory): the lattice as 15 values in the
//! precision (min, size, 1/size, resolution, least margin, mag, far-origin factor) and one
//! more (uniform: 1 with macro regions; irregular: the deepest octree level); then each
//! grid's arrays exactly as built, in storage buffers.

use crate::lattice::Lattice;
use crate::{IrregularGrid, Precision, TwoLevelGrid, UniformGrid};
use std::borrow::Cow;
use tb_core::gpu::words;
use tb_core::{GpuBuffer, GpuProgram};

/// The header buffer: `lat` as 15 words in `precision` (as the CPU walk rounds it,
/// [`Lattice::cast`]), then `extra`.
fn header(
    what: &'static str,
    lat: &Lattice,
    precision: Precision,
    extra: f64,
) -> GpuBuffer<'static> {
    let w: Vec<f64> = lat
        .min
        .iter()
        .chain(&lat.size)
        .chain(&lat.inv_size)
        .copied()
        .chain(lat.res.map(f64::from))
        .chain([lat.delta_min(), lat.mag, lat.far_scale, extra])
        .collect();
    let bytes = match precision {
        Precision::F32 => w
            .into_iter()
            .flat_map(|x| (x as f32).to_le_bytes())
            .collect(),
        Precision::F64 => w.into_iter().flat_map(f64::to_le_bytes).collect(),
    };
    GpuBuffer {
        what,
        bytes: Cow::Owned(bytes),
        uniform: true,
    }
}

/// The program of `kind` (one source per precision: `alias real = …;` then grid.wgsl and
/// the kind's walk), `names[0]` in `f32`, `names[1]` in `f64`.
fn program<'a>(
    names: [&'static str; 2],
    sources: [&'static str; 2],
    precision: Precision,
    triangles: &'a [tb_core::Triangle],
    buffers: Vec<GpuBuffer<'a>>,
) -> GpuProgram<'a> {
    let k = (precision == Precision::F64) as usize;
    let mut p = GpuProgram::new(names[k], sources[k], Cow::Borrowed(triangles));
    // Each bound as it says (the header uniform, the arrays storage).
    p.buffers.extend(buffers);
    if precision == Precision::F64 {
        p.in_f64()
    } else {
        p
    }
}

/// The two sources of a grid kind: `alias real = f32;` or `f64;`, the module constants
/// `$consts` (none by default), grid.wgsl, then `$walk`.
macro_rules! sources {
    ($walk:literal) => {
        sources!($walk, "")
    };
    ($walk:literal, $consts:literal) => {
        [
            concat!(
                "alias real = f32;\n",
                $consts,
                include_str!("../shaders/grid.wgsl"),
                include_str!($walk)
            ),
            concat!(
                "alias real = f64;\n",
                $consts,
                include_str!("../shaders/grid.wgsl"),
                include_str!($walk)
            ),
        ]
    };
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
            ["uniform-grid/dda", "uniform-grid/dda-f64"],
            sources!("../shaders/uniform.wgsl"),
            self.precision,
            &self.tris,
            vec![
                header(
                    "the uniform grid's lattice",
                    lat,
                    self.precision,
                    (!macros.is_empty()) as u8 as f64,
                ),
                GpuBuffer {
                    what: "the uniform grid's cell ranges",
                    bytes: words(self.start.iter().copied()),
                    uniform: false,
                },
                GpuBuffer {
                    what: "the uniform grid's references",
                    bytes: words(self.refs.iter().copied()),
                    uniform: false,
                },
                GpuBuffer {
                    what: "the uniform grid's macro regions",
                    bytes: macro_words,
                    uniform: false,
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
            ["two-level-grid/dda", "two-level-grid/dda-f64"],
            sources!("../shaders/two_level.wgsl"),
            self.precision,
            &self.tris,
            vec![
                header(
                    "the two-level grid's top lattice",
                    &self.top,
                    self.precision,
                    0.0,
                ),
                GpuBuffer {
                    what: "the two-level grid's top cells",
                    bytes: words(self.tops.iter().flat_map(|t| [t.first_leaf, t.res])),
                    uniform: false,
                },
                GpuBuffer {
                    what: "the two-level grid's leaf ranges",
                    bytes: words(self.start.iter().copied()),
                    uniform: false,
                },
                GpuBuffer {
                    what: "the two-level grid's references",
                    bytes: words(self.refs.iter().copied()),
                    uniform: false,
                },
            ],
        )
    }
}

impl IrregularGrid {
    /// `irregular-grid/walk`: the base lattice and the deepest octree level, the voxel map,
    /// the cells (lo, begin, hi, end: two 16-byte words for the kernel's vector loads), the
    /// references.
    pub(crate) fn gpu_walk(&self) -> GpuProgram<'_> {
        self.gpu_irregular(
            ["irregular-grid/walk", "irregular-grid/walk-f64"],
            sources!("../shaders/irregular.wgsl", "const TIES = false;\n"),
        )
    }

    /// `irregular-grid/walk-hagrid`: the same walk with the authors' step (`TIES`,
    /// `grid.wgsl`'s `advance_ties`), the same buffers.
    pub(crate) fn gpu_walk_hagrid(&self) -> GpuProgram<'_> {
        self.gpu_irregular(
            [
                "irregular-grid/walk-hagrid",
                "irregular-grid/walk-hagrid-f64",
            ],
            sources!("../shaders/irregular.wgsl", "const TIES = true;\n"),
        )
    }

    fn gpu_irregular(
        &self,
        names: [&'static str; 2],
        sources: [&'static str; 2],
    ) -> GpuProgram<'_> {
        program(
            names,
            sources,
            self.precision,
            &self.tris,
            vec![
                header(
                    "the irregular grid's base lattice",
                    &self.base,
                    self.precision,
                    self.dmax as f64,
                ),
                GpuBuffer {
                    what: "the irregular grid's voxel map",
                    bytes: words(self.map.iter().copied()),
                    uniform: false,
                },
                GpuBuffer {
                    what: "the irregular grid's cells",
                    bytes: words(self.cells.iter().flat_map(|c| {
                        [
                            c.lo[0], c.lo[1], c.lo[2], c.begin, c.hi[0], c.hi[1], c.hi[2], c.end,
                        ]
                    })),
                    uniform: false,
                },
                GpuBuffer {
                    what: "the irregular grid's references",
                    bytes: words(self.refs.iter().copied()),
                    uniform: false,
                },
            ],
        )
    }
}
