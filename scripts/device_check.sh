#!/usr/bin/env bash
# gmcpt on a lent GPU in one call of the device tool (docs/design.md, section 10, "Devices").
#
#   python scripts/pack_device.py --dataset data/procedural   # here first: fills .device/, prints the call:
#   run(command="bash scripts/device_check.sh", carry=[".device"], timeout_s=360)
#   OUT=/tmp/dc PYTHON=.venv/bin/python scripts/device_check.sh --dry-run   # here: CPU, tiny settings, ~30 s
#
# Unpacks .device/site.tar.xz (Mitsuba, Dr.Jit, ... for the device's Python), declares the checkout's entry points
# (masked_path) beside them, runs the tests marked cuda,
# renders `make demo`'s image with GMCPT_DEVICE=cuda (the completion tests instead where that fails), and
# trains the gpu preset on every dataset under .device/data for what is left of the command's time, at
# most 9 minutes. Writes under $OUT: gan-gpu-device.pt and .json (the weights), demo.exr/.png/.json,
# curves.png, device-check.log and summary.json (each stage's exit status and seconds, the environment,
# the training summary): 8 files, the most a call brings back. A failed stage is recorded and the next
# one runs; the exit status is 1 if any failed (or, off the dry run, torch saw no GPU), 2 for bad usage.
# Environment: OUT (required); PYTHON (python3); DEVICE_CHECK_SECONDS (the whole run: 300, so that a first call
# that fails leaves device time to fix and call again; 570 fits a call of 600 s; dry 90);
# DEVICE_CHECK_MINUTES (training at most: 9, dry 0.2); DEVICE_CHECK_DATA (a folder of dataset folders:
# .device/data; dry: one of 3 scenes rendered on the fly).
set -euo pipefail
[[ -z "${OUT:-}" ]] || OUT=$(realpath -m "$OUT")
[[ -z "${DEVICE_CHECK_DATA:-}" ]] || DEVICE_CHECK_DATA=$(realpath -m "$DEVICE_CHECK_DATA")
cd "$(dirname "$0")/.."

dry=0
case "${1:-}" in
    --dry-run) dry=1 ;;
    "") ;;
    *) echo "error: unknown argument $1 (usage: scripts/device_check.sh [--dry-run])" >&2; exit 2 ;;
esac
[[ -n "${OUT:-}" ]] || { echo "error: set OUT to the folder for the results" >&2; exit 2; }
mkdir -p "$OUT"
PYTHON=${PYTHON:-python3}
budget=${DEVICE_CHECK_SECONDS:-$((dry ? 90 : 300))}
cap=${DEVICE_CHECK_MINUTES:-$( ((dry)) && echo 0.2 || echo 9)}
data=${DEVICE_CHECK_DATA:-.device/data}
log=$OUT/device-check.log
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/site"  # the device's packages, unpacked
: >"$log"
: >"$work/stages.tsv"
export PYTHONUNBUFFERED=1 PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"

say() { echo "[device-check $SECONDS s] $*" | tee -a "$log"; }

# stage NAME LIMIT_S COMMAND...: run COMMAND (output to the log and stdout) under a time limit; record
# its exit status and seconds in stages.tsv; never stops the script
stage() {
    local name=$1 limit=$2 started=$SECONDS
    shift 2
    say "$name: $*"
    { local status=0; timeout --kill-after=10 "$limit" "$@" 2>&1 || status=$?; echo $status >"$work/status"; } |
        tee -a "$log"
    printf '%s\t%s\t%s\n' "$name" "$(cat "$work/status")" "$((SECONDS - started))" >>"$work/stages.tsv"
    say "$name: exit $(cat "$work/status") after $((SECONDS - started)) s"
}
passed() { [[ "$(cat "$work/status")" == 0 ]]; }

if ((dry)); then
    device=cpu
    demo_size=(--res 64 64)
    train_sets=(--set 'generator.widths=[8,8,8]' --set 'generator.encoder_blocks=[1,1,1]'
                --set 'generator.decoder_blocks=[1,1]' --set generator.condition_width=4 --set 'critic.widths=[8,8]'
                --set train.device=cpu --set train.batch=2 --set train.crop=16 --set train.threads=2)
    if [[ -z "${DEVICE_CHECK_DATA:-}" ]]; then
        data=$work/data
        stage dataset 120 "$PYTHON" -m gmcpt dataset --out "$data/tiny" --train 2 --val 1 --res 32 --ref-spp 16 \
            --spp 4 --workers 0 -q
    fi
else
    device=cuda
    demo_size=()
    train_sets=()
    if [[ -f .device/site.tar.xz ]]; then
        stage packages 120 "$PYTHON" -c 'import sys, tarfile; tarfile.open(sys.argv[1]).extractall(sys.argv[2], filter="tar")' \
            .device/site.tar.xz "$work/site"  # Python's lzma: the machine may have no xz
    else
        say "no .device/site.tar.xz: using the packages installed (python scripts/pack_device.py packs them)"
    fi
fi

# the checkout is not pip-installed on the device: without pyproject's entry points Mitsuba finds no masked_path
export PYTHONPATH="$PYTHONPATH:$work/site"
stage entry-points 60 "$PYTHON" - "$work/site" <<'EOF'
import sys, tomllib
from pathlib import Path

