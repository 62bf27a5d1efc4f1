#!/usr/bin/env bash
# The main job on an embedded default: converts the bunny that ships inside pymeshlab and writes
# out/bunny.png (texel points by patch + height maps), out/bunny.gtex and a stats table.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
python -m geomtex --quiet "$@"
