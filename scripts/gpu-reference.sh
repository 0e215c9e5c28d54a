#!/usr/bin/env bash
# The GPU reference: the GPU columns of every paper table in one report folder, with the claims'
# verdicts. It is `trace-bench reproduce PAPERS,all --device gpu`: every claims file's GPU runs (R-trees
# Tables 1-3 and the outside views, the kd review's GPU traversals, multi-kd Table 5's sorted and
# presorted rows, grids Tables 1-3 and 5 and the inset figure, sparse boxes' SLTR), each row
# validated against the CPU oracle, then the claims evaluated on those rows.
#
#   scripts/gpu-reference.sh [OUT]          on a machine with a GPU (at most 7 minutes of runs, then
#                                           the report; default OUT results/reference/DATE)
#   scripts/gpu-reference.sh --smoke [OUT]  a functional check at tiny sizes on any adapter
#                                           (lavapipe in CI): small images, few validated rays,
#                                           and, where the paper scenes are absent (or with
#                                           GPU_REFERENCE_STAND_INS=1, as CI sets: the builds
#                                           on the paper scenes took most of its minutes),
#                                           small generated stand-ins under OUT/scenes
#
# The papers are made in order of how much their claims need a device: the irregular grids
# (the SBVH's and the grid's rates), multi-kd Table 5, the kd review, the R-trees, then sparse
# boxes' GPU rows (for the record). A hard deadline (`reproduce --deadline`, default 7m) ends a
# run still going then (its finished rows kept) and leaves the rest out, so the report is always
# written within the device's time; REPORT.md says which runs were ended or left out.
#
# On a lent device machine use scripts/gpu-device.sh (`pack` here, then one call of `run` there):
# it carries a stripped binary, a copy of the scenes and the Vulkan loader, and returns the
# folder as one archive.
#
# Environment: TRACE_BENCH (the binary; default target/release/trace-bench, built if missing;
# gpu-device.sh sets its stripped copy), TRACE_BENCH_SCENES (the paper scenes; default
# ../shared/scenes, which does not travel to a device machine), GPU_REFERENCE_BUDGET (the reproduce budget, default 12m: the GPU
# runs' declared costs, about 630 s, fit it unscaled, so every run keeps its images: 1024x1024,
# sparse boxes 800x600; the costs are estimates, the sustained samples of about 1,300 rows
# included), GPU_REFERENCE_DEADLINE (default 7m), GPU_REFERENCE_ADAPTER (a substring of the
# adapter's name).
# The adapter is named in OUT/REPORT.md and OUT/REPRODUCTION.md; OUT/targets.txt holds the GPU
# targets' verdicts (scripts/gpu-targets.py: the rounds' spread, the SBVH's and the grid's rates; rerun
# it with --against an earlier folder for the spread between runs). Exit status: reproduce's (1 when
# a run failed); a run on a software adapter without --smoke is refused (its times are not GPU
# figures).
set -euo pipefail
cd "$(dirname "$0")/.."

smoke=0
if [ "${1:-}" = "--smoke" ]; then
  smoke=1
  shift
fi
out=${1:-results/reference/$(date -u +%Y-%m-%d)}
bin=${TRACE_BENCH:-target/release/trace-bench}
scenes=${TRACE_BENCH_SCENES:-../shared/scenes}
budget=${GPU_REFERENCE_BUDGET:-12m}
deadline=${GPU_REFERENCE_DEADLINE:-7m}
papers=perard-gayot-irregular-grids,torres-multi-kd,hapala-havran-kd-review,feldmann-rtrees,all

if [ ! -x "$bin" ]; then
  cargo build --release --quiet
  bin=target/release/trace-bench
fi

args=(reproduce "$papers" --device gpu --budget "$budget" --out "$out" -q)
if [ "$smoke" = 0 ]; then
  args+=(--deadline "$deadline")
