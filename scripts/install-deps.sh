#!/usr/bin/env bash
# Installs the Debian 12 packages palletd needs to build, test and run its demo.
# Idempotent: quiet and fast (no apt-get update) when everything is already present.
set -euo pipefail

packages=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  lld  # the linker scripts/test.sh uses when present (much faster links)
  # libraries
  libpcl-dev libcgal-dev libopencv-dev libeigen3-dev
  libaravis-dev aravis-tools libopenni2-dev
  libmodbus-dev libspdlog-dev libyaml-cpp-dev libsystemd-dev
  nlohmann-json3-dev libcli11-dev libcpp-httplib-dev
  prometheus-cpp-dev  # the metrics' families and text format (src/metrics)
  catch2
  # test peers and tools: python Modbus client, systemd-analyze, network namespaces
  python3 python3-pymodbus systemd iproute2 util-linux
  python3-serial-asyncio  # pymodbus 3.0 imports it even for TCP clients
  mbpoll  # the Modbus commands in docs/register-map.md
  chromium  # headless browser test of the status page (tests/web)
  clang-14 libclang-rt-14-dev  # ASan+UBSan build with libFuzzer (scripts/test.sh asan/fuzz stages)
  gdb  # thread stacks of a daemon that does not exit in time (tests/reliability/daemon_harness.hpp)
  prometheus  # promtool and a real Prometheus scraping palletd (tests/metrics); its service stays off
)
if [[ "${1:-}" == "--print" ]]; then printf '%s\n' "${packages[@]}"; exit 0; fi

# An npm client drives the Modbus handshake in the tests: Debian's nodejs/npm unless the machine
# already has them.
if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then packages+=(nodejs npm); fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[[ ${#missing[@]} -eq 0 ]] && exit 0

sudo=""
if [[ $(id -u) -ne 0 ]]; then sudo="sudo"; fi
echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
# Packages that are services (prometheus) must not start one: the tests start their own on
# loopback. Where no policy-rc.d says so already, one that refuses every start stands for the install.
policy=/usr/sbin/policy-rc.d
if [[ ! -e $policy ]]; then
  printf '#!/bin/sh\nexit 101\n' | $sudo tee "$policy" >/dev/null
  $sudo chmod 755 "$policy"
  trap '$sudo rm -f "$policy"' EXIT
fi
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
