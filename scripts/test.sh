#!/usr/bin/env bash
# The whole test suite: formatting and lints (rustfmt, clippy with the 100-line function limit,
# ruff), Rust core tests (no Python; the one GPU test skips without an adapter), pytest, and the type stubs.
# Any failure — including pytest finding no tests (exit 5) — fails the script.
set -euo pipefail
# The lints need rustfmt and clippy (the demo does not): checked before the set-up's long steps
# (a missing cargo is the set-up's to report).
[ -x "$HOME/.cargo/bin/cargo" ] && export PATH="$HOME/.cargo/bin:$PATH"
if command -v cargo >/dev/null 2>&1; then
  for tool in clippy fmt; do
    cargo "$tool" --version >/dev/null 2>&1 || {
      echo "test: cargo $tool is missing; install it with: rustup component add ${tool/fmt/rustfmt}" >&2; exit 1; }
  done
fi
# Every extra (test, bench, docs, notebook, gdm, distributed) on top of the demo's packages.
GEOMTEX_SETUP=test . "$(dirname "${BASH_SOURCE[0]}")/setup.sh"

echo "== rustfmt, clippy (core and binding layer together), ruff"
cargo fmt --check
# One clippy run with the binding layer on lints the core too; `cargo test` below builds the core
# without it, so a core that needs PyO3 still fails the suite.
cargo clippy --quiet --all-targets --features python -- -D warnings
python -m ruff check python tests bench

echo "== cargo test (pure-Rust core)"
cargo test --release --quiet

echo "== pytest"
python -m pytest -q -p no:cacheprovider tests "$@"

echo "== docs (sphinx -W, nitpicky) and docstring lint"
# The whole site with warnings as errors (conf.py: nitpicky, so every geomtex name must resolve);
# tests/test_api_docs.py, run by pytest above, checks that docs/api/ lists every public name.
python -m sphinx -W --keep-going -q -b html docs docs/_build/html
# pydocstyle's rules (numpy convention) as pyproject.toml configures them for python/geomtex.
python -m ruff check python/geomtex

echo "== type stubs (mypy.stubtest) and mypy"
# The extension alone: importing geomtex adds nothing to geomtex._core (tests/test_bridge.py), so
# stubtest sees what _core.pyi describes and nothing the package wrote.
python -m mypy.stubtest geomtex._core
python -m mypy
