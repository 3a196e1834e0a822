"""Filter a whole collection of clips: ``python -m dynfilter.batch`` (or ``dynfilter-batch``).

    python -m dynfilter.batch data/mocap/cmu -o out/ --workers 2 [--mode qp]
    python -m dynfilter.batch clips.yaml -o out/ --ray-address auto

Input: a folder or a manifest. A folder's clips are its ``*.bvh`` files (each with a
mapping: ``<stem>.yaml`` beside it or in ``mappings/``, else the longest ``<prefix>.yaml``
there whose prefix starts the stem followed by ``_``, else ``--mapping``) and its ``*.csv``
reference motions. A manifest (``.csv`` with a header, or ``.yaml``: a list or
``{clips: [...]}``) names one clip per entry: ``input`` (required), ``name``, ``mapping``,
``max_seconds``, ``mode``; relative paths are relative to the manifest.

Output per clip, in ``<out>/<name>/``: ``filtered.csv`` and ``filtered.contacts.csv`` (the
files of ``dynfilter-offline``), ``reference.csv`` and ``reference.stance.csv`` for a BVH
clip (retargeted and cleaned up as ``dynfilter-bvh2ref`` writes them; the filter reads the
CSV back, so the result is that of the two tools), and
``done.json`` (the clip's summary row and the hash of everything that went in). A re-run
skips a clip whose ``done.json`` has the same input hash (input file, mapping, model,
configuration and options); a failed clip leaves no ``done.json`` and is tried again.

Summary: ``<out>/summary.csv`` and ``<out>/summary.md``, one row per clip in input order:
status (ok, skipped, failed) and error, frames, seconds of motion, re-seeds, frames with a
pulling contact, a force outside its friction cone, a CoP outside its support, a torque
beyond its URDF limit (counted as tools/paper_results.py does), QP fallbacks, tracking RMS
(joints, rad; base position, m), the largest Eq. 12 base residual, and wall time.
A failing clip is reported with its error and does not stop the batch; the exit status is
1 when any clip failed.

Parallelism: ``--workers N`` local worker processes, or ``--ray-address ADDRESS`` (``auto``
for a running cluster, ``local`` to start one here, or ``host:port``) with one Ray task per
clip; the workers must be able to import this package (same venv, or PYTHONPATH).
"""
from __future__ import annotations

import argparse
import csv
import hashlib
import json
import math
import os
import sys
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Optional

SUMMARY_COLUMNS = [
    ("name", "clip"), ("status", "status"), ("frames", "frames"),
    ("duration_s", "motion (s)"), ("reseeds", "re-seeds"),
    ("frames_pulling_contact", "pulling"), ("frames_friction_violation", "friction"),
    ("frames_cop_outside", "CoP"), ("frames_torsion_violation", "torsion"),
    ("frames_torque_over_limit", "torque limit"),
    ("frames_qp_fallback", "QP fallback"), ("joint_rms_rad", "joint RMS (rad)"),
    ("joint_rms_legs_rad", "legs"), ("joint_rms_arms_rad", "arms"), ("joint_rms_spine_rad", "spine"),
    ("base_rms_m", "base RMS (m)"), ("max_base_residual_n", "max base residual (N)"),
    ("wall_s", "wall (s)"), ("error", "error"),
]
_TOL = 1e-6  # tools/paper_results.py's tolerance on every limit


@dataclass
class Clip:
    """One clip of a batch: a BVH with its mapping, or a reference CSV."""
    name: str
    input: str
    mapping: Optional[str] = None
    max_seconds: Optional[float] = None
    mode: Optional[str] = None


@dataclass
class Settings:
    """What every clip of the batch shares."""
    out_dir: str
    model: str
    backend: str = "dart"
    config: Optional[str] = None
    mode: Optional[str] = None
    tick_hz: float = 500.0
    max_seconds: Optional[float] = None
    force: bool = False
    package_paths: list[str] = field(default_factory=list)  # dynfilter.Model's package_paths
    lock_joints: list[str] = field(default_factory=list)    # dynfilter.Model's lock_joints


# ----------------------------------------------------------------------------- clips
def _mapping_for(bvh: Path, fallback: Optional[str]) -> Optional[str]:
    for folder in (bvh.parent, bvh.parent / "mappings"):
        exact = folder / (bvh.stem + ".yaml")
        if exact.exists():
            return str(exact)
    best = None
    for folder in (bvh.parent, bvh.parent / "mappings"):
        for cand in sorted(folder.glob("*.yaml")) if folder.is_dir() else []:
            if bvh.stem.startswith(cand.stem + "_") and (best is None or len(cand.stem) > len(best.stem)):
                best = cand
    if best is not None:
        return str(best)
    return fallback


