#!/usr/bin/env bash
# Continue (or start) a training run on the lent GPU machine for at most LIMIT seconds, then
# stop it cleanly (SIGTERM -> checkpoint) and pack what is needed to resume and judge it
# (checkpoints, model_best.pt, validation.csv, train_meta.json, train.log, tensorboard files;
# not the per-checkpoint validation folders) into $OUT/<run name>.tgz.
#
# Usage (after installing the wheels, see ../shared/device.md; several runs may share the
# machine side by side, e.g. two with PHYS=7):
#   bash scripts/device_train.sh RUN_DIR ROLE CONTEXT [extra `selfright train` flags...]
# A new run starts with INIT's weights if INIT is set (--init-from), or from scratch; an
# existing run (RUN_DIR holds model_*.pt) resumes and the extra flags must repeat the run's own.
# Env: LIMIT (s, default 540), ENVS (default 512), PHYS (physics threads, default 14),
#      DEVICE (torch device of the networks, default cuda), ITERATIONS (default 100000),
#      TEACHER (teacher run or checkpoint, for ROLE=student).
# Back here: tar xzf <run name>.tgz -C runs/ and resume (here or on the next lease).
set -uo pipefail
run=$1; role=$2; context=$3; shift 3
export PYTHONUNBUFFERED=1  # no MUJOCO_GL=egl: mujoco 4 then fails to import without an EGL driver
mkdir -p "$run"
start=()
if ls "$run"/model_[0-9]*.pt > /dev/null 2>&1; then
  start=(--resume)
elif [ -n "${INIT:-}" ]; then
  start=(--init-from "$INIT")
fi
[ -n "${TEACHER:-}" ] && start+=(--teacher "$TEACHER")
timeout -s TERM -k 60 "${LIMIT:-540}" python3 -m selfright.cli train --role "$role" --context "$context" \
  --out "$run" --envs "${ENVS:-512}" --iterations "${ITERATIONS:-100000}" --physics-threads "${PHYS:-14}" \
  --torch-threads 1 --device "${DEVICE:-cuda}" "${start[@]}" "$@" >> "$run/train.log" 2>&1
echo "== $run: exit $?"
grep -v "^\[" "$run/train.log" | tail -5
tail -2 "$run/train.log"
[ -f "$run/validation.csv" ] && cat "$run/validation.csv"
tar czf "$OUT/$(basename "$run").tgz" --exclude=validation -C "$(dirname "$run")" "$(basename "$run")"
