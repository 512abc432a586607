#!/usr/bin/env bash
# Installs the Debian packages of mk/debian-packages.txt that are missing, saying which, with sudo
# when not run as root. Quiet and quick (one dpkg-query) when everything is there, so `make run`
# and `make test` call it every time.
set -euo pipefail
cd "$(dirname "$0")/.."
mapfile -t wanted < <(sed -e 's/#.*//' -e 's/[[:space:]]//g' mk/debian-packages.txt | grep -v '^$')
missing=()
if command -v dpkg-query >/dev/null; then
  # dpkg-query exits 1 when a package is unknown to dpkg: that package is simply missing.
  installed=$( { dpkg-query -W -f='${Package} ${db:Status-Abbrev}\n' "${wanted[@]}" 2>/dev/null || true; } |
              awk '$2 ~ /^ii/ {print $1}')
  for p in "${wanted[@]}"; do
    grep -qx -F "$p" <<<"$installed" || missing+=("$p")
  done
else
  echo "depthpose: this is not a Debian system (no dpkg-query); install the equivalents of:" >&2
  printf '  %s\n' "${wanted[@]}" >&2
  exit 1
fi
[ ${#missing[@]} -eq 0 ] && exit 0
echo "depthpose: installing missing Debian packages: ${missing[*]}"
if [ "$(id -u)" = 0 ]; then
  SUDO=()
elif command -v sudo >/dev/null; then
  SUDO=(sudo)
  echo "depthpose: not root, using sudo"
else
  echo "depthpose: need root to install ${missing[*]}: run 'make deps' as root" >&2
  exit 1
fi
"${SUDO[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${SUDO[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "depthpose: installed ${missing[*]}"
