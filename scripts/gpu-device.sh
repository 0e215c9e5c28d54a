#!/usr/bin/env bash
# The GPU reference on a lent device machine (the `device` tool), in two steps:
#
#   scripts/gpu-device.sh pack          here: fills target/gpu-ref/ (ignored by git) with what
#                                       the device needs and does not have, and prints the call
#   scripts/gpu-device.sh run [--smoke] there (the call's command), from the repository root:
#                                       scripts/gpu-reference.sh into /tmp/ref, then the whole
#                                       folder as $OUT/ref.tar.gz (and targets.txt, REPORT.md)
#
# What `pack` puts in target/gpu-ref/ (carry it: `carry = ["target/gpu-ref"]`, about 30 MB of the
# call's 64 MiB):
# - trace-bench: the release binary without its debug info (68 MB with it, over the limit);
# - scenes/: a copy of TRACE_BENCH_SCENES (default ../shared/scenes, about 7 MB): the folder
#   beside the checkout does not travel, and without it every paper scene would be skipped;
# - gl/: the Vulkan loader's Debian packages (amd64), unpacked on the device only where
#   `ldconfig` finds no libvulkan (the device tool's README).
#
# Why `run` packs its output: the device returns at most 8 files, no more than two folders
# below $OUT, and a reproduce folder holds runs/<paper>/<n-config>/results.csv. Unpack here with
# `tar xzf FILES_AT/ref/ref.tar.gz -C /tmp` and move /tmp/ref to results/reference/DATE-COMMIT.
# `run --smoke` is gpu-reference.sh's smoke run (tiny sizes, any adapter; a local check of this
# script with OUT set to any folder).
set -euo pipefail
cd "$(dirname "$0")/.."
dest=target/gpu-ref

pack() {
  cargo build --release --quiet
  mkdir -p "$dest"
  objcopy --strip-debug target/release/trace-bench "$dest/trace-bench"
  local src=${TRACE_BENCH_SCENES:-../shared/scenes}
  if [ ! -d "$src" ]; then
    echo "gpu-device: $src: no scenes folder (set TRACE_BENCH_SCENES)" >&2
    exit 1
  fi
  rm -rf "$dest/scenes"
  cp -rL "$src" "$dest/scenes"
  chmod -R u+w "$dest/scenes"
  if [ ! -d "$dest/gl" ]; then
    local lists
    lists=$(mktemp -d)
    mkdir -p "$lists/partial" "$dest/gl"
    local o=(-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oAPT::Sandbox::User=root
      "-oDir::State::Lists=$lists")
    apt-get "${o[@]}" update -qq >/dev/null
    (cd "$dest/gl" && apt-get "${o[@]}" download -qq libvulkan1 >/dev/null)
    rm -rf "$lists"
  fi
  # What travels: the tracked files, the untracked ones git does not ignore, and the carry; the
  # device tool refuses a call over 64 MiB.
  local tree carry limit=$((64 * 1024 * 1024))
  tree=$( (git ls-files -z; git ls-files -z -o --exclude-standard) | xargs -0 du -cb 2>/dev/null |
    awk '$2 == "total" {s += $1} END {print s + 0}')
  carry=$(du -sb "$dest" | cut -f1)
  echo "gpu-device: $((carry / 1000000)) MB in $dest, $((tree / 1000000)) MB of working tree," \
    "$(((tree + carry) / 1000000)) MB of the call's $((limit / 1000000)) (commit" \
    "$(git rev-parse --short HEAD))"
  if [ $((tree + carry)) -gt "$limit" ]; then
    echo "gpu-device: over the device call's 64 MiB: leave scenes out of $dest/scenes" >&2
    exit 1
  fi
  echo "gpu-device: the device call: run(command=\"scripts/gpu-device.sh run\"," \
    "carry=[\"$dest\"], timeout_s=560)"
}

run() {
  : "${OUT:?gpu-device: OUT, the device tool folder, is not set}"
  chmod +x "$dest/trace-bench"
  if ! ldconfig -p | grep -q libvulkan; then
    for f in "$dest"/gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
  fi
  local icd=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
  if [ -f "$icd" ]; then
    export VK_DRIVER_FILES=$icd
  fi
  nvidia-smi -L 2>/dev/null || true
  local status=0
  rm -rf /tmp/ref
  TRACE_BENCH=$dest/trace-bench TRACE_BENCH_SCENES=$dest/scenes \
    scripts/gpu-reference.sh "$@" /tmp/ref || status=$?
  if [ -d /tmp/ref ]; then
    tar czf "$OUT/ref.tar.gz" -C /tmp ref
    cp /tmp/ref/targets.txt /tmp/ref/REPORT.md "$OUT/" 2>/dev/null || true
  fi
  exit "$status"
}

case "${1:-}" in
  pack) pack ;;
  run) shift; run "$@" ;;
  *)
    echo "usage: scripts/gpu-device.sh pack | run [--smoke]" >&2
    exit 2
    ;;
esac
