//! The registry of named structures: one [`Family`] per structure crate, listed once here.
//! `trace-bench list` prints it (pbrt's `CreateAccelerator`, ripgrep's flag table).
//!
//! Where a new structure goes: its crate exports a `pub static FAMILY: tb_core::Family` (name,
//! doc, parameter table, traversal table, builder); add one line to `FAMILIES` and the crate
//! to `Cargo.toml`. Nothing else in the harness, the GPU crate or the tests names a structure.

use std::collections::BTreeMap;
use tb_core::{Accel, Family, ParamKind, TraversalInfo, Triangle};

/// Every registered structure family, in listing order.
static FAMILIES: &[&Family] = &[
    &tb_core::oracle::FAMILY,
    &tb_bvh::FAMILY,
    &tb_bvh::CWBVH_FAMILY,
    &tb_kdtree::FAMILY,
    &tb_multikd::FAMILY,
    &tb_sparse::FAMILY,
    &tb_rtree::FAMILY,
    &tb_grid::UNIFORM_FAMILY,
    &tb_grid::TWO_LEVEL_FAMILY,
    &tb_grid::IRREGULAR_FAMILY,
    #[cfg(feature = "embree")]
    &tb_peers::embree::FAMILY,
    #[cfg(feature = "obvhs")]
    &tb_peers::obvhs::FAMILY,
    #[cfg(feature = "bvh-rs")]
    &tb_peers::bvh_rs::FAMILY,
];

/// The harness's method version: how rays are generated (cameras, views, shadow, AO and path
/// rays), and how rows are timed and counted. Raised with every change of those that moves a
/// row's figures; written in every row's `method` as `harness=N` ([`method_of`]).
/// 1: method versions begin (2026-12-08).
pub const HARNESS_METHOD: u32 = 1;

/// The methods that make a row of family `f` (`gpu`: a GPU row), as its `method` column holds
/// them: `NAME=VERSION;…`, the family's own version first, then its first stage's family (a
/// structure built over another's, `sparse-boxes=1;kdtree=1`), the harness's
/// ([`HARNESS_METHOD`]) and on the GPU the GPU driver's ([`tb_gpu::METHOD`]).
pub fn method_of(f: &Family, gpu: bool) -> String {
    let mut s = format!("{}={}", f.name, f.method);
    if let Some(st) = &f.stage {
        s.push_str(&format!(";{}={}", st.base.name, st.base.method));
    }
    s.push_str(&format!(";harness={HARNESS_METHOD}"));
    if gpu {
        s.push_str(&format!(";gpu={}", tb_gpu::METHOD));
    }
    s
}

/// A set of structure families a config is resolved against: [`Registry::builtin`] (what the
/// binary offers) or that plus test-only families.
#[derive(Clone)]
pub struct Registry {
    families: Vec<&'static Family>,
}

impl Default for Registry {
    fn default() -> Self {
        Self::builtin()
    }
}

impl Registry {
    /// The registered families ([`families`]).
    pub fn builtin() -> Self {
        Registry {
            families: FAMILIES.to_vec(),
        }
    }

    /// This registry with `f` added (tests register their own structures this way).
    pub fn with(mut self, f: &'static Family) -> Self {
        self.families.push(f);
        self
    }

    /// The families, in listing order.
    pub fn families(&self) -> &[&'static Family] {
        &self.families
    }

    /// The current version of every method a row's `method` names (each family's, the
    /// harness's and the GPU driver's): what `claims` reads rows against.
    pub fn methods(&self) -> BTreeMap<String, u32> {
        let mut m: BTreeMap<String, u32> = self
            .families
            .iter()
            .map(|f| (f.name.to_owned(), f.method))
            .collect();
        m.insert("harness".into(), HARNESS_METHOD);
        m.insert("gpu".into(), tb_gpu::METHOD);
        m
    }

