"""Shared fixtures: the repository, the C++ tools the bindings are compared with, models."""
import os
import subprocess
from pathlib import Path

import pytest

import dynfilter

ROOT = Path(__file__).resolve().parents[2]
MODEL = ROOT / "models" / "human_figure.urdf"
SQUAT = ROOT / "data" / "squat_reference.csv"
CMU = ROOT / "data" / "mocap" / "cmu"


def tool(name):
    """Path of a C++ tool from the environment ctest sets (DYNFILTER_OFFLINE, ...)."""
    path = os.environ.get("DYNFILTER_" + name.upper())
    if not path or not Path(path).exists():
        pytest.skip(f"DYNFILTER_{name.upper()} not set (run through ctest)")
    return path


def run_tool(args):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True)


def read_csv(path):
    """Header and a float matrix of a CSV written by FilteredMotionWriter (shortest
    round-trip numbers: parsing gives back the exact doubles)."""
    with open(path) as f:
        header = f.readline().strip().split(",")
        rows = [line.strip().split(",") for line in f if line.strip()]
    return header, rows


@pytest.fixture(scope="session")
def model():
    return dynfilter.Model(str(MODEL), "dart")


def cut_bvh(src, dst, seconds):
    """Writes the first `seconds` of the BVH src to dst (header kept, "Frames:" changed): the
    clean-up of a whole shipped clip takes 15-60 s, and these tests filter a second of it."""
    lines = Path(src).read_text().splitlines()
    at = next(i for i, l in enumerate(lines) if l.strip().startswith("Frames:"))
    dt = float(lines[at + 1].split(":")[1])
    n = min(int(round(seconds / dt)) + 1, len(lines) - at - 2)
    lines[at] = f"Frames: {n}"
    Path(dst).write_text("\n".join(lines[:at + 2 + n]) + "\n")
    return Path(dst)


def cut_collection(folder, seconds, stems=("131_01_start_walk_stop", "10_01_soccer_kick",
                                           "01_01_forward_jumps")):
    """A folder of the shipped clips cut to their first `seconds`, beside their mappings."""
    folder = Path(folder)
    (folder / "mappings").mkdir(parents=True, exist_ok=True)
    for stem in stems:
        cut_bvh(CMU / f"{stem}.bvh", folder / f"{stem}.bvh", seconds)
        prefix = stem.split("_")[0] + "_" + stem.split("_")[1]
        (folder / "mappings" / f"{prefix}.yaml").write_text(
            (CMU / "mappings" / f"{prefix}.yaml").read_text())
    return folder


def make_collection(folder, clips=("walk", "kick", "squat", "broken_csv", "no_mapping")):
    """A manifest of shipped clips (their first 1.5 s) plus deliberately broken ones; returns
    its path and the error text each broken clip must be reported with."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    entries, errors = [], {}
    cut = cut_collection(folder / "cmu", 1.5, ("131_01_start_walk_stop", "10_01_soccer_kick"))
    if "walk" in clips:  # its mapping found in mappings/ beside it
        entries.append({"name": "walk", "input": str(cut / "131_01_start_walk_stop.bvh")})
    if "kick" in clips:
        entries.append({"name": "kick", "input": str(cut / "10_01_soccer_kick.bvh"),
                        "mapping": str(cut / "mappings" / "10_01.yaml")})
    if "squat" in clips:
        squat = folder / "squat.csv"
        squat.write_text(SQUAT.read_text())
        entries.append({"name": "squat", "input": str(squat)})
    if "broken_csv" in clips:
        lines = SQUAT.read_text().splitlines()
        at = next(i for i, l in enumerate(lines) if l.startswith("time,")) + 2
        fields = lines[at].split(",")
        fields[3] = "nan"
        lines[at] = ",".join(fields)
        broken = folder / "broken.csv"
        broken.write_text("\n".join(lines) + "\n")
        entries.append({"name": "broken", "input": str(broken)})
        with pytest.raises(dynfilter.InputError) as e:
            dynfilter.read_reference(str(broken), dynfilter.Model(str(MODEL)))
        errors["broken"] = str(e.value)
    if "no_mapping" in clips:
        lonely = folder / "lonely.bvh"
        lonely.write_text((CMU / "131_01_start_walk_stop.bvh").read_text())
        entries.append({"name": "lonely", "input": str(lonely)})
        errors["lonely"] = f"{lonely}: no mapping"
    import yaml
    manifest = folder / "clips.yaml"
    manifest.write_text(yaml.safe_dump({"clips": entries}))
    return manifest, errors


def run_batch(args):
    import sys
    return subprocess.run([sys.executable, "-m", "dynfilter.batch", *map(str, args)],
                          capture_output=True, text=True)


def read_summary(out):
    import csv
    with open(Path(out) / "summary.csv", newline="") as f:
        return {r["name"]: r for r in csv.DictReader(f)}
