#!/usr/bin/env bash
# Installs what softshadow needs on Debian when it is missing: lavapipe (mesa-vulkan-drivers),
# glslangValidator (glslang-tools), the Khronos validation layers, spirv-tools, a C and C++
# toolchain (g++: the nv-flip crate builds NVIDIA's C++ FLIP with the cc crate),
# and a Rust toolchain through rustup when no cargo is on the PATH.
set -euo pipefail

packages=(mesa-vulkan-drivers glslang-tools vulkan-validationlayers spirv-tools libvulkan1 ca-certificates curl gcc g++)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  $sudo apt-get update
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y "${missing[@]}"
fi
if ! command -v cargo >/dev/null 2>&1 && [ ! -x "$HOME/.cargo/bin/cargo" ]; then
  echo "installing Rust with rustup"
  curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal
fi
