#!/usr/bin/env bash
# The whole pipeline behind the shipped policies, one stage per call, each resumable:
#
#   bash scripts/train_policies.sh flat-teacher      # PPO teacher on the flat plane
#   bash scripts/train_policies.sh context-teachers  # rough and incline teachers, fine-tuned from flat
#   bash scripts/train_policies.sh students          # distil the three sensor-only students
#   bash scripts/train_policies.sh ship              # evaluate (64 episodes) and ship all six
#
# Re-running a stage resumes its runs from their latest checkpoints (a run that has reached
# its iteration target does nothing). Iteration targets are what the shipped policies were
# trained for (see their model cards); override with FLAT_IT, CONTEXT_IT, STUDENT_IT.
# Runs sharing the machine split its cores: PHYSICS_THREADS (default 2) goes to a lone run,
# one thread each when two run side by side.
set -euo pipefail
cd "$(dirname "$0")/.."
stage=${1:?usage: train_policies.sh flat-teacher|context-teachers|students|ship}
FLAT_IT=${FLAT_IT:-2600}
CONTEXT_IT=${CONTEXT_IT:-1200}
STUDENT_IT=${STUDENT_IT:-400}
ENVS=${ENVS:-128}
EPISODES=${EPISODES:-64}

# train OUT ROLE CONTEXT ITERATIONS THREADS [EXTRA...]: start or resume one run.
train() {
  local out=$1 role=$2 context=$3 iterations=$4 threads=$5
  shift 5
  local extra=("$@")
  if ls "$out"/model_*.pt > /dev/null 2>&1; then
    extra=(--resume)  # --init-from/--teacher were recorded when the run started
    [ "$role" = student ] && extra+=(--teacher "runs/${context}_teacher")
  fi
  mkdir -p "$out"
  selfright train --role "$role" --context "$context" --out "$out" --envs "$ENVS" \
    --iterations "$iterations" --physics-threads "$threads" "${extra[@]}" >> "$out.log" 2>&1
}

case $stage in
  flat-teacher)
    train runs/flat_teacher teacher flat "$FLAT_IT" "${PHYSICS_THREADS:-2}"
    ;;
  context-teachers)
    train runs/rough_teacher teacher rough "$CONTEXT_IT" 1 --init-from runs/flat_teacher &
    train runs/incline_teacher teacher incline "$CONTEXT_IT" 1 --init-from runs/flat_teacher &
    wait
    ;;
  students)
    for c in flat rough incline; do
      train "runs/${c}_student" student "$c" "$STUDENT_IT" 1 --teacher "runs/${c}_teacher" &
    done
    wait
    ;;
  ship)
    for c in flat rough incline; do
      for role in teacher student; do
        name=$c; [ "$role" = teacher ] && name=$c-teacher
        selfright evaluate --policy "runs/${c}_${role}" --grid "$c" --episodes "$EPISODES" \
          --out "results/${name}_${c}" --no-progress
        selfright ship --run "runs/${c}_${role}" --name "$name" --evaluation "results/${name}_${c}"
      done
    done
    ;;
  *)
    echo "unknown stage $stage (flat-teacher | context-teachers | students | ship)" >&2
    exit 2
    ;;
esac
