#!/usr/bin/env bash
# Installs the Debian packages weft needs to build and test. Idempotent; needs root (or sudo).
set -euo pipefail
# With --test: also Debian's Chromium, the real browser of the dashboard test (Playwright drives
# it at /usr/bin/chromium; its own browser download would fail offline).
packages=(build-essential cmake libeigen3-dev libgtest-dev redis-server python3-venv python3-dev)
if [ "${1:-}" = "--test" ]; then
  packages+=(chromium)
fi
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "installing Debian packages: ${missing[*]}"
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
