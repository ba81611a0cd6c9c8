#!/usr/bin/env bash
# The GPU checks of one session on a lent device machine (tools: device), in priority order, each
# under its own time limit so that a slow one cannot eat the others' time. JSON lines to $OUT.
#
#   bash experiments/gpu_session.sh          # on the device machine (JAX with CUDA, no install:
#                                            # rockjax from src/, trimesh from carried wheels)
#   GPU_SMALL=1 OUT=/tmp/out bash experiments/gpu_session.sh   # a dry run of the same on the CPU
#
# 1. where a step's device time goes (gpu_profile: a jax.profiler trace summed per HLO instruction
#    and per rockjax source line), WCSPH and DFSPH at 1M: the profile the single-GPU targets ask for;
#    with the compiled modules (hlo_*.txt.gz) to read the kernels no rockjax frame names (2026-11-30:
#    36 memcpy32_post copies per step, 1.05 of the WCSPH step's 4.33 ms); then the same of the
#    forward and the checkpointed gradient of bench_grad's dam scene at 23k water (issue 47: the
#    gradient <= 4.5 forwards; 7.3 with row gathers on 2026-11-28: where the rest goes), under
#    AUTODIFF (JAX transposes the gathers: scatter-adds) and PAIR_SUMS with its reverse pass in one
#    block (gathers over the symmetric list; never measured on a GPU in one block);
# 2. the coupled wedge at >= 1M water particles (bench_coupled --dx 0.0065: 1.0M water, 0.4M wall):
#    the blocks + coupling share, whose target is stated at that size (35k measured 2026-11-28: 33 %);
# 3. fluid-only throughput and device memory, 3D dam break, 80k -> 1M, WCSPH (compare_peers
#    --scaling; DFSPH beside it measured 2026-11-30), and at 1M in float64 (issue 47: >= 120 M).
# Earlier sessions' checks (the gather forms, the adjoints, the gradient ratio: 2026-11-27/-28,
# RESULTS "On a GPU") are unchanged by the code since and not repeated.
# Limits sum to 570 s: with a machine's start (~1 min) one call fits a 15-min session.
set -u
OUT=${OUT:?set OUT}
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
PY=${PY:-python3}
if [ -n "${GPU_SMALL:-}" ]; then
  SIZES="5k"; PSIZE=5k; CDX=0.05; GDX=0.05; T0=300; T1=300; T2=300; T3=300
else
  SIZES="80k 300k 1M"; PSIZE=1M; CDX=0.0065; GDX=0.0125; T0=200; T1=210; T2=100; T3=60
fi
if [ -d .whl ] && [ -z "${GPU_SMALL:-}" ]; then  # trimesh (pure Python) is not in the device image
  $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl \
    && export PYTHONPATH=$PYTHONPATH:/tmp/site
fi
(nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv 2>/dev/null || true) | tee $OUT/env.txt
$PY -c "import jax, sys; print('jax', jax.__version__, jax.devices(), sys.version.split()[0])" 2>&1 | tee -a $OUT/env.txt
git log -1 --format='commit %h %cd' 2>/dev/null | tee -a $OUT/env.txt
run() {  # name limit cmd...
  local name=$1 limit=$2; shift 2
  local t0=$SECONDS
  timeout $limit "$@" > $OUT/$name.jsonl 2> /tmp/gpu_session_$name.err
  echo "## $name rc=$? ${limit}s-limit took $((SECONDS - t0))s" | tee -a $OUT/env.txt
  { echo "## $name"; tail -c 3000 /tmp/gpu_session_$name.err; } | tee -a $OUT/errors.txt | tail -c 800
}
run profile $T0 bash -c "$PY experiments/gpu_profile.py --size $PSIZE --scheme wcsph dfsph --top 30 \
  --hlo-out '$OUT/hlo_{scheme}.txt.gz'; $PY experiments/gpu_profile.py --grad $GDX --grad-adjoint autodiff pair_sums --top 30"
run coupled $T1 $PY experiments/bench_coupled.py --dx $CDX --reps 5
run scaling $T2 $PY experiments/compare_peers.py --scaling --sizes $SIZES --schemes wcsph --reps 3
run scaling64 $T3 env JAX_ENABLE_X64=1 $PY experiments/compare_peers.py --scaling --sizes $PSIZE --schemes wcsph --reps 3
# at most 8 files come back from the device: env.txt, errors.txt, these four .jsonl and two hlo_*.txt.gz