def _unique_names(clips: list[Clip]) -> list[Clip]:
    seen: dict[str, int] = {}
    for c in clips:
        if c.name in seen:
            seen[c.name] += 1
            c.name = f"{c.name}_{seen[c.name]}"
        else:
            seen[c.name] = 0
    return clips


def discover(source: str, mapping: Optional[str] = None, exclude: Optional[str] = None) -> list[Clip]:
    """The clips of a folder or a manifest (see the module doc)."""
    path = Path(source)
    if path.is_dir():
        excluded = Path(exclude).resolve() if exclude else None
        clips = []
        for f in sorted(path.iterdir()):
            if excluded is not None and f.resolve() == excluded:
                continue
            if f.suffix.lower() == ".bvh":
                clips.append(Clip(f.stem, str(f), _mapping_for(f, mapping)))
            elif f.suffix.lower() == ".csv":
                clips.append(Clip(f.stem, str(f)))
        if not clips:
            raise ValueError(f"{source}: no .bvh or .csv clips in this folder")
        return _unique_names(clips)
    if not path.exists():
        raise ValueError(f"{source}: no such file or folder")
    base = path.parent
    if path.suffix.lower() == ".csv":
        with open(path, newline="") as f:
            entries = [{k.strip(): v.strip() for k, v in row.items() if k and v and v.strip()}
                       for row in csv.DictReader(f)]
    elif path.suffix.lower() in (".yaml", ".yml"):
        import yaml
        data = yaml.safe_load(path.read_text())
        entries = data.get("clips") if isinstance(data, dict) else data
        if not isinstance(entries, list):
            raise ValueError(f"{source}: a manifest is a list of clips or {{clips: [...]}}")
    else:
        raise ValueError(f"{source}: a manifest is .csv or .yaml")
    clips = []
    for k, e in enumerate(entries):
        if not isinstance(e, dict) or "input" not in e:
            raise ValueError(f"{source}: entry {k + 1}: no 'input'")
        unknown = set(e) - {"name", "input", "mapping", "max_seconds", "mode"}
        if unknown:
            raise ValueError(f"{source}: entry {k + 1}: unknown keys {sorted(unknown)}")
        inp = base / str(e["input"])
        mp = e.get("mapping")
        if mp:
            mp = str(base / str(mp))
        elif inp.suffix.lower() == ".bvh":
            mp = _mapping_for(inp, mapping)
        clips.append(Clip(str(e.get("name") or inp.stem), str(inp), mp,
                          float(e["max_seconds"]) if e.get("max_seconds") not in (None, "") else None,
                          e.get("mode") or None))
    return _unique_names(clips)


# ----------------------------------------------------------------------------- one clip
def _hash_of(clip: Clip, settings: Settings) -> str:
    h = hashlib.sha256()
    for p in (clip.input, clip.mapping, settings.model, settings.config):
        h.update(b"\0")
        if p:
            try:
                h.update(Path(p).read_bytes())
            except OSError:
                h.update(("missing:" + p).encode())
    opts = {"backend": settings.backend, "mode": clip.mode or settings.mode,
            "tick_hz": settings.tick_hz, "max_seconds": clip.max_seconds or settings.max_seconds,
            "name": clip.name, "package_paths": settings.package_paths,
            "lock_joints": settings.lock_joints}
    h.update(json.dumps(opts, sort_keys=True).encode())
    return h.hexdigest()


def _rms(a) -> float:
    import numpy as np
    a = np.asarray(a, float)
    return float(math.sqrt(np.mean(a * a))) if a.size else float("nan")


