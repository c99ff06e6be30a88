#!/usr/bin/env bash
# Continue (or start) a training run on the lent GPU machine's 16 CPU cores for at most
# LIMIT seconds, then stop it cleanly (SIGTERM -> checkpoint) and put what is needed to
# resume it under $OUT (latest checkpoint, train_meta.json, train.log, newest tensorboard file).
#
# Device `run` call (carry [".whl", "runs/NAME"]; see ../shared/device.md):
#   bash scripts/device_train.sh runs/flat_teacher_best teacher flat   # continue the shipped flat teacher
#   TEACHER=runs/flat_teacher_best bash scripts/device_train.sh runs/flat_student student flat
# Back here: copy the returned files into runs/NAME/ and resume (here or on the next lease).
# Env: LIMIT (s, default 540), ENVS (default 512), ITERATIONS (default 100000).
set -uo pipefail
run=$1; role=$2; context=$3
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target .site .whl/*.whl \
  && export PYTHONPATH=$PWD/.site:$PWD/src || exit 1
export PYTHONUNBUFFERED=1 MUJOCO_GL=egl
mkdir -p "$run"
resume=()
ls "$run"/model_*.pt > /dev/null 2>&1 && resume=(--resume)
teacher=()
[ -n "${TEACHER:-}" ] && teacher=(--teacher "$TEACHER")
timeout -s TERM -k 60 "${LIMIT:-540}" python3 -m selfright.cli train --role "$role" --context "$context" \
  --out "$run" --envs "${ENVS:-512}" --iterations "${ITERATIONS:-100000}" --physics-threads 16 --torch-threads 4 \
  "${resume[@]}" "${teacher[@]}" 2>&1 | tee -a "$run/train.log" | grep -v "^\[" | tail -20
tail -3 "$run/train.log"
latest=$(ls -v "$run"/model_*.pt | tail -1)
cp "$latest" "$run/train_meta.json" "$run/train.log" "$OUT/"
cp "$(ls -t "$run"/events.out.tfevents.* | head -1)" "$OUT/"
ls -la "$OUT"
