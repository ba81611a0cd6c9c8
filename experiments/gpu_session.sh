#!/usr/bin/env bash
# The GPU checks of one session on a lent device machine (tools: device), in priority order, each
# under its own time limit so that a slow one cannot eat the others' time. JSON lines to $OUT.
#
#   bash experiments/gpu_session.sh          # on the device machine (JAX with CUDA, no install:
#                                            # rockjax from src/, trimesh from carried wheels)
#   GPU_SMALL=1 OUT=/tmp/out bash experiments/gpu_session.sh   # a dry run of the same on the CPU
#
# 1. where a WCSPH step's time goes at 80k (bench_sph): gather form components vs rows (GatherForm),
#    (512-row blocks, measured 2026-11-27 and -28: 3.4x slower than one block, no longer run);
# 2. fluid-only throughput and device memory, 3D dam break, 20k -> 1M fluid (compare_peers --scaling);
# 3. the gradient under both adjoints and both gather forms (DESIGN: the reverse mode of 1-D
#    gathers was measured 8x slower than of row gathers on a GPU; 2026-11-28: 2.6x), and PAIR_SUMS with
#    its backward in one block (its 512-row blocks are a sequential scan there: 20 forwards, 2026-11-28);
# 4. coupled wedge step: the blocks + coupling share;
# 5. gradient ratio and XLA temp bytes at T and 4T steps, ensembles 1/64 (2026-11-28: its compiles,
#    18 s and 32 s for the two gradients, outran a 60 s limit before the ensembles).
# Limits sum to 570 s: with a machine's start (~1 min) one call fits a 15-min session with room.
set -u
OUT=${OUT:?set OUT}
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
PY=${PY:-python3}
if [ -n "${GPU_SMALL:-}" ]; then
  SIZES="5k"; SPH=5k; GDX=0.1; BATCH="1 8"; CDX=0.05; T0=300; T1=300; T2=300; T3=300; T4=300
else
  SIZES="20k 80k 300k 1M"; SPH=80k; GDX=0.0125; BATCH="1 64"; CDX="0.02"; T0=55; T1=90; T2=220; T3=150; T4=55
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
run sph $T0 bash -c "$PY experiments/bench_sph.py --sizes $SPH --schemes wcsph --reps 3 --gather components --tag gpu;
  $PY experiments/bench_sph.py --sizes $SPH --schemes wcsph --reps 3 --gather rows --tag gpu"
run scaling $T1 $PY experiments/compare_peers.py --scaling --sizes $SIZES --schemes wcsph --reps 3
run adjoint $T2 bash -c "$PY experiments/bench_grad.py --scene dam --dx $GDX --adjoint-ab --ab-tiles 0 --repeats 3;
  $PY experiments/bench_grad.py --scene dam --dx $GDX --adjoint-ab --ab-tiles 0 --repeats 3 --gather rows;
  $PY experiments/bench_grad.py --scene dam --dx $GDX --adjoint pair_sums --multiples 1 --skip-ensemble --repeats 3 --gather rows --backward-tile 0"
run coupled $T4 $PY experiments/bench_coupled.py --dx $CDX --reps 10
run grad $T3 $PY experiments/bench_grad.py --scene dam --dx $GDX --multiples 1 4 --batches $BATCH --repeats 3
# at most 8 files come back from the device: env.txt, errors.txt and these five .jsonl
