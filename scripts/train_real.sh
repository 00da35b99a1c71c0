#!/bin/sh
# Reproduce the GAN weights gan-cpu-real end to end: import the training-only real scenes, build the
# procedural and the real datasets, fine-tune gan-cpu on their mix and export it (see
# docs/experiments.md, "Training on real content"). One core throughout (the builds and the training
# are seeded and deterministic on the CPU; each step resumes if stopped).
#
#   scripts/train_real.sh [DPPM_SCENES_CHECKOUT]
#
# Without an argument the importer clones hchoi405/dppm-scenes (only the four folders). The weights were
# made from a snapshot lacking six mesh files (bathroom: a rug, blinds, a steel part; living-room-2:
# radiator panels; spaceship: two aluminium parts), which --drop-missing drops, and two textures
# (bathroom's rug, bathroom2's environment), which become uniform grey: a complete checkout keeps them,
# so its examples differ. bathroom2's two cupboard parts are dropped too (the scene names
# geometry/cupboardsPart*.serialized, the files are cupBoardsPart*: the source was case-insensitive).
set -eu
# Timings (2-core machine shared with other jobs, one core here): the real build 35 min (60 examples,
# 24-62 s each), the procedural one 25-45 min (247 examples), the training 8.5 min (2500 steps).
# --init gan-cpu means the gan-cpu weights of sha256
# 7db971090de9d86f40254755699dc9f5d1e0509e352d3ff90e53021d0d12c5c8 (gmcpt/gan/weights/gan-cpu.json).
cd "$(dirname "$0")/.."
PY=${PY:-.venv/bin/python}
export DRJIT_NUM_THREADS=1 OMP_NUM_THREADS=1
SOURCE=${1:+--source $1}

# shellcheck disable=SC2086
$PY scripts/import_scenes.py $SOURCE --out data/train-scenes --variants --drop-missing \
    bathroom bathroom2 living-room-2 spaceship
$PY -m gmcpt dataset --out data/procedural-small --train 237 --val 10 --workers 1 --threads 1
$PY -m gmcpt dataset --real data/train-scenes --out data/real-train --train 56 --val 4 --workers 1 --threads 1
$PY -m gmcpt train --config cpu --dataset data/procedural-small --dataset data/real-train --init gan-cpu \
    --set train.steps=2500 --set train.lr_g=0.0003 --set train.lr_d=0.0001 --set train.max_train_scenes=0 \
    --set "train.dataset_weights=[0.5,0.5]" --out runs/gan-cpu-real --export gan-cpu-real