    /// The family named `name`.
    pub fn find(&self, name: &str) -> Option<&'static Family> {
        self.families.iter().copied().find(|f| f.name == name)
    }

    /// The listing printed by `trace-bench list`: every family with its traversals (paper,
    /// step cap, auxiliary arrays, GPU kernel) and parameters (default, accepted values).
    pub fn listing(&self) -> String {
        let mut s = String::new();
        for f in &self.families {
            s.push_str(&format!("{:<14} {}\n", f.name, f.doc));
            s.push_str(&format!(
                "  method {} ({})\n",
                f.method,
                if f.method_change.is_empty() {
                    "not declared"
                } else {
                    f.method_change
                }
            ));
            for t in (f.traversals)() {
                s.push_str(&format!("  traversal {:<20} {}", t.name, t.doc));
                let tags = tags(t);
                if !tags.is_empty() {
                    s.push_str(&format!(" [{tags}]"));
                }
                s.push('\n');
            }
            let defaults = (f.defaults)();
            for p in f.params {
                let default = defaults
                    .get(p.name)
                    .map(|v| v.to_string())
                    .unwrap_or_default();
                s.push_str(&format!(
                    "  param {:<22} default {:<12} {} ({})\n",
                    p.name,
                    default,
                    p.doc_line(),
                    values(p.kind)
                ));
            }
        }
        s
    }
}

/// A traversal's facts beyond its doc line: its paper where the doc does not name it, its step
/// cap, the auxiliary arrays it reads, no counters.
fn tags(t: &TraversalInfo) -> String {
    let mut tags = Vec::new();
    if !t.paper.is_empty() && !t.doc.contains(t.paper) {
        tags.push(t.paper.to_string());
    }
    if t.step_cap {
        tags.push("step cap".into());
    }
    if !t.aux.is_empty() {
        tags.push(format!("reads {}", t.aux.join(", ")));
    }
    if t.counters.is_empty() {
        tags.push("no counters".into());
    }
    if let Some(walk) = t.cpu_as {
        tags.push(format!("on the CPU `{walk}`'s walk: no CPU rows"));
    }
    if t.on_request {
        tags.push("on request: run only where `traversals` names it".into());
    }
    tags.join("; ")
}

/// The values a parameter accepts: its choices or its range.
fn values(kind: ParamKind) -> String {
    match kind {
        ParamKind::Choice(o) => format!("one of: {}", o.join(", ")),
        ParamKind::Int { min, max } => format!("{min}..={max}"),
        ParamKind::Float { min, max } => format!("{min}..={max}"),
        ParamKind::Bool => "true, false".to_string(),
    }
}

/// A table cell: one line, `|` escaped.
fn cell(s: &str) -> String {
    s.split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
        .replace('|', "\\|")
}

/// Where docs/structures.md, which [`Registry::reference`] fills, lies from the README.
const REFERENCE: &str = "docs/structures.md";

