#!/usr/bin/env bash
# Installs the Debian packages listed in debian-packages.txt (or in the lists named as arguments,
# files beside this script) that are missing.
# As root: apt-get update + install (non-interactive). Otherwise: prints the exact command and
# exits 1, so `make` stops before a build that cannot work.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
lists=("$@")
[[ ${#lists[@]} -eq 0 ]] && lists=(debian-packages.txt)
wanted=()
for list in "${lists[@]}"; do
  mapfile -t -O "${#wanted[@]}" wanted < <(grep -v '^\s*#' "$here/$list" | grep -v '^\s*$')
done
missing=()
for p in "${wanted[@]}"; do
  status="$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)"
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done
[[ ${#missing[@]} -eq 0 ]] && exit 0
cmd="apt-get install -y --no-install-recommends ${missing[*]}"
if [[ $(id -u) -ne 0 ]]; then
  echo "photonflow: missing Debian packages: ${missing[*]}" >&2
  echo "photonflow: run as root:  apt-get update && DEBIAN_FRONTEND=noninteractive $cmd" >&2
  exit 1
fi
echo "photonflow: installing ${missing[*]}" >&2
apt-get update -q >&2
DEBIAN_FRONTEND=noninteractive $cmd >&2