fi
if [ -n "${GPU_REFERENCE_ADAPTER:-}" ]; then
  args+=(--adapter "$GPU_REFERENCE_ADAPTER")
fi

if [ "$smoke" = 1 ]; then
  # Tiny sizes: every run's images, the random-ray and multi-view counts, and the oracle's
  # share shrink; the pipeline (kernels, sort pass, oracle, rows, claims) is the same.
  args+=(--set scene.camera.width=16 --set scene.camera.height=16 --set scene.random.count=256
    --set run.validate=64 --set run.repeat=1 --set run.warmup=0)
  need=(stanford-bunny/stanford-bunny.obj.gz sibenik/sibenik.obj.gz
    conference/conference.obj.gz dabrovic-sponza/sponza.obj.gz)
  for f in "${need[@]}"; do
    if [ "${GPU_REFERENCE_STAND_INS:-0}" = 1 ] || [ ! -f "$scenes/$f" ]; then
      echo "gpu-reference: $scenes/$f absent or GPU_REFERENCE_STAND_INS=1: small generated stand-ins in $out/scenes"
      scenes="$out/scenes"
      mkdir -p "$scenes"
      python3 - "$scenes" "${need[@]}" <<'EOF'
# Stand-ins for the paper scenes (smoke test only): a box around every config's cameras and a
# few hundred triangles at scales from 0.01 to 1000 around the origin, so that rays hit.
import gzip, os, random, sys
root, names = sys.argv[1], sys.argv[2:]
rng = random.Random(7)
lines = []
s = 5000.0
corners = [(x, y, z) for x in (-s, s) for y in (-s, s) for z in (-s, s)]
lines += ["v %g %g %g" % c for c in corners]
for a, b, c, d in [(1, 2, 4, 3), (5, 7, 8, 6), (1, 5, 6, 2), (3, 4, 8, 7), (1, 3, 7, 5), (2, 6, 8, 4)]:
    lines += ["f %d %d %d" % (a, b, c), "f %d %d %d" % (a, c, d)]
n = 8
for i in range(600):
    r = 10 ** rng.uniform(-2, 3)
    cx, cy, cz = (rng.uniform(-r, r) for _ in range(3))
    for _ in range(3):
        lines.append("v %g %g %g" % (cx + rng.uniform(-r, r) / 4, cy + rng.uniform(-r, r) / 4, cz + rng.uniform(-r, r) / 4))
    lines.append("f %d %d %d" % (n + 1, n + 2, n + 3))
    n += 3
text = ("\n".join(lines) + "\n").encode()
for name in names:
    path = os.path.join(root, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with gzip.open(path, "wb") as f:
        f.write(text)
EOF
      break
    fi
  done
fi
args+=(--scenes-root "$scenes")

echo "gpu-reference: $bin ${args[*]}"
mkdir -p "$out"
status=0
"$bin" "${args[@]}" >"$out/reproduce.log" 2>&1 || status=$?
tail -n 3 "$out/reproduce.log"
adapter=$(grep -m1 '^GPU adapter:' "$out/REPORT.md" 2>/dev/null | sed 's/^GPU adapter: //; s/ *$//' || true)
echo "gpu-reference: adapter: ${adapter:-none (no GPU row was written)}"
if [ -z "$adapter" ]; then
  exit 1
fi
if [ "$smoke" = 0 ] && grep -q "(software)\|(cpu)" <<<"$adapter"; then
  echo "gpu-reference: $adapter is a software adapter: its times are not GPU figures (use --smoke)" >&2
  exit 1
fi
rm -rf "$out/scenes"
# The GPU targets' verdicts (the rounds' spread, the SBVH's and the grid's rates) from the rows.
if command -v python3 >/dev/null; then
  soft=(); [ "$smoke" = 1 ] && soft=(--software)
  python3 scripts/gpu-targets.py "$out" "${soft[@]}" >"$out/targets.txt" 2>&1 || true
  cat "$out/targets.txt"
fi
exit "$status"
