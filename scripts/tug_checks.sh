#!/usr/bin/env bash
# The tug test's checks (issue 53, point 1; docs/studies/tug-checks.md): one results file
# per cell under DIR, <design>__<setting>.jsonl, each a `tethernet validate --criterion
# held` run on the same samples (base seed 0).  Resumable: a cell's finished samples are
# read back from its file.  Then: python scripts/tug_checks.py DIR --out PATH
#   bash scripts/tug_checks.sh DIR [WORKERS] [CELL ...]   (default: every cell, 2 workers)
set -euo pipefail
DIR=${1:?usage: tug_checks.sh DIR [WORKERS] [CELL ...]}
WORKERS=${2:-2}
shift $(( $# >= 2 ? 2 : 1 ))
PY=${PY:-.venv/bin/python}
mkdir -p "$DIR/configs"
M=mass-min
C1=docs/cases/case1-new-chosen.yaml
C2=docs/cases/case2-new-chosen.yaml
# cell name -> design, samples, configuration (YAML, over the defaults; criterion held)
declare -A DESIGN SAMPLES CONFIG
cell() { DESIGN[$1]=$2; SAMPLES[$1]=$3; CONFIG[$1]=$4; }
cell mass-min__ref           $M  100 "{}"
cell mass-min__dt0.5ms       $M  100 "{implicit_dt: 0.0005, tug: {ladder_levels: 0}}"
cell mass-min__dt0.25ms      $M  50  "{implicit_dt: 0.00025, tug: {ladder_levels: 0}}"
cell case1-chosen__dt0.5ms   $C1 100 "{implicit_dt: 0.0005, tug: {ladder_levels: 0}}"
cell mass-min__dt2ms         $M  100 "{implicit_dt: 0.002, implicit_iterations: 8, tug: {ladder_levels: 0}}"
cell mass-min__creep0.1      $M  100 "{tug: {creep_speed: 0.1, ladder_levels: 0}}"
cell mass-min__creep0.4      $M  100 "{tug: {creep_speed: 0.4, ladder_levels: 0}}"
cell mass-min__hold5         $M  100 "{tug: {hold_time: 5.0, ladder_levels: 0}}"
cell mass-min__hold40        $M  100 "{tug: {hold_time: 40.0, ladder_levels: 0}}"
cell mass-min__hold80        $M  100 "{tug: {hold_time: 80.0, ladder_levels: 0}}"
cell mass-min__cinch         $M  100 "{lock_model: cinch}"
cell mass-min__cinch-hold40  $M  100 "{lock_model: cinch, tug: {hold_time: 40.0, ladder_levels: 0}}"
cell case1-chosen__cinch     $C1 100 "{lock_model: cinch}"
cell case2-chosen__cinch     $C2 100 "{lock_model: cinch}"
cell mass-min__hold20        $M  100 "{tug: {hold_time: 20.0, ladder_levels: 0}}"
cell mass-min__explicit      $M  20  "{integrator: explicit, tug: {ladder_levels: 0}}"
cell case1-chosen__ref       $C1 100 "{}"
cell case1-chosen__explicit  $C1 20  "{integrator: explicit, tug: {ladder_levels: 0}}"
cell case2-chosen__ref       $C2 100 "{}"
cell case2-chosen__ratchet   $C2 100 "{lock_model: ratchet, tug: {ladder_levels: 0}}"
ORDER=(mass-min__ref case1-chosen__ref case2-chosen__ref case2-chosen__ratchet
       mass-min__dt0.5ms mass-min__dt2ms mass-min__creep0.1 mass-min__creep0.4
       mass-min__hold5 mass-min__hold20 mass-min__explicit case1-chosen__explicit
       mass-min__hold40 mass-min__hold80 mass-min__dt0.25ms case1-chosen__dt0.5ms
       mass-min__cinch mass-min__cinch-hold40 case1-chosen__cinch case2-chosen__cinch)
[ $# -gt 0 ] && ORDER=("$@")
for c in "${ORDER[@]}"; do
    [ -n "${DESIGN[$c]:-}" ] || { echo "unknown cell $c" >&2; exit 2; }
    echo "${CONFIG[$c]}" > "$DIR/configs/$c.yaml"
    echo "== $c ($(date -u +%H:%M:%S))"
    "$PY" -m tethernet_ros.cli validate --design "${DESIGN[$c]}" --samples "${SAMPLES[$c]}" \
        --seed 0 --workers "$WORKERS" --criterion held --config "$DIR/configs/$c.yaml" \
        --results "$DIR/$c.jsonl"
done
