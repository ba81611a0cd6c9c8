#!/usr/bin/env bash
# Follow-up device checks of the wall sums (Tuning.wall_sums): the sums alone on the real 1M list
# (wall_sums_ab), the WCSPH step's profile under both forms (gpu_profile --wall-sums), fluid-only
# throughput with the accelerator default (compare_peers --scaling), the coupled wedge at 1M water.
#   bash experiments/gpu_wall_sums.sh                          # on the device machine
#   GPU_SMALL=1 OUT=/tmp/out bash experiments/gpu_wall_sums.sh  # a dry run on the CPU
set -u
OUT=${OUT:?set OUT}
export PYTHONPATH=$PWD/src${PYTHONPATH:+:$PYTHONPATH} PYTHONUNBUFFERED=1
PY=${PY:-python3}
if [ -n "${GPU_SMALL:-}" ]; then
  SIZES="5k"; PSIZE=5k; CDX=0.05
else
  SIZES="80k 300k 1M"; PSIZE=1M; CDX=0.0065
fi
if [ -d .whl ] && [ -z "${GPU_SMALL:-}" ]; then
  $PY -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl \
    && export PYTHONPATH=$PYTHONPATH:/tmp/site
fi
git log -1 --format='commit %h %cd' 2>/dev/null | tee $OUT/env.txt
run() {  # name limit cmd...
  local name=$1 limit=$2; shift 2
  local t0=$SECONDS
  timeout $limit "$@" > $OUT/$name.jsonl 2> /tmp/gpu_$name.err
  echo "## $name rc=$? ${limit}s-limit took $((SECONDS - t0))s" | tee -a $OUT/env.txt
  { echo "## $name"; tail -c 2000 /tmp/gpu_$name.err; } | tee -a $OUT/errors.txt | tail -c 400
}
run wall_sums 70 $PY experiments/wall_sums_ab.py --size $PSIZE --reps 20
run profile 90 $PY experiments/gpu_profile.py --size $PSIZE --scheme wcsph --wall-sums scatter ranges --top 20
run scaling 90 $PY experiments/compare_peers.py --scaling --sizes $SIZES --schemes wcsph --reps 3
run coupled 110 $PY experiments/bench_coupled.py --dx $CDX --reps 5
