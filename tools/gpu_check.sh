#!/usr/bin/env bash
# The first run on a CUDA machine (none here: the CUDA paths are kept right by reading and by the CPU tests).
#
#   bash tools/gpu_check.sh [cuda:0]
#
# 1. the simulator and task tests (tests/cra_warp/sim/, tests/envs/test_locomotion.py) on the device (CRA_TEST_DEVICE; the
#    MuJoCo C rows stay on the CPU), 2. cra-train for 50 iterations at N=4096 on flat and on rough ground,
# 3. cra-bench of the Newton world and the full task at N=1024 and 4096 (tools/results/bench_cuda.json).
# Logs go to runs/gpu_check/; a summary is printed at the end. Exit 1 if any step failed, 2 if there is no device.
set -uo pipefail
cd "$(dirname "$0")/.."
dev=${1:-cuda:0}
out=runs/gpu_check
mkdir -p "$out"
bash tools/setup.sh || exit 1
py=.venv/bin/python
# PyPI's torch wheel for Linux is a CUDA build; the CPU-only file this project's CPU machine installs is not.
"$py" -c "import sys, torch; sys.exit(0 if torch.cuda.is_available() else 2)" || {
  echo "gpu_check: torch sees no CUDA device (a CPU-only torch build, or no driver)" >&2; exit 2; }

summary=()
failed=0
run_step() {  # name, command...: its output goes to $out/<name>.log
  local name=$1; shift
  echo "+ $*"
  if "$@" > "$out/$name.log" 2>&1; then summary+=("$name: ok")
  else failed=1; summary+=("$name: FAILED (see $out/$name.log)"); fi
}

run_step tests env CRA_TEST_DEVICE="$dev" "$py" -m pytest -q tests/cra_warp/sim tests/envs/test_locomotion.py
for task in flat rough; do
  run_step "train_$task" .venv/bin/cra-train --device "$dev" --num-envs 4096 --task "$task" --max-iterations 50 \
    --save-interval 50 --log-dir "$out" --no-export
done
run_step bench .venv/bin/cra-bench --device "$dev" --num-envs 1024 4096 --engines newton task --parallel 1 \
  --terrain flat rough --no-cold --json tools/results/bench_cuda.json

echo
echo "== gpu_check on $dev"
"$py" -c "import torch; print(torch.cuda.get_device_name('$dev'))"
printf '%s\n' "${summary[@]}"
tail -n 1 "$out/tests.log"
for task in flat rough; do
  echo "train_$task, first and last iteration:"
  grep -E "^it [0-9]+/" "$out/train_$task.log" | sed -n '1p;$p'
done
grep -E "^  (newton|task) " "$out/bench.log"
exit $failed
