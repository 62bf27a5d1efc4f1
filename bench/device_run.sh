#!/usr/bin/env bash
# Runs benchmarks on a lent GPU machine (the workplace's `device` tool; see the README's "One run
# on a real GPU"). That machine is bare (Python 3.12 with numpy, matplotlib, Pillow, tqdm; no
# network, no Vulkan loader, no trimesh), so everything travels from here, in ignored folders
# named in the call's `carry`. Prepare once, from the repository root, after `bash scripts/setup.sh`:
#
#   printf '/.gl/\n/.whl/\n/.dev/\n' >> .git/info/exclude; mkdir -p .gl .whl .dev /tmp/amd64/partial
#   o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
#   apt-get $o update; (cd .gl && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
#   python3 -m pip download --no-deps --only-binary=:all: --python-version 3.12 --implementation cp \
#     --platform manylinux_2_28_x86_64 --platform manylinux_2_17_x86_64 -d .whl trimesh==5.2.0 embreex rtree
#   cp -r ../shared/meshes .dev/meshes
#   python -c "import sys; sys.path.insert(0, 'bench'); from render import dense_bunny, BUNNY; dense_bunny(BUNNY, 2)"
#
# (pymeshlab's wheel is too large to carry, hence the cached Loop-subdivided bunny in bench/.cache.)
# Then: run(command='bash bench/device_run.sh "rays@120:--wait-idle,2" "render@300:--wait-idle,3"',
#           carry=[".gl", ".whl", ".dev", "python/geomtex/_core.abi3.so", "bench/.cache"])
# Each argument is BENCH@SECONDS:ARGS (ARGS comma-separated); results come back in $OUT.
exec > >(tee -a "$OUT/log.txt") 2>&1
for f in .gl/*.deb; do dpkg -x "$f" /; done; ldconfig
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit 1
export PYTHONPATH=/tmp/site:$PWD/python PYTHONUNBUFFERED=1
[ -f /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json ] && export VK_DRIVER_FILES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
mkdir -p ../shared && ln -sfn "$PWD/.dev/meshes" ../shared/meshes
nvidia-smi -L; nproc; python3 --version
python3 -c "import geomtex as gt, trimesh, embreex; print(gt.Renderer(8, 8).adapter_info, trimesh.__version__)" || exit 2
cd bench
for step in "$@"; do
  name=${step%%:*}; args=${step#*:}; args=${args//,/ }
  secs=${name##*@}; name=${name%@*}
  echo "=== $name $args (limit $secs s) $(date +%T)"
  timeout "$secs" python3 "$name.py" $args 2>&1 | grep -v "it/s\]" | tail -60 || echo "=== $name failed or timed out"
  cp results/"$name"*.json results/"$name"*.png "$OUT"/ 2>/dev/null
  ls -la "$OUT"
done
