#!/usr/bin/env bash
# Installs the Debian 12 packages the project needs, only those that are missing.
# Runs as root (apt-get) or through sudo when available.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  ccache   # scripts/build_deb.sh (and tests/package) reuse the developer build's objects
  cyclonedds-dev cyclonedds-tools
  libeigen3-dev
  libprotobuf-dev protobuf-compiler
  libspdlog-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libceres-dev
  python3-numpy python3-matplotlib
  iproute2 procps
  rt-tests stress-ng   # bench/loop: cyclictest (the machine's wake-up latency), a CPU hog
  libzstd-dev                                           # zstd MCAP chunks (recorder)
  libwebsocketpp-dev libasio-dev nlohmann-json3-dev     # hexa_bridge (Foxglove WebSocket)
  clang-14 libclang-rt-14-dev   # tests/fuzz: libFuzzer, ASan, UBSan runtimes
  gcc-arm-none-eabi             # firmware/board: the Cortex-M4 compile check (board.CortexM4Build)
  # Networked deployments (docs/deployment.md): sd_notify for the systemd units, OpenSSL for
  # the DDS Security files (openssl CLI in deploy/make_security.sh, libssl in hexa_deploy
  # verify-security), systemd-analyze to verify generated units, nftables for network faults
  # in the multi-host tests, tcpdump for the wire-encryption test, and the Debian package
  # tools (lintian; help2man for the manual pages; debootstrap for the install test in a
  # chroot). Cyclone's security plugins come with libddsc0debian (cyclonedds-dev's dependency).
  libsystemd-dev systemd openssl libssl-dev nftables tcpdump lintian debootstrap dpkg-dev help2man
)
# Node.js + npm (test clients only: the MCAP project's JS library reads recordings, Foxglove's
# schemas and WebSocket client check the scene and hexa_bridge; tests/foxglove): machines
# of this kind ship their own Node; Debian's npm conflicts with it, so the Debian packages are
# only installed when no node/npm is on PATH.
need_node=0
command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1 || need_node=1

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done

if [ "$need_node" -eq 1 ]; then
  for p in nodejs npm; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
fi

if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#packages[@]} Debian packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install_deps: missing ${missing[*]} and not root" >&2; exit 1; }
  SUDO=sudo
fi
echo "install_deps: installing ${missing[*]}"
$SUDO apt-get update -qq
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
