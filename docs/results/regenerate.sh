#!/usr/bin/env bash
# Writes every file in docs/results/ (the figures the docs quote). Run from the checkout's
# root after `cargo build --profile ci`; about two hours on two cores.
#   docs/results/regenerate.sh [OUT_DIR] [COMPARE_DIR]
# COMPARE_DIR: an earlier OUT_DIR, whose figures each suite is put beside.
set -euo pipefail
out=${1:-docs/results}
cmp=()
[[ $# -ge 2 ]] && cmp=(--compare "$2")
hw=${HELMWATCH:-target/ci/helmwatch}
eval_fdi() { "$hw" eval --fdi --in-turn --results "$out" "${cmp[@]}" "$@" >/dev/null; }
eval_fdi --seed 1 --runs 40 --nominal-runs 40 --tests 4
eval_fdi --seed 7 --runs 40 --nominal-runs 40 --tests 4
eval_fdi --seed 1 --scenarios envelope --runs 20 --nominal-runs 20 --tests 4
eval_fdi --seed 1 --scenarios commissioning --runs 20 --nominal-runs 20 --tests 4
eval_fdi --seed 1 --scenarios envelope --onset-after 16 --runs 10 --nominal-runs 10 --tests 4
for sea in calm moderate; do
  "$hw" bench --time-to-alarm --seed 1 --runs 12 --sea "$sea" --results "$out" "${cmp[@]}" >/dev/null
  # What the class's prior buys: the same without it.
  "$hw" bench --time-to-alarm --seed 1 --runs 12 --sea "$sea" --ablate class-prior \
    --results "$out/ablation" >/dev/null
done
# One test's Cramer-Rao bound on (u, D) from its features, beside the networks' spread.
"$hw" eval --crb --family --runs 100 --seed 1 --results "$out" >/dev/null
"$hw" eval --passive --runs 40 --seed 1 --results "$out" >/dev/null
# The decision on its own model against the budget (and without the Hotelling calibration).
"$hw" eval --budget --seed 7 --results "$out" >/dev/null
# Each mechanism of the decision off in turn (docs/fdi.md, "Mechanisms"), every set, small;
# then those a hull outside the design's family tests, on its two surge-sway-yaw hulls.
"$hw" eval --fdi --in-turn --scenarios all --seed 1 --runs 3 --nominal-runs 3 --tests 4 \
  --ablate --results "$out/ablation" >/dev/null
# The commissioning set at full size for the two whose effect is false flags there.
"$hw" eval --fdi --in-turn --scenarios commissioning --seed 1 --runs 20 --nominal-runs 20 \
  --tests 4 --ablate own-noise,hotelling-calibration --results "$out/ablation" >/dev/null
"$hw" eval --fdi --in-turn --family --member "120 m" --seed 5 --runs 8 --nominal-runs 4 \
  --tests 4 --ablate loop-shape,log-step --results "$out/ablation" >/dev/null
# The time to alarm on every other member of the family, with the design's networks (its class),
# at the watch's default interval.
for member in "nomoto2 T2/T1 0.05 T3/T1 0.12" "nomoto2 T2/T1 0.1 T3/T1 0.25" "norrbin n3 3000 s^2" \
  "norrbin n3 30000 s^2" "dead band 0.5 deg" "dead band 1 deg" "backlash 0.5 deg" "backlash 1 deg" \
  "fixed-gain autopilot" "all at the upper strength"; do
  for sea in calm moderate; do
    "$hw" bench --time-to-alarm --seed 1 --runs 12 --sea "$sea" --intervals 3600 --member "$member" \
      --results "$out" >/dev/null
  done
done
# The time to alarm on the family's two surge-sway-yaw hulls, at the watch's default interval.
for member in KVLCC2 Mariner; do for sea in calm moderate; do
  "$hw" bench --time-to-alarm --seed 1 --runs 12 --sea "$sea" --intervals 3600 --member "$member" \
    --results "$out" >/dev/null
done; done
# The same hulls with their own class's models (config/classes/ names them), and what the
# class's measured displacement direction buys there.
for class in "kvlcc2-120 KVLCC2" "mariner-120 Mariner"; do
  set -- $class
  for sea in calm moderate; do
    "$hw" --config "config/classes/$1.toml" bench --time-to-alarm --seed 1 --runs 12 --sea "$sea" \
      --intervals 3600 --member "$2" --results "$out" >/dev/null
  done
done
# What ending a method's commissioning on the other's resolution buys: the hours on the hulls
# where one method reads noisier than its class.
"$hw" bench --time-to-alarm --seed 1 --runs 12 --sea moderate --intervals 3600 \
  --member "all at the upper strength" --ablate one-resolved --results "$out/ablation" >/dev/null
"$hw" --config config/classes/mariner-120.toml bench --time-to-alarm --seed 1 --runs 12 \
  --sea moderate --intervals 3600 --member Mariner --ablate one-resolved --results "$out/ablation" >/dev/null
# One test's bound on the two classes, their own networks beside it.
"$hw" --config config/classes/mariner-120.toml eval --crb --family --member Mariner --runs 100 \
  --seed 1 --results "$out" >/dev/null
"$hw" --config config/classes/kvlcc2-120.toml eval --crb --family --member KVLCC2 --runs 100 \
  --seed 1 --results "$out" >/dev/null
for sea in calm moderate; do
  "$hw" --config config/classes/mariner-120.toml bench --time-to-alarm --seed 1 --runs 12 \
    --sea "$sea" --intervals 3600 --member Mariner --ablate class-direction --results "$out/ablation" >/dev/null
done
"$hw" --config config/classes/kvlcc2-120.toml bench --time-to-alarm --seed 1 --runs 12 \
  --sea calm --intervals 3600 --member KVLCC2 --ablate class-direction --results "$out/ablation" >/dev/null
"$hw" --config config/classes/mariner-120.toml eval --fdi --in-turn --family --member Mariner \
  --models models/classes/mariner-120 --scenarios envelope --sea moderate --seed 1 --runs 6 \
  --nominal-runs 6 --tests 4 --ablate class-direction --results "$out/ablation" >/dev/null
