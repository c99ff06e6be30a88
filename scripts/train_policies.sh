#!/usr/bin/env bash
# Retrains the six shipped learned policies from scratch, every run of each one's lineage oldest
# first, and ships them: each run goes to $ROOT/<its name in runs/> and stops at the checkpoint
# its child reads (`--iterations K+1` writes model_K.pt); the last run of a policy stops at the
# shipped checkpoint, which is then scored as the model cards are (`selfright evaluate`, 256
# episodes per cell, seed 1000, into $ROOT/eval/NAME) and shipped (`selfright ship`).
#
#   bash scripts/train_policies.sh flat-teacher|flat|rough-teacher|rough|incline-teacher|incline|all
#
# A policy's stage trains what it needs of its lineage (`flat` also trains the flat teacher,
# but ships only `flat`); `all` ships the six. Rerun to resume: a run that holds its checkpoint
# is skipped, a run with an earlier one goes on from its latest (`--resume`, `--init-from`
# dropped). Each run's output is appended to its train.log.
#
# Environment:
#   ROOT=runs/retrain      where the runs and evaluations go
#   EXTRA="..."            appended to every `selfright train` (the last value of a flag wins),
#                          e.g. EXTRA="--device cuda --physics-threads 8" on a GPU machine
#   DEST=DIR               ship into DIR instead of the package's checkpoints folder
#   SELFRIGHT_DRY_RUN=1    print the commands the stage would run from the runs already under
#                          ROOT (each printed run counted as done), run nothing
#
# What each run took when it was recorded (env steps and wall-clock to the checkpoint used;
# "2 cores" machines are cloud VMs):
#
#   run (ROOT/...)                   to model_K   env steps   wall-clock  machine
#   flat_teacher_v1_scratch                1805       11.1 M      0.59 h  Intel Xeon, 2 cores, 2 physics threads
#   flat_student_v1                        1003        6.2 M      0.19 h  Intel Xeon, 2 cores, 2 physics threads
#   rough_scratch                          2216        6.8 M      0.86 h  x86-64, 2 cores, 1 physics thread
#   rough_dc_teacher                      15832       48.6 M      2.85 h  Intel Xeon, 2 cores, 1 then 2 physics threads
#   gpu_rough_h25w                          721        4.4 M      0.17 h  Intel Xeon, 16 cores, 5 then 8 physics threads,
#                                                                          networks on an NVIDIA H200
#   incline_scratch_narrow                 1928        5.9 M      1.12 h  x86-64, 2 cores, 1 physics thread
#   incline_dc_teacher                     1173        3.6 M      0.27 h  Intel Xeon, 2 cores, 1 physics thread
#   incline_dc_teacher_e512                 395        4.9 M      0.27 h  AMD EPYC, 2 cores, 2 physics threads
#   incline_h25_sel_seed31                  479        2.9 M      0.28 h  AMD EPYC, 2 cores, 1 physics thread
#   incline_h25_sel31_479_stance03          339        2.1 M      0.18 h  AMD EPYC, 2 cores, 1 physics thread
#
#   in all, per stage: flat-teacher 11.1 M / 0.59 h, flat 17.3 M / 0.78 h, rough-teacher 55.4 M / 3.71 h,
#   rough 59.9 M / 3.88 h, incline-teacher 14.4 M / 1.66 h, incline 19.4 M / 2.11 h (all: 96.6 M / 6.8 h)
#
# Every run trains under the current benchmark version (docs/benchmark.md, *Benchmark versions*):
# of the recorded runs listed above, the flat runs trained under version 1, the others under version 0.
#
# A rerun is a draw of the recipe, not a copy of the shipped weights: physics and episode draws
# depend on thread counts and machine, and a PPO run from scratch can take off later than the
# recorded one. Where a run's validation (its validation.csv) stays well under the recorded one,
# train it further (--resume --iterations N) and point its child at the checkpoint that
# validates as well. The runs recorded with MuJoCo's softer joint stops train with them
# (--joint-stop-timeconst-s 0.02).
set -euo pipefail
cd "$(dirname "$0")/.."
usage="usage: bash scripts/train_policies.sh flat-teacher|flat|rough-teacher|rough|incline-teacher|incline|all"
ROOT=${ROOT:-runs/retrain}
EXTRA=${EXTRA:-}
DRY=${SELFRIGHT_DRY_RUN:-0}
declare -A dry_last=()  # with SELFRIGHT_DRY_RUN: the checkpoint each printed step would have written

# run COMMAND...: run it, or print it with SELFRIGHT_DRY_RUN=1.
run() {
  if [ "$DRY" = 1 ]; then
    printf '%q ' "$@" | sed 's/ $//'
    echo
  else
    "$@"
  fi
}

