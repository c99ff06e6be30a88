#!/usr/bin/env bash
# Train on a rented GPU machine in time-limited sessions: continue (or start) a run for at most
# LIMIT seconds, stop it cleanly (SIGTERM writes a checkpoint) and pack what is needed to resume
# and judge it (checkpoints, model_best.pt, validation.csv, train_meta.json, train.log,
# tensorboard files; not the per-checkpoint validation folders) into $OUT/<run name>.tgz.
#
#   bash scripts/device_train.sh RUN_DIR ROLE CONTEXT [more `selfright train` flags...]
#
# e.g. the `rough` student (scripts/train_policies.sh) with its networks on the GPU:
#   TEACHER=runs/rough_teacher_v1/model_3246.pt PHYS=8 ITERATIONS=333 ENVS=256 \
#     bash scripts/device_train.sh runs/rough_student_gpu student rough --seed 1 --action-reference tall \
#     --train.distillation.student-history 25 --train.policy.hidden-dims 512 256 128
#
# A new run starts with INIT's weights if INIT is set (--init-from), or from scratch; an
# existing run (RUN_DIR holds model_*.pt) resumes and the extra flags must repeat the run's own.
# Several runs may share the machine side by side (e.g. two with PHYS=7).
# Env: LIMIT (s, default 540), ENVS (default 512), PHYS (physics threads, default 14),
#      DEVICE (torch device of the networks, default cuda), ITERATIONS (default 100000),
#      TEACHER (teacher run or checkpoint, for ROLE=student), OUT (where the archive goes, default .).
# Back on the machine the run continues on: tar xzf <run name>.tgz -C runs/ and resume.
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
tar czf "${OUT:-.}/$(basename "$run").tgz" --exclude=validation -C "$(dirname "$run")" "$(basename "$run")"
