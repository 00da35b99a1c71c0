#!/bin/sh
# Reproduce the GAN weights gan-cpu-real end to end: import the training-only real scenes, build the
# procedural and the real datasets, fine-tune gan-cpu on their mix and export it (see
# docs/experiments.md, "Training on real content"). One core throughout (the builds and the training
# are seeded and deterministic on the CPU; each step resumes if stopped).
#
#   scripts/train_real.sh [DPPM_SCENES_CHECKOUT]
#
# Without an argument the importer clones hchoi405/dppm-scenes (only the four folders). The weights were
# made from a snapshot lacking eight mesh files (bathroom: a rug, blinds, a steel part; living-room-2:
# radiator panels; spaceship: two aluminium parts) and bathroom2's environment texture, which
# --drop-missing drops (the texture becomes grey): a complete checkout keeps them, so its examples differ.
set -eu
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
export DRJIT_NUM_THREADS=1 OMP_NUM_THREADS=1
SOURCE=${1:+--source $1}

# shellcheck disable=SC2086
$PY scripts/import_scenes.py $SOURCE --out data/train-scenes --variants --drop-missing \
    bathroom bathroom2 living-room-2 spaceship
$PY -m gmcpt dataset --out data/procedural-small --train @PROCEDURAL@ --val 10 --workers 1 --threads 1
$PY -m gmcpt dataset --real data/train-scenes --out data/real-train --train @REAL@ --val 4 --workers 1 --threads 1
$PY -m gmcpt train --config cpu --dataset data/procedural-small --dataset data/real-train --init gan-cpu \
    @TRAIN_SETTINGS@ --out runs/gan-cpu-real --export gan-cpu-real