project = tomllib.loads(Path("pyproject.toml").read_text())["project"]
info = Path(sys.argv[1]) / f"{project['name']}-{project['version']}.dist-info"
info.mkdir(exist_ok=True)
(info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {project['name']}\nVersion: {project['version']}\n")
(info / "entry_points.txt").write_text("".join(
    f"[{group}]\n" + "".join(f"{name} = {target}\n" for name, target in points.items())
    for group, points in project["entry-points"].items()))
print(f"{info.name}: {project['entry-points']}")
EOF

stage environment 120 "$PYTHON" - "$work/environment.json" <<'EOF'
import ctypes.util, json, platform, shutil, subprocess, sys

# libcuda: Dr.Jit's CUDA backend; libnvoptix: Mitsuba's ray tracing on it (both come with the driver)
record = {"python": platform.python_version(), "libcuda": ctypes.util.find_library("cuda"),
          "libnvoptix": ctypes.util.find_library("nvoptix")}
if shutil.which("nvidia-smi"):
    query = ["nvidia-smi", "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"]
    record["nvidia_smi"] = subprocess.run(query, capture_output=True, text=True).stdout.strip()
import torch
record.update(torch=torch.__version__, torch_cuda=torch.cuda.is_available(),
              gpu=torch.cuda.get_device_name(0) if torch.cuda.is_available() else None)
try:
    import pyoidn  # noqa: F401
    record["pyoidn"] = True
except ImportError:
    record["pyoidn"] = False
print(json.dumps(record))
with open(sys.argv[1], "w") as handle:
    json.dump(record, handle)
import gmcpt, mitsuba as mi
record.update(mitsuba=mi.__version__, variant=mi.variant())
print(json.dumps(record))
with open(sys.argv[1], "w") as handle:
    json.dump(record, handle)
EOF

stage cuda-tests 180 "$PYTHON" -m pytest -q -p no:cacheprovider --continue-on-collection-errors -m cuda tests

demo_method=()
grep -q '"pyoidn": true' "$work/environment.json" 2>/dev/null || demo_method=(--method gan_pawnnm)
stage demo 180 env GMCPT_DEVICE="$device" "$PYTHON" render_and_complete.py scenes/still-life/scene.xml --rate 0.3 \
    --out "$OUT/demo.exr" "${demo_method[@]}" "${demo_size[@]}"
if ! passed; then  # Mitsuba cannot render here: check completion, which needs no scene, instead
    stage completion-tests 180 "$PYTHON" -m pytest -q -p no:cacheprovider tests/test_completion.py \
        tests/test_gan_model.py tests/test_tiles.py tests/test_lowrank.py
fi

datasets=()
for folder in "$data"/*/; do
    if [[ -d "$folder/train" ]]; then datasets+=(--dataset "${folder%/}"); fi
done
left=$((budget - SECONDS - 30))  # 30 s: the last validation, checkpoint and export, the summary
minutes=$(awk -v left="$left" -v cap="$cap" 'BEGIN { m = left / 60; print (m < cap ? m : cap) }')
if ((${#datasets[@]} == 0)); then
    say "train: no dataset under $data (python scripts/pack_device.py --dataset DIR packs one)"
    printf 'train\tno dataset\t0\n' >>"$work/stages.tsv"
elif ((left < 20)); then
    say "train: only $left s left of $budget"
    printf 'train\tno time left\t0\n' >>"$work/stages.tsv"
else
    stage train $((left + 60)) "$PYTHON" -m gmcpt train --config gpu "${datasets[@]}" "${train_sets[@]}" \
        --out "$work/run" --export "$OUT/gan-gpu-device.pt" --minutes "$minutes"
    if [[ -f "$work/run/curves.png" ]]; then cp "$work/run/curves.png" "$OUT/"; fi
fi

"$PYTHON" - "$work" "$OUT" "$dry" "$budget" "$minutes" <<'EOF' | tee -a "$log"
import json, sys
from pathlib import Path

work, out = Path(sys.argv[1]), Path(sys.argv[2])
stages = [line.split("\t") for line in (work / "stages.tsv").read_text().splitlines()]
read = lambda path: json.loads(path.read_text()) if path.is_file() else None  # noqa: E731
weights, demo = read(out / "gan-gpu-device.json"), read(out / "demo.json")
dry, environment = sys.argv[3] == "1", read(work / "environment.json")
summary = {"ok": all(status == "0" for _, status, _ in stages) and (dry or bool(environment and environment["torch_cuda"])),
           "dry_run": dry,
           "budget_s": int(sys.argv[4]), "train_minutes_limit": float(sys.argv[5]),
           "stages": {name: {"status": int(status) if status.isdigit() else status, "seconds": int(seconds)}
                      for name, status, seconds in stages},
           "environment": environment,
           "training": weights and weights["training"],
           "demo": demo and {**{key: demo["parameters"][key] for key in ("method", "device", "generator_precision",
                                                                          "resolution")},
                             "timings": demo["timings"]}}
(out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
print(json.dumps(summary))
sys.exit(0 if summary["ok"] else 1)
EOF
