#!/usr/bin/env bash
# The whole real-GPU measurement as one command (BENCHMARKS.md is written from its output):
#
#   scripts/gpu-bench.sh [--quick] [--out DIR] [--device NAME] [--bin PATH]
#
# 1. main/: `softshadow bench` over every built-in scene and every technique, the scene's light
#    radius, 512x512 image, 1024^2 light buffers, 5 warm-up + 20 timed frames, with
#    `--spirv glslang,tuned` (adds the `smoothies spirv=tuned` rows);
# 2. silhouettes/: both smoothie forms and penumbra-map with `--silhouettes cpu,gpu` on
#    `dense` and `dense-1m` (the CPU path against the compute passes, same sizes);
# 3. DIR/README.md: the device, driver, commit, command lines and seconds per step, with links
#    to each step's report.md, time_vs_error.png and results.csv.
#
# Aimed at under 8 minutes on an H100/H200 host (16 cores for the CPU ray-cast reference,
# which dominates on dense-1m; it is cached under ~/.cache/softshadow for re-runs).
# `--quick` runs the same steps at 64x64 with 128^2 buffers, 1 warm-up + 1 timed frame, on
# `cylinder` and `overlap` (main) and `dense` (silhouettes), validation layers on: CI runs it
# on lavapipe (.ci/run, about 15 s after the build) so that the script cannot rot. Without --bin, the full run builds and uses the
# release binary and --quick the debug one (which `cargo test` has already built).
# Nothing is written into DIR unless every step succeeded (each bench stages its own output;
# the steps write into DIR.partial, renamed to DIR at the end).
set -euo pipefail
cd "$(dirname "$0")/.."

quick=0
out=""
bin=""
device=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) quick=1 ;;
    --out) out="${2:?--out needs a folder}"; shift ;;
    --device) device=(--device "${2:?--device needs a name}"); shift ;;
    --bin) bin="${2:?--bin needs a path}"; shift ;;
    -h|--help) sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "error: gpu-bench.sh: unknown argument '$1' (allowed: --quick, --out DIR, --device NAME, --bin PATH)" >&2; exit 2 ;;
  esac
  shift
done
if [ -z "$out" ]; then
  if [ $quick = 1 ]; then out=gpu-bench-quick; else out=gpu-bench-out; fi
fi
if [ -e "$out" ] && [ ! -d "$out" ]; then
  echo "error: gpu-bench.sh: $out exists and is not a folder" >&2
  exit 2
fi
export PATH="$HOME/.cargo/bin:$PATH"
if [ -z "$bin" ]; then
  if [ $quick = 1 ]; then
    cargo build --quiet --bin softshadow
    bin=target/debug/softshadow
  else
    cargo build --quiet --release --bin softshadow
    bin=target/release/softshadow
  fi
fi
if [ ! -x "$bin" ]; then
  echo "error: gpu-bench.sh: $bin is not an executable softshadow" >&2
  exit 2
fi

if [ $quick = 1 ]; then
  main_scenes=(--scenes cylinder,overlap)
  sil_scenes=dense
  sizes=(--width 64 --height 64 --resolutions 128)
  frames=(--warmup 1 --frames 1)
  # CI: any validation message fails the step.
  device+=(--validation)
else
  main_scenes=(--full)
  sil_scenes=dense,dense-1m
  sizes=(--width 512 --height 512 --resolutions 1024)
  frames=(--warmup 5 --frames 20)
fi
common=("${sizes[@]}" "${frames[@]}" --radii scene)

partial="$out.partial"
rm -rf "$partial"
mkdir -p "$partial"
trap 'rm -rf "$partial"' EXIT
started=$(date -u +%Y-%m-%dT%H:%M:%SZ)
steps=()

# Runs one bench into $partial/$1 and records its command line and seconds.
step() {
  local name="$1"
  shift
  local cmd=("$bin" "${device[@]}" bench "$@" --out "$partial/$name")
  echo "gpu-bench: $name: ${cmd[*]}"
  local t0=$SECONDS
  "${cmd[@]}" > "$partial/$name.log" 2>&1 || {
    tail -20 "$partial/$name.log" >&2
    echo "error: gpu-bench.sh: step $name failed (its log is above)" >&2
    exit 1
  }
  local dt=$((SECONDS - t0))
  steps+=("| $name | $dt | \`softshadow bench ${*} --out $name\` |")
  echo "gpu-bench: $name: ${dt} s"
}

step main "${main_scenes[@]}" "${common[@]}" --spirv glslang,tuned
step silhouettes --scenes "$sil_scenes" --techniques smoothies,smoothies-centred,penumbra-map \
  --silhouettes cpu,gpu "${common[@]}"

device_line=$(grep -m1 '^device: ' "$partial/main.log" || echo "device: unknown")
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
{
  echo "# softshadow gpu-bench$([ $quick = 1 ] && echo ' (--quick)')"
  echo
  echo "- $device_line"
  echo "- commit $commit, started $started, finished $(date -u +%Y-%m-%dT%H:%M:%SZ)"
  echo "- host: $(nproc) CPU cores (the reference ray cast runs on the CPU)"
  if command -v nvidia-smi > /dev/null 2>&1; then
    echo "- nvidia-smi: $(nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null | head -1)"
  fi
  echo
  echo "| step | seconds | command |"
  echo "|:---|---:|:---|"
  printf '%s\n' "${steps[@]}"
  echo
  echo "Each step's folder holds report.md (a table per scene: frame ms, × hard, per-pass ms,"
  echo "mae_lit, p99_lit, flip, mae_shadow), time_vs_error.png, results.csv, results.json and"
  echo "images/; the step's console output is beside it as STEP.log."
  echo
  echo "- [main/report.md](main/report.md), ![main](main/time_vs_error.png)"
  echo "- [silhouettes/report.md](silhouettes/report.md)"
} > "$partial/README.md"

rm -rf "$out"
mv "$partial" "$out"
trap - EXIT
echo "gpu-bench: wrote $out/README.md, $out/main/, $out/silhouettes/ in $SECONDS s"
