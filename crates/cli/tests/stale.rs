//! Rows of an older method never decide a claim: the committed H200 reference runs
//! (results/reference/2026-11-27*, made before rows carried their `method`) give every claim
//! they alone would decide the verdict `stale`, with the commit that made them and the
//! command that renews them, and tally no claim.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `trace-bench claims claims/PAPER.toml FOLDER --format json`'s verdicts.
fn verdicts(paper: &str, folder: &Path) -> serde_json::Value {
    let o = Command::new(env!("CARGO_BIN_EXE_trace-bench"))
        .current_dir(root())
        .args(["claims", &format!("claims/{paper}.toml")])
        .arg(folder)
        .args(["--format", "json"])
        .output()
        .expect("run trace-bench claims");
    assert!(
        o.status.success(),
        "{paper}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    serde_json::from_slice(&o.stdout).expect("claims --format json")
}

#[test]
fn the_committed_h200_rows_read_stale_and_tally_nothing() {
    let mut stale = 0;
    for reference in [
        "2026-11-27",
        "2026-11-27-677306e",
        "2026-11-27-66bdc28-grids",
    ] {
        let runs = root()
            .join("results/reference")
            .join(reference)
            .join("runs");
        let papers = std::fs::read_dir(&runs).expect("the committed reference runs");
        for p in papers {
            let p = p.unwrap().path();
            let paper = p.file_name().unwrap().to_string_lossy().into_owned();
            let v = verdicts(&paper, &p);
            for c in v["claims"].as_array().unwrap() {
                let (id, verdict) = (&c["id"], c["verdict"].as_str().unwrap());
                assert!(
                    !matches!(verdict, "agree" | "disagree"),
                    "{reference} {paper} {id} [{}]: {verdict} from rows of an older method",
                    c["device"]
                );
                if verdict == "stale" {
                    stale += 1;
                    let why = c["why"].as_str().unwrap();
                    assert!(why.contains("made by "), "{id}: {why}");
                    if c["device"] == "gpu" {
                        assert!(why.contains("scripts/gpu-reference.sh"), "{id}: {why}");
                    }
                }
            }
            let t = &v["tally"];
            assert_eq!(
                (t["agree"].as_u64(), t["disagree"].as_u64()),
                (Some(0), Some(0))
            );
        }
    }
    assert!(stale > 50, "only {stale} stale verdicts");
}
