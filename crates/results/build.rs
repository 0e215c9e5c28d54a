//! Bakes what results.json records about the binary into it at build time: the commit and
//! whether the tree was dirty, the harness's enabled features (the peers), the optimisation
//! level, target and compiler (vergen), and the locked versions of the peer libraries' crates
//! and wgpu (from Cargo.lock, as `TB_CRATE_VERSIONS`). Outside a git checkout the git values
//! are absent and the metadata says "unknown".

use vergen_gitcl::{Cargo, Emitter, Gitcl, Rustc};

/// Crates whose versions results.json records.
const RECORDED: &[&str] = &["wgpu", "obvhs", "bvh", "embree3", "rayon"];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let git = Gitcl::builder()
        .sha(false)
        .dirty(false)
        .commit_timestamp(true)
        .build();
    let cargo = Cargo::builder()
        .features(true)
        .opt_level(true)
        .target_triple(true)
        .build();
    let rustc = Rustc::builder().semver(true).llvm_version(true).build();
    Emitter::default()
        .add_instructions(&git)?
        .add_instructions(&cargo)?
        .add_instructions(&rustc)?
        .emit()?;

    let lock = std::path::Path::new(&std::env::var("CARGO_MANIFEST_DIR")?).join("../../Cargo.lock");
    println!("cargo:rerun-if-changed={}", lock.display());
    let text = std::fs::read_to_string(&lock).unwrap_or_default();
    let mut versions = Vec::new();
    let mut name = None;
    for line in text.lines() {
        if let Some(n) = line.strip_prefix("name = ") {
            name = Some(n.trim_matches('"').to_string());
        } else if let (Some(v), Some(n)) = (line.strip_prefix("version = "), name.take()) {
            if RECORDED.contains(&n.as_str()) {
                versions.push(format!("{n} {}", v.trim_matches('"')));
            }
        }
    }
    println!("cargo:rustc-env=TB_CRATE_VERSIONS={}", versions.join(","));
    Ok(())
}