# last_it DIR: the iteration of DIR's newest model_K.pt (-1: none).
last_it() {
  local k=${dry_last[$1]:--1} f n
  for f in "$1"/model_*.pt; do
    [ -e "$f" ] || continue
    n=${f##*/model_}
    n=${n%.pt}
    case $n in *[!0-9]*) continue ;; esac
    [ "$n" -gt "$k" ] && k=$n
  done
  echo "$k"
}

# step NAME STOP ARGS...: `selfright train --out ROOT/NAME --iterations STOP ARGS` unless the run
# holds model_{STOP-1}.pt or a later checkpoint; a run with an earlier one goes on from it.
step() {
  local dir=$ROOT/$1 stop=$2 last a skip=0 args=()
  shift 2
  last=$(last_it "$dir")
  if [ "$last" -ge $((stop - 1)) ]; then
    echo "== $dir: model_$last.pt is there, skipped" >&2
    return
  fi
  for a in "$@"; do
    if [ "$skip" = 1 ]; then skip=0; continue; fi
    if [ "$last" -ge 0 ] && [ "$a" = --init-from ]; then skip=1; continue; fi
    args+=("$a")
  done
  [ "$last" -ge 0 ] && args+=(--resume)
  echo "== $dir: to model_$((stop - 1)).pt" >&2
  if [ "$DRY" = 1 ]; then
    # shellcheck disable=SC2086
    run selfright train --out "$dir" --iterations "$stop" "${args[@]}" $EXTRA
    dry_last[$dir]=$((stop - 1))
  else
    mkdir -p "$dir"
    # shellcheck disable=SC2086
    selfright train --out "$dir" --iterations "$stop" "${args[@]}" $EXTRA >> "$dir/train.log" 2>&1
  fi
}

# publish NAME CHECKPOINT CONTEXT [EVALUATE FLAGS...]: score the checkpoint as its model card
# does (256 episodes per cell on fresh falls, seed 1000) and ship it as NAME.
publish() {
  local name=$1 ckpt=$2 context=$3 dest=()
  shift 3
  [ -n "${DEST:-}" ] && dest=(--dest "$DEST")
  run selfright evaluate --policy "$ckpt" --grid "$context" --episodes 256 --seed 1000 --out "$ROOT/eval/$name" \
    --no-progress "$@"
  run selfright ship --run "$ckpt" --name "$name" --evaluation "$ROOT/eval/$name" "${dest[@]}"
}

# MuJoCo's softer joint stops, which the rough and incline runs from scratch trained with (the
# benchmark's are 0.01 s).
SOFT_STOPS=(--joint-stop-timeconst-s 0.02)
# The ideal servos (full torque at any speed), which the rough and incline runs from scratch
# trained with (the benchmark's motors are the A1's DC motors, `dcmotor`).
IDEAL=(--motor ideal)

flat_teacher() {
  # `flat-teacher`: PPO from scratch under the benchmark's DC motors and joint stops; training
  # episodes end as terminal after 1 s upright on three or four feet under the goal bar (a
  # leaky count).
  step flat_teacher_v1_scratch 1806 --role teacher --context flat --envs 256 --physics-threads 2 --seed 1 \
    --action-reference tall --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky \
    --train.validation.episodes 64 --train.checkpoint-every-s 300 --train.keep-checkpoints 2
}

flat() {
  flat_teacher
  # `flat`: plain distillation of the flat teacher.
  step flat_student_v1 1004 --role student --context flat --teacher "$ROOT/flat_teacher_v1_scratch/model_1805.pt" \
    --envs 256 --physics-threads 2 --seed 1 --action-reference tall --train.validation.episodes 64 \
    --train.checkpoint-every-s 300 --train.keep-checkpoints 2
}

rough_teacher() {
  # PPO from scratch on rough ground with the roughness curriculum, ideal servos.
  step rough_scratch 2217 --role teacher --context rough --envs 128 --physics-threads 1 "${SOFT_STOPS[@]}" "${IDEAL[@]}" \
    --action-reference tall --train.randomization.friction 0.6 1.2 --train.reward.target-height-m 0.38 \
    --train.episode.curriculum --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky \
    --train.validation.episodes 64 --train.checkpoint-every-s 240 --train.keep-checkpoints 0
  # `rough-teacher`: PPO fine-tune under DC motors, no curriculum.
  step rough_dc_teacher 15833 --role teacher --context rough --init-from "$ROOT/rough_scratch/model_2216.pt" \
    --motor dcmotor --action-reference tall --envs 128 --physics-threads 2 --train.randomization.friction 0.6 1.2 \
    --train.reward.target-height-m 0.38 --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky \
    --train.validation.episodes 64 --train.checkpoint-every-s 240 --train.keep-checkpoints 0
}