def clip_metrics(out: dict, model, friction: float) -> dict:
    """Summary numbers of one filter_motion result, counted as tools/paper_results.py
    counts them from the CSV files."""
    import numpy as np
    c = out["contacts"]
    status = out["status"].astype(np.int64)
    m: dict[str, Any] = {"frames": int(len(out["time"])),
                         "duration_s": float(out["time"][-1] - out["time"][0])}
    m["reseeds"] = int(out["counters"]["reseeds"])
    m["frames_pulling_contact"] = int(len(np.unique(c["time"][c["normal_force_n"] < 0])))
    f, n = c["wrench_W"][:, :3], c["n_W"]
    fn = np.sum(f * n, axis=1)
    ft = np.linalg.norm(f - fn[:, None] * n, axis=1)
    m["frames_friction_violation"] = int(len(np.unique(c["time"][ft > friction * np.maximum(fn, 0) + _TOL])))
    kind = c["kind"]
    cop, lo, hi = c["cop_A"], c["support_min_A"], c["support_max_A"]
    out_x = (cop[:, 0] < lo[:, 0] - _TOL) | (cop[:, 0] > hi[:, 0] + _TOL)
    out_y = (cop[:, 1] < lo[:, 1] - _TOL) | (cop[:, 1] > hi[:, 1] + _TOL)
    bad = (kind != 3) & (c["normal_force_n"] > 1e-9) & (out_x | ((kind == 6) & out_y))
    m["frames_cop_outside"] = int(len(np.unique(c["time"][bad])))
    # Twist of edges and faces about the normal beyond μ r f_n (r: the support's farthest point).
    twist = np.abs(np.sum(c["wrench_W"][:, 3:] * n, axis=1))
    r = np.hypot(np.maximum(np.abs(lo[:, 0]), np.abs(hi[:, 0])), np.maximum(np.abs(lo[:, 1]), np.abs(hi[:, 1])))
    twisted = (kind != 3) & (twist > friction * r * np.maximum(fn, 0) + _TOL)
    m["frames_torsion_violation"] = int(len(np.unique(c["time"][twisted])))
    limit = np.asarray(model.tau_max)
    m["frames_torque_over_limit"] = int(np.count_nonzero(np.any(np.abs(out["tau"]) > limit + _TOL, axis=1)))
    m["frames_qp_fallback"] = int(np.count_nonzero(status & 256))
    m["frames_qp_relaxed"] = int(np.count_nonzero(status & 512))
    nb = 6 if model.floating_base else 0
    m["joint_rms_rad"] = _rms(out["tracking_error"][:, nb:])
    groups = np.asarray(model.joint_groups)
    for g in ("legs", "arms", "spine"):
        m[f"joint_rms_{g}_rad"] = _rms(out["tracking_error"][:, nb:][:, groups == g])
    m["base_rms_m"] = _rms(out["tracking_error"][:, :3]) if nb else 0.0
    m["max_eq12_residual"] = float(np.max(np.abs(out["eq12_residual"])))
    m["max_base_residual_n"] = float(np.max(np.abs(out["base_residual_n"])))
    m["status_flags"] = f"0x{int(np.bitwise_or.reduce(status)) if len(status) else 0:x}"
    return m


_models: dict = {}


def run_clip(clip: Clip, settings: Settings) -> dict:
    """Filters one clip into ``<out>/<name>/``; never raises: a failure is returned as a
    row with status "failed" and the error's message."""
    t0 = time.perf_counter()
    row: dict[str, Any] = {"name": clip.name, "input": clip.input, "status": "failed", "error": ""}
    folder = Path(settings.out_dir) / clip.name
    done = folder / "done.json"
    try:
        digest = _hash_of(clip, settings)
        if not settings.force and done.exists():
            previous = json.loads(done.read_text())
            if previous.get("input_hash") == digest:
                previous["row"]["status"] = "skipped"
                return previous["row"]
        import dynfilter
        key = (settings.model, settings.backend, tuple(settings.package_paths), tuple(settings.lock_joints))
        if key not in _models:
            _models[key] = dynfilter.Model(settings.model, settings.backend,
                                           package_paths=settings.package_paths,
                                           lock_joints=settings.lock_joints)
        model = _models[key]
        cfg = dynfilter.config(settings.config)
        folder.mkdir(parents=True, exist_ok=True)
        if done.exists():
            done.unlink()
        source = clip.input
        if clip.input.lower().endswith(".bvh"):
            if not clip.mapping:
                raise ValueError(f"{clip.input}: no mapping (none beside it or in mappings/, "
                                 "no --mapping)")
            result = dynfilter.retarget(clip.input, clip.mapping, model)
            source = str(folder / "reference.csv")
            result.write_csv(source, model)
        out = dynfilter.filter_motion(
            model, source, cfg, mode=clip.mode or settings.mode, tick_hz=settings.tick_hz,
            output_csv=folder / "filtered.csv",
            max_seconds=clip.max_seconds or settings.max_seconds)
        row.update(clip_metrics(out, model, cfg.ground_friction))
        row["status"] = "ok"
        row["wall_s"] = time.perf_counter() - t0
        done.write_text(json.dumps({"input_hash": digest, "row": row}, indent=1))
        return row
    except Exception as e:  # noqa: BLE001 - a clip's failure is data for the summary
        row["error"] = f"{type(e).__name__}: {e}" if not isinstance(e, ValueError) else str(e)
        if os.environ.get("DYNFILTER_BATCH_TRACEBACK"):
            row["error"] += "\n" + traceback.format_exc()
        row["wall_s"] = time.perf_counter() - t0
        return row


