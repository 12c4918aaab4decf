#!/usr/bin/env bash
# The Warp benchmark's GPU check: benchmarks/warp.py on cuda:0 at 1,024 / 4,096 / 16,384 worlds for Go2 and
# the humanoid (steady and restarting), then the CUDA-against-CPU tests of the Warp engine
# (tests/warp/test_warp_cuda.py: Philox words, the sensor layer with drawn schedules, misalign and drawn
# parameters, cameras in a captured control step). At most 9 minutes of device time after the payload's first
# two calls; every stage has its own timeout, and what it printed is in $OUT (warp.txt, warp.json,
# cuda_tests.txt) even when one runs out.
#
# Here, from the repository root, with a network (once; .device/ is git-excluded by device-payload):
#   ../shared/tools/device-payload                   # wheels: prints the three device calls
#   MENAGERIE_ROOT=/path/to/mujoco_menagerie bash benchmarks/warp_gpu.sh prepare
#       # .device/models/: dm_control's humanoid, and Menagerie's unitree_go2 (scene_mjx.xml, go2_mjx.xml,
#       # assets/) from MENAGERIE_ROOT or the mujoco-menagerie package; without either, Go2 runs
#       # tests/models/go2_like.xml and the table says so
# On the device (the run tool), the payload's calls 1 and 2 as device-payload prints them, then at once:
#   carry [".device/c", ".device/models"], timeout_s 600:
#       PYTHONUNBUFFERED=1 bash benchmarks/warp_gpu.sh
# (On a machine where the wheels are installed already, /tmp/site present, the same command skips the install.)
set -uo pipefail
cd "$(dirname "$0")/.."
models=.device/models

if [[ ${1:-} == prepare ]]; then
  set -e
  exclude=$(git rev-parse --git-path info/exclude)  # .device/ travels only where a call carries it
  mkdir -p "$(dirname "$exclude")"; grep -qx '/.device/' "$exclude" 2>/dev/null || echo '/.device/' >> "$exclude"
  rm -rf "$models"; mkdir -p "$models/humanoid"
  python3 - "$models/humanoid" <<'PY'
import os, sys
sys.path.insert(0, "benchmarks")
from _humanoid import humanoid_xml
out = sys.argv[1]
xml, assets = humanoid_xml()
open(os.path.join(out, "humanoid.xml"), "w").write(xml)
for name, data in assets.items():
    path = os.path.join(out, name)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    open(path, "wb").write(data)
PY
  go2=""
  if [[ -n ${MENAGERIE_ROOT:-} ]]; then
    go2=$MENAGERIE_ROOT/unitree_go2
  elif python3 -c "import mujoco_menagerie" 2>/dev/null; then
    go2=$(python3 -c "import mujoco_menagerie as m; print(m.get('unitree_go2').path(progress=None))")
  fi
  if [[ -n $go2 && -f $go2/scene_mjx.xml ]]; then
    mkdir -p "$models/unitree_go2"
    cp "$go2/scene_mjx.xml" "$go2/go2_mjx.xml" "$models/unitree_go2/"
    cp -r "$go2/assets" "$models/unitree_go2/"
  else
    echo "no Menagerie Go2 (set MENAGERIE_ROOT or pip install mujoco-menagerie): Go2 will run go2_like.xml"
  fi
  du -sh "$models"
  exit 0
fi

OUT=${OUT:-/tmp/warp-gpu}
mkdir -p "$OUT"
export PYTHONUNBUFFERED=1
t0=$SECONDS
stamp() { echo "[warp_gpu +$((SECONDS - t0))s] $*"; }

# 1. the wheels (Warp from the payload's three parts, MuJoCo 4, MuJoCo Warp, pydantic, dm-env) into /tmp/site
if [[ -d /tmp/site/warp && -d /tmp/site/mujoco_warp ]]; then
  export PYTHONPATH=/tmp/site:$PWD
else
  stamp "installing the wheels"
  # shellcheck disable=SC1091
  source .device/c/install.sh || { echo "install failed: run the payload's calls 1 and 2 first"; exit 1; }
fi
python3 -c "import mujoco, warp, mujoco_warp; print('mujoco', mujoco.__version__, 'warp', warp.__version__)" || exit 1
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader

go2=$models/unitree_go2/scene_mjx.xml
humanoid=$models/humanoid/humanoid.xml
args=()
if [[ -f $go2 ]]; then args+=(--model-go2 "$go2"); else stamp "no $go2: Go2 is tests/models/go2_like.xml"; fi
if [[ -f $humanoid ]]; then args+=(--model-humanoid "$humanoid"); else
  stamp "no $humanoid (run 'bash benchmarks/warp_gpu.sh prepare' here first): humanoid left out"
  args+=(--models go2)
fi

# 2. the kernel cache: each model's first mjw.step compiles MuJoCo Warp's kernels (about 2 minutes for the
#    first on a bare H100); what this leaves uncompiled, the benchmark's untimed warm-up steps compile
stamp "warming the kernel cache"
timeout 150 python3 benchmarks/warp.py --device cuda:0 --worlds 16 --steps 1 --pairs 1 "${args[@]}" \
  > "$OUT/warm.txt" 2>&1 || stamp "warm-up failed or ran out (rc $?)"
tail -12 "$OUT/warm.txt"

# 3. the benchmark
stamp "benchmark"
timeout 250 python3 benchmarks/warp.py --device cuda:0 --worlds 1024,4096,16384 --steps 80 --pairs 3 \
  "${args[@]}" --json "$OUT/warp.json" 2>&1 | tee "$OUT/warp.txt"
stamp "benchmark rc ${PIPESTATUS[0]}"

# 4. CUDA against CPU: the same keys give the same numbers, the sensor layer the same reads
stamp "CUDA tests"
MUJOCO_GL=egl PYTHONHASHSEED=0 timeout 120 python3 -m pytest -q -p no:cacheprovider tests/warp/test_warp_cuda.py \
  2>&1 | tee "$OUT/cuda_tests.txt"
stamp "done"
