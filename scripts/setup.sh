#!/usr/bin/env bash
# Idempotent set-up on a fresh Debian machine that has Rust (cargo) and Python >= 3.11:
# a Vulkan driver (Mesa's lavapipe, if none is installed), a virtualenv in .venv, Python packages
# from pyproject.toml, and a release build of the extension installed into the venv (editable:
# python/ is imported in place). Sourced by demo.sh, test.sh and install_check.sh; safe to run
# again (seconds: each step is skipped while what it depends on is unchanged).
#
# GEOMTEX_SETUP picks the packages: "demo" (the default: what `python -m geomtex` needs, the
# runtime dependencies and maturin) or "test" (those plus every extra: test, bench, docs,
# notebook...). pip's and maturin's output goes to .venv/setup.log, shown if a step fails; with
# --quiet among the sourcing script's arguments the set-up prints nothing unless it fails.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

PY=${PYTHON:-python3}
SETUP_MODE=${GEOMTEX_SETUP:-demo}
as_root() { if [ "$(id -u)" = 0 ]; then "$@"; else sudo "$@"; fi; }
setup_quiet=0
for arg in "$@"; do [ "$arg" = --quiet ] && setup_quiet=1; done
say() { [ "$setup_quiet" = 1 ] || echo "setup: $*" >&2; }

if ! command -v cargo >/dev/null 2>&1; then
  [ -x "$HOME/.cargo/bin/cargo" ] && export PATH="$HOME/.cargo/bin:$PATH"
fi
command -v cargo >/dev/null 2>&1 || {
  echo "setup: cargo not found; install Rust first: curl https://sh.rustup.rs -sSf | sh" >&2; exit 1; }
"$PY" -c 'import sys; sys.exit(sys.version_info < (3, 11))' || {
  echo "setup: $PY is older than Python 3.11" >&2; exit 1; }

# A Vulkan driver for the renderer: Mesa's lavapipe (software) where no other is installed.
# (Any one driver manifest will do: `ls` of both folders' globs failed when either was empty.)
has_vulkan_icd() {
  local f
  for f in /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json; do [ -e "$f" ] && return 0; done
  return 1
}
if ! has_vulkan_icd || ! ldconfig -p 2>/dev/null | grep libvulkan.so.1 >/dev/null; then
  if command -v apt-get >/dev/null 2>&1; then
    say "installing Mesa's software Vulkan driver (mesa-vulkan-drivers, libvulkan1) with apt-get"
    as_root apt-get update -qq
    as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
      mesa-vulkan-drivers libvulkan1 >/dev/null
  else
    echo "setup: no Vulkan driver found; install Mesa's lavapipe (mesa-vulkan-drivers)" >&2
  fi
fi

if [ ! -x .venv/bin/python ]; then
  say "creating the virtualenv .venv"
  if ! "$PY" -m venv .venv 2>/dev/null; then
    # Debian's system Python keeps venv in a separate package.
    rm -rf .venv
    as_root apt-get update -qq && as_root env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
    "$PY" -m venv .venv
  fi
fi
# shellcheck disable=SC1091
. .venv/bin/activate

SETUP_LOG=.venv/setup.log
# Runs a command with its output in the log; on failure shows the log's end and stops.
logged() {
  echo "\$ $*" >>"$SETUP_LOG"
  if ! "$@" >>"$SETUP_LOG" 2>&1; then
    echo "setup: failed: $*; the end of $SETUP_LOG:" >&2
    tail -n 40 "$SETUP_LOG" >&2
    exit 1
  fi
}

# Python packages, reinstalled when pyproject.toml changes. A test set-up covers a demo's.
deps_hash=$(sha1sum pyproject.toml | cut -c1-12)
if [ ! -f ".venv/.deps-$SETUP_MODE-$deps_hash" ] && [ ! -f ".venv/.deps-test-$deps_hash" ]; then
  say "installing the Python packages for the $SETUP_MODE (log: $SETUP_LOG)"
  mapfile -t reqs < <(python - "$SETUP_MODE" <<'PY'
import sys
import tomllib

p = tomllib.load(open("pyproject.toml", "rb"))
reqs = p["build-system"]["requires"] + p["project"]["dependencies"]
if sys.argv[1] == "test":
    for extra in p["project"]["optional-dependencies"].values():
        reqs += extra
print("\n".join(dict.fromkeys(reqs)))
PY
)
  logged python -m pip install --disable-pip-version-check --upgrade pip
  logged python -m pip install --disable-pip-version-check "${reqs[@]}"
  touch ".venv/.deps-$SETUP_MODE-$deps_hash"
fi

# The extension: a release build (about 2 minutes cold on 2 cores), redone when the Rust sources,
# shaders or build settings change. (`cargo test` in test.sh rebuilds the library without the
# python feature in the same target dir, so an unconditional `maturin develop` would rebuild it
# from scratch on every run.)
mapfile -t build_inputs < <(ls -d src shaders build.rs Cargo.toml Cargo.lock pyproject.toml 2>/dev/null || true)
build_hash=$(find "${build_inputs[@]}" -type f -print0 | sort -z | xargs -0 sha1sum | sha1sum | cut -c1-12)
if [ ! -f ".venv/.build-$build_hash" ] || ! python -c 'import geomtex._core' >/dev/null 2>&1; then
  say "building the extension (release; about 2 minutes the first time; log: $SETUP_LOG)"
  logged maturin develop --release
  rm -f .venv/.build-*
  touch ".venv/.build-$build_hash"
fi
