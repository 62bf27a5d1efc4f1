#!/usr/bin/env bash
# The main job on the bundled default mesh: converts the Stanford bunny that ships inside geomtex
# (gt.data.bunny()) and writes out/bunny.png (texel points by patch + height maps), out/bunny.gtex
# and a stats table. A user's set-up: the runtime packages only, no clippy or rustfmt needed;
# with --quiet nothing but the stats table is printed.
set -euo pipefail
GEOMTEX_SETUP=demo . "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
python -m geomtex --quiet "$@"