rough() {
  rough_teacher
  # `rough`: 25 frames, 512-256-128 units, DC motors (recorded with networks on a GPU:
  # EXTRA="--device cuda --physics-threads 8"; 2 CPU cores train it as well).
  step gpu_rough_h25w 722 --role student --context rough --teacher "$ROOT/rough_dc_teacher/model_15832.pt" \
    --motor dcmotor --action-reference tall --envs 256 --physics-threads 2 --torch-threads 1 \
    --train.randomization.friction 0.6 1.2 --train.distillation.student-history 25 \
    --train.policy.hidden-dims 512 256 128 --train.validation.episodes 64 --train.checkpoint-every-s 300 \
    --train.keep-checkpoints 0
}

incline_teacher() {
  # PPO from scratch with the slope curriculum 5 -> 20 deg, ideal servos.
  step incline_scratch_narrow 1929 --role teacher --context incline --envs 128 --physics-threads 1 "${SOFT_STOPS[@]}" "${IDEAL[@]}" \
    --action-reference tall --train.randomization.friction 0.6 1.2 --train.reward.target-height-m 0.37 \
    --train.episode.curriculum --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky \
    --train.validation.episodes 64 --train.checkpoint-every-s 240 --train.keep-checkpoints 0
  # PPO fine-tune under DC motors on the 20 deg slope.
  step incline_dc_teacher 1174 --role teacher --context incline --init-from "$ROOT/incline_scratch_narrow/model_1928.pt" \
    --motor dcmotor --action-reference tall --envs 128 --physics-threads 1 --train.randomization.friction 0.6 1.2 \
    --train.reward.target-height-m 0.37 --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky \
    --train.validation.episodes 64 --train.checkpoint-every-s 240 --train.keep-checkpoints 0
  # `incline-teacher`: the same at 512 envs and half the KL target.
  step incline_dc_teacher_e512 396 --role teacher --context incline --init-from "$ROOT/incline_dc_teacher/model_1173.pt" \
    --motor dcmotor --action-reference tall --envs 512 --physics-threads 2 --train.randomization.friction 0.6 1.2 \
    --train.reward.target-height-m 0.37 --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky \
    --train.ppo.desired-kl 0.005 --train.validation.episodes 128 --train.checkpoint-every-s 480 \
    --train.keep-checkpoints 0
}

incline() {
  incline_teacher
  # The distillation, 25 frames; model_479 was chosen on evaluation seeds 4-11 among its
  # checkpoints from 130 on (scripts/select_checkpoints.py). This run and the next were recorded
  # with an approximation of the DC motors (the ideal servos with each control step's targets
  # held to the DC motors' torque-speed limit, recorded as motor "envelope"); they train here
  # with the DC motors themselves.
  step incline_h25_sel_seed31 480 --role student --context incline --teacher "$ROOT/incline_dc_teacher_e512/model_395.pt" \
    --seed 31 --motor dcmotor --action-reference tall --envs 256 --physics-threads 1 --torch-threads 1 \
    --train.randomization.friction 0.6 1.2 --train.distillation.student-history 25 --train.validation.episodes 64 \
    --train.checkpoint-every-s 120 --train.keep-checkpoints 0
  # `incline`: that student's labels moved 30 % of the way to the tall stance over 1 s after 1 s
  # upright within 35 deg.
  step incline_h25_sel31_479_stance03 340 --role student --context incline \
    --teacher "$ROOT/incline_h25_sel_seed31/model_479.pt" --seed 31 --motor dcmotor --action-reference tall \
    --envs 256 --physics-threads 1 --torch-threads 1 --train.randomization.friction 0.6 1.2 \
    --train.distillation.stance-ramp-s 1.0 --train.distillation.stance-delay-s 1.0 \
    --train.distillation.stance-tilt-deg 35 --train.distillation.stance-weight 0.3 --train.validation.episodes 64 \
    --train.checkpoint-every-s 60 --train.keep-checkpoints 0
}

ship_flat_teacher() { flat_teacher; publish flat-teacher "$ROOT/flat_teacher_v1_scratch/model_1805.pt" flat; }
ship_flat() { flat; publish flat "$ROOT/flat_student_v1/model_1003.pt" flat; }
ship_rough_teacher() { rough_teacher; publish rough-teacher "$ROOT/rough_dc_teacher/model_15832.pt" rough; }
ship_rough() { rough; publish rough "$ROOT/gpu_rough_h25w/model_721.pt" rough; }
ship_incline_teacher() {
  incline_teacher
  publish incline-teacher "$ROOT/incline_dc_teacher_e512/model_395.pt" incline
}
ship_incline() { incline; publish incline "$ROOT/incline_h25_sel31_479_stance03/model_339.pt" incline; }

case ${1:-} in
  flat-teacher) ship_flat_teacher ;;
  flat) ship_flat ;;
  rough-teacher) ship_rough_teacher ;;
  rough) ship_rough ;;
  incline-teacher) ship_incline_teacher ;;
  incline) ship_incline ;;
  all)
    ship_flat_teacher
    ship_flat
    ship_rough_teacher
    ship_rough
    ship_incline_teacher
    ship_incline
    ;;
  *)
    echo "$usage" >&2
    exit 2
    ;;
esac
