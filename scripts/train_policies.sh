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
#   rough_teacher_v1                       3246       19.9 M      1.10 h  Intel Xeon then AMD EPYC, 2 cores, 2 physics threads
#   rough_student_v1                        332        2.0 M      0.26 h  AMD EPYC, 2 cores, 1 physics thread
#   incline_teacher_v1                     1638       10.1 M      0.93 h  Intel Xeon, 2 cores, 2 then 1 then 2 physics threads
#   incline_teacher_v1_goal                 842        5.2 M      0.59 h  AMD EPYC, 2 cores, 1 physics thread
#   incline_student_v1                      373        2.3 M      0.25 h  AMD EPYC, 2 cores, 1 physics thread
#
#   in all, per stage (the flat teacher counted in each): flat-teacher 11.1 M / 0.59 h, flat 17.3 M / 0.78 h,
#   rough-teacher 31.0 M / 1.69 h, rough 33.0 M / 1.95 h, incline-teacher 26.4 M / 2.11 h,
#   incline 28.7 M / 2.36 h (all: 56.8 M / 3.91 h)
#
# Every run trains under the current benchmark version (docs/benchmark.md, *Benchmark versions*),
# as every recorded run above did (version 1).
#
# A rerun is a draw of the recipe, not a copy of the shipped weights: physics and episode draws
# depend on thread counts and machine, and a PPO run from scratch can take off later than the
# recorded one. Where a run's validation (its validation.csv) stays well under the recorded one,
# train it further (--resume --iterations N) and point its child at the checkpoint that
# validates as well.
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
  flat_teacher
  # `rough-teacher`: PPO from the flat teacher on the rough context, the flat recipe otherwise;
  # model_3246 validated best (seed 1, 192 falls).
  step rough_teacher_v1 3247 --role teacher --context rough --init-from "$ROOT/flat_teacher_v1_scratch/model_1805.pt" \
    --envs 256 --physics-threads 2 --seed 1 --action-reference tall --train.episode.terminate-low-stance-s 1.0 \
    --train.episode.low-stance-leaky --train.validation.episodes 64 --train.checkpoint-every-s 300 \
    --train.keep-checkpoints 2
}

rough() {
  rough_teacher
  # `rough`: plain distillation into a 25-frame, 512-256-128 student; model_332 validated best.
  step rough_student_v1 333 --role student --context rough --teacher "$ROOT/rough_teacher_v1/model_3246.pt" \
    --envs 256 --physics-threads 1 --torch-threads 1 --seed 1 --action-reference tall \
    --train.distillation.student-history 25 --train.policy.hidden-dims 512 256 128 --train.validation.episodes 64 \
    --train.checkpoint-every-s 300 --train.keep-checkpoints 3
}

incline_teacher() {
  flat_teacher
  # PPO from the flat teacher with the slope curriculum 5 -> 20 deg, the flat recipe otherwise.
  step incline_teacher_v1 1639 --role teacher --context incline --init-from "$ROOT/flat_teacher_v1_scratch/model_1805.pt" \
    --envs 256 --physics-threads 2 --seed 1 --action-reference tall --train.episode.curriculum \
    --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky --train.validation.episodes 64 \
    --train.checkpoint-every-s 300 --train.keep-checkpoints 2
  # `incline-teacher`: on the 20 deg slope alone, with a goal-set reward term (not in Table I);
  # model_842 validated best.
  step incline_teacher_v1_goal 843 --role teacher --context incline --init-from "$ROOT/incline_teacher_v1/model_1638.pt" \
    --envs 256 --physics-threads 1 --seed 2 --action-reference tall --train.reward.goal-set 10 \
    --train.episode.terminate-low-stance-s 1.0 --train.episode.low-stance-leaky --train.validation.episodes 64 \
    --train.checkpoint-every-s 300 --train.keep-checkpoints 2
}

incline() {
  incline_teacher
  # `incline`: plain distillation into a 25-frame, 512-256-128 student; model_373 validated best.
  step incline_student_v1 374 --role student --context incline --teacher "$ROOT/incline_teacher_v1_goal/model_842.pt" \
    --envs 256 --physics-threads 1 --torch-threads 1 --seed 1 --action-reference tall \
    --train.distillation.student-history 25 --train.policy.hidden-dims 512 256 128 --train.validation.episodes 64 \
    --train.checkpoint-every-s 300 --train.keep-checkpoints 3
}

ship_flat_teacher() { flat_teacher; publish flat-teacher "$ROOT/flat_teacher_v1_scratch/model_1805.pt" flat; }
ship_flat() { flat; publish flat "$ROOT/flat_student_v1/model_1003.pt" flat; }
ship_rough_teacher() { rough_teacher; publish rough-teacher "$ROOT/rough_teacher_v1/model_3246.pt" rough; }
ship_rough() { rough; publish rough "$ROOT/rough_student_v1/model_332.pt" rough; }
ship_incline_teacher() { incline_teacher; publish incline-teacher "$ROOT/incline_teacher_v1_goal/model_842.pt" incline; }
ship_incline() { incline; publish incline "$ROOT/incline_student_v1/model_373.pt" incline; }

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
