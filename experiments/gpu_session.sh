#!/usr/bin/env bash
# The GPU checks of one session on a lent device machine (tools: device), in priority order, each
# under its own time limit so that a slow one cannot eat the others' time. JSON lines to $OUT.
#
#   bash experiments/gpu_session.sh          # on the device machine (JAX with CUDA, no install:
#                                            # rockjax from src/, trimesh from carried wheels)
#   GPU_SMALL=1 OUT=/tmp/out bash experiments/gpu_session.sh   # a dry run of the same on the CPU
#
# 1. fluid-only throughput and device memory, 3D dam break, 20k -> 1M fluid (compare_peers --scaling);
# 2. gradient: backward/forward ratio and XLA temp bytes, T and 4T steps, and ensembles 1/8/64;
# 3. the two adjoints (AUTODIFF, PAIR_SUMS) side by side (the gather form matters on GPUs, DESIGN);
# 4. coupled wedge step: the blocks + coupling share.
set -u
OUT=${OUT:?set OUT}
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
PY=${PY:-python3}
if [ -n "${GPU_SMALL:-}" ]; then
  SIZES="5k"; GDX=0.05; BATCH="1 8"; CDX=0.05; T1=300; T2=300; T3=300; T4=300
else
  SIZES="20k 80k 300k 1M"; GDX=0.0125; BATCH="1 8 64"; CDX="0.02"; T1=130; T2=150; T3=100; T4=90
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
  timeout $limit "$@" > $OUT/$name.jsonl 2> $OUT/$name.err
  echo "## $name rc=$? ${limit}s-limit took $((SECONDS - t0))s" | tee -a $OUT/env.txt
  tail -c 1500 $OUT/$name.err
}
run scaling $T1 $PY experiments/compare_peers.py --scaling --sizes $SIZES --schemes wcsph --reps 3
run grad $T2 $PY experiments/bench_grad.py --scene dam --dx $GDX --multiples 1 4 --batches $BATCH --repeats 3
run adjoint $T3 $PY experiments/bench_grad.py --scene dam --dx $GDX --adjoint-ab --ab-tiles 0 --repeats 3
run coupled $T4 $PY experiments/bench_coupled.py --dx $CDX --reps 10