def _input_size(clip: Clip) -> int:
    try:
        return Path(clip.input).stat().st_size
    except OSError:
        return 0


# ----------------------------------------------------------------------------- summary
def _cell(row: dict, key: str) -> str:
    v = row.get(key, "")
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def write_summary(out_dir: str, rows: list[dict]) -> tuple[Path, Path]:
    """summary.csv (every key) and summary.md (the main columns) in out_dir."""
    out = Path(out_dir)
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    csv_path, md_path = out / "summary.csv", out / "summary.md"
    with open(csv_path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in keys})
    lines = ["| " + " | ".join(h for _, h in SUMMARY_COLUMNS) + " |",
             "|" + "---|" * len(SUMMARY_COLUMNS)]
    for r in rows:
        cells = [_cell(r, k).replace("|", "\\|").replace("\n", " ") for k, _ in SUMMARY_COLUMNS]
        lines.append("| " + " | ".join(cells) + " |")
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "skipped", "failed")}
    lines += ["", f"{len(rows)} clips: {counts['ok']} filtered, {counts['skipped']} skipped "
              f"(already done), {counts['failed']} failed."]
    md_path.write_text("\n".join(lines) + "\n")
    return csv_path, md_path


class _Progress:
    def __init__(self, total: int, kind: str):
        self.total, self.done, self.bar = total, 0, None
        if kind == "auto":
            kind = "tqdm" if sys.stderr.isatty() else "plain"
        if kind == "tqdm":
            try:
                from tqdm import tqdm
                self.bar = tqdm(total=total, unit="clip", file=sys.stderr)
            except ImportError:
                kind = "plain"
        self.kind = kind

    def update(self, row: dict) -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.set_postfix_str(f"{row['name']}: {row['status']}")
            self.bar.update(1)
        elif self.kind == "plain":
            extra = f" ({row['error'].splitlines()[0]})" if row.get("error") else ""
            print(f"[{self.done}/{self.total}] {row['name']}: {row['status']} "
                  f"{row.get('wall_s', 0.0):.1f} s{extra}", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def run_batch(clips: list[Clip], settings: Settings, workers: int = 1,
              ray_address: Optional[str] = None, progress: str = "auto") -> list[dict]:
    """Filters every clip; returns the summary rows in clip order."""
    Path(settings.out_dir).mkdir(parents=True, exist_ok=True)
    rows: list[Optional[dict]] = [None] * len(clips)
    # Largest inputs first (their size is the best cheap guess of their cost), so that the
    # last clips to finish are short ones and the workers end together.
    order = sorted(range(len(clips)), key=lambda i: -_input_size(clips[i]))
    bar = _Progress(len(clips), progress)
    try:
        if ray_address is not None:
            # No usage report leaves a cluster started here, and it lives on loopback only:
            # Ray turns a node address of 127.0.0.1 into the host's own address unless
            # multi-node clusters are off (the switch Ray reads on Windows and macOS).
            os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
            if ray_address == "local":
                os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
            import ray
            started = not ray.is_initialized()
            if started:
                if ray_address == "local":
                    ray.init(num_cpus=max(1, workers), include_dashboard=False,
                             log_to_driver=False)
                else:
                    ray.init(address=ray_address, log_to_driver=False)
            try:
                task = ray.remote(num_cpus=1, max_retries=0)(run_clip)
                pending = {task.remote(clips[i], settings): i for i in order}
                while pending:
                    ready, _ = ray.wait(list(pending), num_returns=1)
                    for ref in ready:
                        i = pending.pop(ref)
                        try:
                            rows[i] = ray.get(ref)
                        except Exception as e:  # noqa: BLE001 - a lost worker is a failed clip
                            rows[i] = {"name": clips[i].name, "input": clips[i].input,
                                       "status": "failed", "error": f"ray: {e}"}
                        bar.update(rows[i])
            finally:
                if started:
                    ray.shutdown()
        elif workers <= 1:
            for i in order:
                rows[i] = run_clip(clips[i], settings)
                bar.update(rows[i])
        else:
            import multiprocessing
            # Workers forked from a server process that has imported the package: a fresh
            # process per worker (no threads of this one) that starts in milliseconds.
            context = multiprocessing.get_context("forkserver")
            context.set_forkserver_preload(["numpy", "dynfilter"])
            with ProcessPoolExecutor(max_workers=workers, mp_context=context) as pool:
                futures = {pool.submit(run_clip, clips[i], settings): i for i in order}
                for fut in as_completed(futures):
                    i = futures[fut]
                    try:
                        rows[i] = fut.result()
                    except Exception as e:  # noqa: BLE001 - a crashed worker is a failed clip
                        rows[i] = {"name": clips[i].name, "input": clips[i].input,
                                   "status": "failed", "error": f"worker: {e}"}
                    bar.update(rows[i])
    finally:
        bar.close()
    done_rows = [r for r in rows if r is not None]
    write_summary(settings.out_dir, done_rows)
    return done_rows


def main(argv: Optional[Iterable[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="dynfilter-batch", description=__doc__.split("\n\n")[0],
                                epilog="See the module documentation (README, \"Python\").")
    p.add_argument("input", help="folder of clips, or manifest (.csv or .yaml)")
    p.add_argument("-o", "--out", required=True, help="output folder")
    p.add_argument("--model", help="URDF (default: the human figure)")
    p.add_argument("--package-path", action="append", default=[], metavar="DIR",
                   help="folder searched for package:// meshes (repeatable; before ROS_PACKAGE_PATH)")
    p.add_argument("--lock-joints", default="",
                   help="weld joints: names or patterns (* ?), comma-separated, each optionally =position")
    p.add_argument("--backend", default="dart", choices=["dart", "ode"])
    p.add_argument("--config", help="YAML configuration (tools/config/default.yaml)")
    p.add_argument("--mode", choices=["paper", "qp"], help="overrides the configuration's mode")
    p.add_argument("--mapping", help="mapping for BVH clips that have none of their own")
    p.add_argument("--tick-hz", type=float, default=500.0)
    p.add_argument("--max-seconds", type=float, help="filter only the first seconds of each clip")
    p.add_argument("--workers", type=int, default=1,
                   help="local worker processes (with --ray-address local: the CPUs of the cluster started here)")
    p.add_argument("--ray-address", help="Ray cluster: auto, local (start one here) or host:port")
    p.add_argument("--force", action="store_true", help="filter clips already done again")
    p.add_argument("--progress", choices=["auto", "tqdm", "plain", "none"], default="auto")
    a = p.parse_args(None if argv is None else list(argv))
    if a.workers < 1:
        p.error("--workers must be >= 1")
    try:
        clips = discover(a.input, a.mapping, exclude=a.out)
        import dynfilter
        model = os.path.abspath(a.model) if a.model else dynfilter.default_model_path()
    except (ValueError, FileNotFoundError) as e:
        print(f"dynfilter-batch: {e}", file=sys.stderr)
        return 2
    settings = Settings(out_dir=os.path.abspath(a.out), model=model, backend=a.backend,
                        config=os.path.abspath(a.config) if a.config else None, mode=a.mode,
                        tick_hz=a.tick_hz, max_seconds=a.max_seconds, force=a.force,
                        package_paths=[os.path.abspath(d) for d in a.package_path],
                        lock_joints=[j.strip() for j in a.lock_joints.split(",") if j.strip()])
    t0 = time.perf_counter()
    rows = run_batch(clips, settings, a.workers, a.ray_address, a.progress)
    wall = time.perf_counter() - t0
    failed = [r for r in rows if r["status"] == "failed"]
    print(f"{len(rows)} clips in {wall:.1f} s: {len(rows) - len(failed)} ok or skipped, "
          f"{len(failed)} failed; summary in {Path(settings.out_dir) / 'summary.md'}")
    for r in failed:
        print(f"  failed: {r['name']}: {r['error'].splitlines()[0] if r['error'] else ''}")
    return 1 if failed else 0


if __name__ == "__main__":
    # Through the package module, so that worker processes unpickle dynfilter.batch.Clip.
    from dynfilter.batch import main as _main
    sys.exit(_main())
