#!/usr/bin/env python3
"""Pack what ``scripts/device_check.sh`` needs into the ignored ``.device/`` and print the device call.

    python scripts/pack_device.py --dataset data/procedural [--dataset DIR ...] [--limit-mib 64]

The lent GPU machines have Python 3.12 with CUDA torch, numpy, scipy, scikit-image, matplotlib and
tqdm, but not Mitsuba, Dr.Jit, OpenEXR, colour-science or flip-evaluator, and fetch nothing; one
call carries at most 64 MiB, the files that travel with the checkout included. This writes

- ``.device/site.tar.xz``: the cp312 manylinux wheels of those five unpacked, less what gmcpt never
  loads (Mitsuba's variants other than ``llvm_ad_rgb`` and ``cuda_ad_rgb``, its spectral upsampling
  table, C++ headers and type stubs; colour-science's coverage report and tests), xz-compressed
  (pyoidn, 88 MB, does not fit: the device's demo completes with ``gan_pawnnm`` instead);
- ``.device/data/NAME/``: each dataset's manifest, the first ``--val`` validation examples and as many
  training examples as fit in what is left of the limit, shared evenly between the datasets;

then measures what travels (tracked and untracked-not-ignored files, plus ``.device``) and prints the
``run`` call. Wheels are cached in ``.cache/device-wheels``; the archive is rebuilt only when they change.
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MIB = 1 << 20
#: the device's Python and the platforms its wheels may have (docs: /work/.library/device/README.md)
PYTHON_VERSION = "3.12"
PLATFORMS = ("manylinux_2_28_x86_64", "manylinux_2_27_x86_64", "manylinux_2_17_x86_64", "manylinux2014_x86_64",
             "manylinux1_x86_64")
#: packages the device lacks: pinned where pyproject pins them, else the version installed here
PACKAGES = ("mitsuba", "drjit", "OpenEXR", "colour-science", "flip-evaluator")
#: unpacked paths left out of the archive (globs relative to the site folder)
STRIP = ("mitsuba/*_mono*.so", "mitsuba/*_spectral*.so", "mitsuba/scalar_*.so", "mitsuba/data/srgb.coeff",
         "mitsuba/include", "mitsuba/mitsuba_stubs", "mitsuba/cmake", "mitsuba/pkgconfig", "drjit/include",
         "**/*.pyi", "colour/htmlcov", "colour/**/tests")
CALL = 'run(command="bash scripts/device_check.sh", carry=[".device"], timeout_s=360)'


def fail(message: str) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(2)


def requirements() -> list[str]:
    from importlib.metadata import PackageNotFoundError, version

    pinned = {}
    for line in (ROOT / "pyproject.toml").read_text().splitlines():
        name = line.strip().strip('",').split("==")
        if len(name) == 2:
            pinned[name[0].lower()] = name[1]
    wanted = []
    for package in PACKAGES:
        try:
            wanted.append(f"{package}=={pinned.get(package.lower()) or version(package)}")
        except PackageNotFoundError:
            fail(f"{package} is not installed here; set up the venv first (make setup)")
    return wanted


def download(wanted: list[str], cache: Path) -> list[Path]:
    cache.mkdir(parents=True, exist_ok=True)
    platforms = [arg for platform in PLATFORMS for arg in ("--platform", platform)]
    command = [sys.executable, "-m", "pip", "download", "-qq", "--no-deps", "--only-binary=:all:", "--python-version",
               PYTHON_VERSION, "--implementation", "cp", *platforms, "-d", str(cache), *wanted]
    if subprocess.run(command).returncode:
        fail(f"pip could not download {' '.join(wanted)} for Python {PYTHON_VERSION}")
    wheels = []
    for requirement in wanted:
        name, release = requirement.split("==")
        stem = f"{name.lower().replace('-', '_')}-{release}-"
        found = sorted(p for p in cache.glob("*.whl") if p.name.lower().startswith(stem))
        if not found:
            fail(f"no wheel of {requirement} in {cache}")
        wheels.append(found[-1])
    return wheels


def build_site(wheels: list[Path], archive: Path) -> None:
    """Unpack ``wheels``, strip them, write ``archive`` (tar.xz) and a stamp naming the wheels and the strip."""
    stamp = archive.with_suffix(".wheels")
    names = "\n".join([*(w.name for w in wheels), *STRIP]) + "\n"
    if archive.is_file() and stamp.is_file() and stamp.read_text() == names:
        return
    with tempfile.TemporaryDirectory() as folder:
        site = Path(folder) / "site"
        for wheel in wheels:
            with zipfile.ZipFile(wheel) as handle:
                handle.extractall(site)
        for pattern in STRIP:
            for path in site.glob(pattern):
                shutil.rmtree(path) if path.is_dir() else path.unlink()
        temporary = archive.with_suffix(".tmp")
        print(f"compressing {sum(p.stat().st_size for p in site.rglob('*') if p.is_file()) / MIB:.0f} MiB "
              f"of packages (about 2 minutes on 2 cores)", file=sys.stderr)
        with open(temporary, "wb") as out:
            tar = subprocess.Popen(["tar", "-C", str(site), "-cf", "-", "."], stdout=subprocess.PIPE)
            xz = subprocess.run(["xz", "-9e", "-T0", "-c"], stdin=tar.stdout, stdout=out)
            if tar.wait() or xz.returncode:
                fail("tar | xz failed")
        temporary.replace(archive)
    stamp.write_text(names)


def travelling_bytes() -> int:
    """Bytes of the tracked and untracked-not-ignored files of the checkout (what a device call sends)."""
    listed = subprocess.run(["git", "-C", str(ROOT), "ls-files", "-z", "--cached", "--others", "--exclude-standard"],
                            capture_output=True, check=True).stdout.split(b"\0")
    return sum((ROOT / name.decode()).stat().st_size for name in listed if name and (ROOT / name.decode()).is_file())


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def check_crops(datasets: list[Path]) -> None:
    """Refuse a dataset whose first training scene is smaller than the ``gpu`` preset's crops."""
    import numpy as np

    from gmcpt.dataset import list_examples
    from gmcpt.gan.train import load_config

    crop = load_config("gpu").train.crop
    for dataset in datasets:
        first = list_examples(dataset, "train")[:1]
        if first:
            with np.load(first[0]) as example:
                size = example["reference"].shape[:2]
            if min(size) < crop:
                fail(f"{dataset}'s training scenes are {size[1]}x{size[0]}, smaller than the gpu preset's "
                     f"{crop}-pixel crops")


