#!/usr/bin/env bash
# The paper's ODN_l (Table 1 row: test 19.3 / 30.1 / 8.3 / 18.2, All 19.0) trained with its recipe
# and scored on the official sets: 5,000 iterations of 512 freshly generated examples (standard
# preset, n = 10, no radial image), Adam at 1e-3, L1 on the relative scale, validation every 10
# iterations on the four official val sets (best.pt: lowest mean of their mean percent errors).
#
#   benchmarks/reproduce_odn.sh [SOURCE] [WORK]
#
# SOURCE: the release archive odms-v1.tar.gz (default ../shared/data/odms-v1.tar.gz from the
# project root) or the release's data/ folder (a clone of griffbr/ODMS); WORK: where the stores,
# the run and the predictions go (default /tmp/odms-reproduce; about 1 GB). Made for a host with
# one GPU and 16 cores (WORKERS, default all cores, make the stream); rerunning it resumes an
# interrupted run and skips the steps already done. Set MODEL=odn-dbar|odn-d, RADIAL=--radial,
# SEED=... for the other rows. Run from the project root after `pip install -e '.[dev]'` (a
# CUDA build of torch for the GPU).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source=${1:-$root/../shared/data/odms-v1.tar.gz}
work=${2:-/tmp/odms-reproduce}
workers=${WORKERS:-$(nproc)}
model=${MODEL:-odn-l}
radial=${RADIAL:-}
seed=${SEED:-1}
run=$work/runs/$model${radial:+-radial}-seed$seed
mkdir -p "$work"

if [ -f "$source" ]; then
    if [ ! -d "$work/release/data" ]; then
        mkdir -p "$work/release" && tar -xzf "$source" -C "$work/release"
    fi
    data=$work/release/data
else
    data=$source
fi
if [ ! -f "$work/stores/perturb-test.zarr/zarr.json" ]; then
    odms-data import odms "$data" -o "$work/stores" --workers "$workers" --overwrite
fi

val=()
for domain in robot driving normal perturb; do val+=(--val "$work/stores/$domain-val.zarr"); done
python -c "import torch; print('torch', torch.__version__, 'cuda' if torch.cuda.is_available() else 'NO GPU: CPU only')"
time odms-data train --model "$model" $radial -o "$run" "${val[@]}" --iterations 5000 --batch-size 512 \
    --val-every 10 --seed "$seed" --workers "$workers"

odms-data predict "$run" --data "$work/stores" -o "$run/predictions.csv" --workers "$workers" --overwrite
odms-data score "$run/predictions.csv" --data "$work/stores" --markdown --plot "$run/errors.png" \
    --name "$model${radial:+ radial} (odms-data, seed $seed)" --n-obs 10 --entry "$run/leaderboard-entry.json"
echo "curves: $run/curves.png; entry: $run/leaderboard-entry.json (set training_data and radial_input," \
     "then copy it into leaderboard/)"
