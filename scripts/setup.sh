#!/usr/bin/env bash
# Idempotent set-up on a fresh Debian machine that has Rust (cargo) and Python >= 3.11:
# a Vulkan driver (Mesa's lavapipe, if none is installed), a virtualenv in .venv, the Python
# packages named in pyproject.toml, and a release build of the extension installed into the venv. Sourced by demo.sh and test.sh; safe to run again (fast).
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

PY=${PYTHON:-python3}
as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }

if ! command -v cargo >/dev/null 2>&1; then
  [ -x "$HOME/.cargo/bin/cargo" ] && export PATH="$HOME/.cargo/bin:$PATH"
fi
command -v cargo >/dev/null 2>&1 || {
  echo "setup: cargo not found; install Rust first: curl https://sh.rustup.rs -sSf | sh" >&2; exit 1; }
for tool in clippy fmt; do
  cargo "$tool" --version >/dev/null 2>&1 || {
    echo "setup: cargo $tool is missing; install it with: rustup component add ${tool/fmt/rustfmt}" >&2; exit 1; }
done
"$PY" -c 'import sys; sys.exit(sys.version_info < (3, 11))' || {
  echo "setup: $PY is older than Python 3.11" >&2; exit 1; }

# A Vulkan driver for the renderer: Mesa's lavapipe (software) where no other is installed.
if ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1 \
   || ! ldconfig -p 2>/dev/null | grep -q libvulkan.so.1; then
  if command -v apt-get >/dev/null 2>&1; then
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      mesa-vulkan-drivers libvulkan1 >/dev/null
  else
    echo "setup: no Vulkan driver found; install Mesa's lavapipe (mesa-vulkan-drivers)" >&2
  fi
fi

if [ ! -x .venv/bin/python ]; then
  if ! "$PY" -m venv .venv 2>/dev/null; then
    # Debian's system Python keeps venv in a separate package.
    rm -rf .venv
    as_root apt-get update -qq && as_root apt-get install -y -qq python3-venv
    "$PY" -m venv .venv
  fi
fi
# shellcheck disable=SC1091
. .venv/bin/activate

# Python packages: runtime + test + bench lists from pyproject.toml, reinstalled when it changes.
stamp=".venv/.deps-$(sha1sum pyproject.toml | cut -c1-12)"
if [ ! -f "$stamp" ]; then
  python -m pip install -q --upgrade pip
  mapfile -t reqs < <(python - <<'PY'
import tomllib
p = tomllib.load(open("pyproject.toml", "rb"))
reqs = p["build-system"]["requires"] + p["project"]["dependencies"]
for extra in p["project"]["optional-dependencies"].values():
    reqs += extra
print("\n".join(dict.fromkeys(reqs)))
PY
)
  python -m pip install -q "${reqs[@]}"
  touch "$stamp"
fi

# The extension: an incremental release build (about 2 minutes cold, seconds after).
maturin develop --release -q