def pack_datasets(datasets: list[Path], out: Path, budget: int, val: int) -> list[dict]:
    """Copy each dataset's manifest and first ``val`` validation examples, then training examples in
    seed order, one dataset after another, while they fit ``budget`` bytes; returns what was packed."""
    from gmcpt.dataset import list_examples

    shutil.rmtree(out, ignore_errors=True)
    packed, queues = [], []
    for dataset in datasets:
        if not (dataset / "train").is_dir():
            fail(f"no dataset at {dataset} (no train/ folder)")
        target = out / dataset.resolve().name
        if target.exists():
            fail(f"two datasets named {target.name}")
        target.mkdir(parents=True)
        if (dataset / "manifest.json").is_file():
            shutil.copy2(dataset / "manifest.json", target)
        record = {"dataset": str(dataset), "packed": target.name, "train": 0, "val": 0}
        for path in list_examples(dataset, "val")[:val]:
            (target / "val").mkdir(exist_ok=True)
            shutil.copy2(path, target / "val")
            record["val"] += 1
        packed.append(record)
        queues.append(list_examples(dataset, "train"))
    used = folder_bytes(out)
    while any(queues):  # round robin: every dataset gets its share
        for record, queue in zip(packed, queues):
            if queue:
                path = queue.pop(0)
                if used + path.stat().st_size > budget:
                    queue.clear()
                    continue
                (out / record["packed"] / "train").mkdir(exist_ok=True)
                shutil.copy2(path, out / record["packed"] / "train")
                used += path.stat().st_size
                record["train"] += 1
    for record in packed:
        if not record["train"]:
            fail(f"not one training example of {record['dataset']} fits; pack fewer datasets or free space")
    return packed


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dataset", action="append", type=Path, required=True, metavar="DIR",
                        help="dataset folder (python -m gmcpt dataset); repeatable")
    parser.add_argument("--val", type=int, default=2, help="validation examples per dataset (2)")
    parser.add_argument("--limit-mib", type=float, default=64.0, help="what one device call may carry (64)")
    parser.add_argument("--margin-mib", type=float, default=1.0, help="left free under the limit (1)")
    args = parser.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    device = ROOT / ".device"
    device.mkdir(exist_ok=True)
    if subprocess.run(["git", "-C", str(ROOT), "check-ignore", "-q", ".device"]).returncode:
        fail(".device is not ignored by git; it would travel twice")
    check_crops(args.dataset)
    build_site(download(requirements(), ROOT / ".cache" / "device-wheels"), device / "site.tar.xz")
    tree, site = travelling_bytes(), sum(p.stat().st_size for p in device.iterdir() if p.is_file())
    budget = int((args.limit_mib - args.margin_mib) * MIB) - tree - site
    if budget <= 0:
        fail(f"the checkout ({tree / MIB:.1f} MiB) and the packages ({site / MIB:.1f} MiB) leave no room "
             f"under {args.limit_mib} MiB")
    packed = pack_datasets(args.dataset, device / "data", budget, args.val)
    total = tree + folder_bytes(device)
    if total > args.limit_mib * MIB:
        fail(f"{total / MIB:.1f} MiB would travel, over {args.limit_mib} MiB")
    print(json.dumps({"checkout_mib": round(tree / MIB, 2), "packages_mib": round(site / MIB, 2),
                      "data_mib": round(folder_bytes(device / "data") / MIB, 2),
                      "total_mib": round(total / MIB, 2), "datasets": packed}, indent=1))
    print(f"device call (from this checkout): {CALL}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