/// A family and, per traversal, the name of its GPU program in a default build (`None`: it
/// has none).
type WithPrograms = (&'static Family, Vec<Option<String>>);

impl Registry {
    /// Every family built with its default parameters on the built-in Cornell box, with the
    /// name of each traversal's GPU program where it has one (a program's name may carry a
    /// parameter, e.g. the R-tree's `M`).
    fn programs(&self) -> Result<Vec<WithPrograms>, String> {
        let scene = tb_scene::builtin::load("cornell").map_err(|e| e.to_string())?;
        let tris: std::sync::Arc<[Triangle]> = scene.triangles.clone().into();
        let mut out = Vec::new();
        for f in &self.families {
            let accel = (f.build)(&tris, &(f.defaults)())
                .map_err(|e| format!("building {} on builtin:cornell: {e}", f.name))?;
            let programs = (0..(f.traversals)().len())
                .map(|i| accel.gpu_program(i).map(|p| p.name.to_string()))
                .collect();
            out.push((*f, programs));
        }
        Ok(out)
    }

    /// The README's structure table (`trace-bench list --markdown`): one line per family, its
    /// name linked to its section of docs/structures.md, its summary, how many traversals it
    /// has and how many of them have a GPU program (those of a default build).
    pub fn markdown(&self) -> Result<String, String> {
        let mut s = String::from(
            "| structure | what | traversals | with a GPU program |\n|---|---|---|---|\n",
        );
        for (f, programs) in self.programs()? {
            s.push_str(&format!(
                "| [`{}`]({REFERENCE}#{}) | {} | {} | {} |\n",
                f.name,
                f.name,
                cell(f.summary),
                programs.len(),
                programs.iter().flatten().count()
            ));
        }
        Ok(s)
    }

    /// docs/structures.md's reference (`trace-bench list --markdown --details`): per family a
    /// section with its doc, its traversals (doc, paper, step cap, auxiliary arrays, the GPU
    /// program of a default build) and its parameters (default, accepted values, doc).
    pub fn reference(&self) -> Result<String, String> {
        let mut s = String::new();
        for (f, programs) in self.programs()? {
            s.push_str(&format!("### `{}`\n\n{}\n\n", f.name, cell(f.doc)));
            s.push_str(&format!(
                "Method version {} (the rows' `method`): {}.\n\n",
                f.method,
                cell(f.method_change)
            ));
            s.push_str("| traversal | what | GPU program |\n|---|---|---|\n");
            for (t, p) in (f.traversals)().iter().zip(&programs) {
                let what = match tags(t) {
                    tags if tags.is_empty() => cell(t.doc),
                    tags => format!("{} [{}]", cell(t.doc), cell(&tags)),
                };
                let p = p.as_ref().map(|p| format!("`{p}`")).unwrap_or_default();
                s.push_str(&format!("| `{}` | {what} | {p} |\n", t.name));
            }
            if !f.params.is_empty() {
                let defaults = (f.defaults)();
                s.push_str("\n| parameter | default | values | meaning |\n|---|---|---|---|\n");
                for p in f.params {
                    let default = defaults.get(p.name).map(|v| v.to_string());
                    s.push_str(&format!(
                        "| `{}` | {} | {} | {} |\n",
                        p.name,
                        default.map(|d| format!("`{d}`")).unwrap_or_default(),
                        cell(&values(p.kind)),
                        cell(&p.doc_line())
                    ));
                }
            }
            s.push('\n');
        }
        Ok(s)
    }
}

/// Every registered structure family (the GPU oracle test loops over these).
pub fn families() -> &'static [&'static Family] {
    FAMILIES
}

/// The structure name of [`generator`] (the label of what it renders, e.g. the shaded image
/// beside the heat maps).
pub const GENERATOR_LABEL: &str = "bvh";

/// The accelerator used to generate secondary rays (shadow, AO, path bounces) from primary
/// hits: the binary binned BVH ([`tb_bvh::BvhParams::binary`]), fixed so that every batch of
/// secondary rays stays the same whatever `bvh`'s defaults are. It is built only when a scene
/// asks for secondary rays.
pub fn generator(tris: &[Triangle]) -> Box<dyn Accel> {
    Box::new(tb_bvh::Bvh::build(tris, &tb_bvh::BvhParams::binary()))
}

/// Tables 1 and 2 of Torres et al. 2012, the multi-kd-trees' normalised weights computed by
/// numerical integration: what the multi-kd family offers beside its structure (`trace-bench
/// weights`).
pub mod weights {
    pub use tb_multikd::measure::{weight_rows, weight_tables, TABLE2_BETAS};

    /// The columns of `weights.csv` (`trace-bench weights --csv`), in the order of
    /// [`weight_rows`]' fields, each with whether it holds numbers (kept with the other CSVs' rows).
    pub use tb_results::tables::WEIGHTS_COLUMNS as CSV_COLUMNS;
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every family declares its method version (a row of an undeclared one would carry
    /// `NAME=0`, read as older than any), and a row's `method` names each method `methods`
    /// knows at its version: such a row is current, and one of version 0 is not.
    #[test]
    fn every_family_declares_its_method_and_rows_name_it() {
        let reg = Registry::builtin();
        let methods = reg.methods();
        for f in reg.families() {
            assert!(f.method >= 1, "{} declares no method version", f.name);
            assert!(!f.method_change.is_empty(), "{}: no method change", f.name);
            for gpu in [false, true] {
                let m = method_of(f, gpu);
                for (k, v) in tb_results::pairs::pairs(&m) {
                    assert_eq!(methods.get(k).map(|x| x.to_string()), Some(v.into()), "{m}");
                }
                assert_eq!(m.contains(";gpu="), gpu, "{m}");
            }
        }
        let sparse = reg.find("sparse-boxes").expect("sparse boxes registered");
        assert!(
            method_of(sparse, false).contains(";kdtree="),
            "the first stage is named"
        );
    }
}
