"""dynfilter.batch with two local worker processes on the shipped clips."""
import sys

import numpy as np
import pytest

import dynfilter
from conftest import (MODEL, ROOT, cut_collection, make_collection, read_csv, read_summary,
                      run_batch, tool)


def test_batch_two_workers_reports_failures_and_skips_what_is_done(tmp_path):
    manifest, errors = make_collection(tmp_path / "in")
    out = tmp_path / "out"
    r = run_batch([manifest, "-o", out, "--workers", "2", "--max-seconds", "1.0",
                   "--progress", "plain"])
    assert r.returncode == 1, r.stderr  # some clips failed, the others were filtered
    rows = read_summary(out)
    assert list(rows) == ["walk", "kick", "squat", "broken", "lonely"]
    for name in ("walk", "kick", "squat"):
        assert rows[name]["status"] == "ok", rows[name]["error"]
        assert int(rows[name]["frames"]) == 121  # 1 s at 120 Hz
        assert (out / name / "filtered.csv").exists() and (out / name / "done.json").exists()
    assert (out / "walk" / "reference.csv").exists()
    for name, message in errors.items():
        assert rows[name]["status"] == "failed"
        assert rows[name]["error"].startswith(message), rows[name]["error"]
        assert not (out / name / "done.json").exists()
    md = (out / "summary.md").read_text()
    assert "| broken | failed |" in md and errors["broken"] in md
    assert "5 clips: 3 filtered, 0 skipped (already done), 2 failed." in md
    assert "[5/5]" in r.stderr

    # The summary counts what tools/paper_results.py counts from the same files.
    sys.path.insert(0, str(ROOT / "tools"))
    import paper_results
    paper_results.MODEL_INFO = tool("model_info")
    pm = paper_results.Model(str(MODEL))
    for name in ("walk", "kick", "squat"):
        m = paper_results.metrics_of(out / name / "filtered.csv",
                                     out / name / "filtered.contacts.csv", pm)
        for key in ("frames_pulling_contact", "frames_friction_violation", "frames_cop_outside",
                    "frames_torsion_violation", "frames_torque_over_limit", "frames_qp_fallback"):
            assert int(rows[name][key]) == m[key], (name, key)
        # Tracking RMS over the joints only (paper_results' joint_rms_rad has the base too).
        t = paper_results.read_table(out / name / "filtered.csv")
        joints = np.column_stack([t["err." + j] for j in pm.moving])
        assert float(rows[name]["joint_rms_rad"]) == pytest.approx(
            np.sqrt(np.mean(joints ** 2)), rel=1e-12)
        for g in ("legs", "arms", "spine"):  # the binding's groups against the tool's
            assert float(rows[name][f"joint_rms_{g}_rad"]) == pytest.approx(
                m[f"joint_rms_{g}_rad"], rel=1e-12), (name, g)
    # The paper mode's walk breaks the contact physics (its bilateral feet pull, slip or
    # put the CoP off the sole; first second of the cleaned walk: 23 frames outside the
    # friction cone, 119 with the CoP outside): the counts are not all zero.
    assert sum(int(rows["walk"][k]) for k in ("frames_pulling_contact", "frames_friction_violation",
                                              "frames_cop_outside")) > 0

    # The batch's file is filter_motion's on the same input.
    model = dynfilter.Model(str(MODEL))
    direct = dynfilter.filter_motion(model, str(tmp_path / "in" / "squat.csv"), max_seconds=1.0)
    header, data = read_csv(out / "squat" / "filtered.csv")
    q0 = header.index("base_x")
    assert np.array_equal(np.array([[float(x) for x in r[q0:q0 + model.nq]] for r in data]),
                          direct["q"])

    # Re-run: done clips are skipped, failed ones tried again; a changed input is redone.
    r = run_batch([manifest, "-o", out, "--workers", "2", "--max-seconds", "1.0",
                   "--progress", "none"])
    rows = read_summary(out)
    assert [rows[n]["status"] for n in rows] == ["skipped", "skipped", "skipped", "failed", "failed"]
    squat = tmp_path / "in" / "squat.csv"
    squat.write_text(squat.read_text().replace("\n0,", "\n0.0,", 1))
    r = run_batch([manifest, "-o", out, "--workers", "2", "--max-seconds", "1.0",
                   "--progress", "none"])
    rows = read_summary(out)
    assert rows["squat"]["status"] == "ok" and rows["walk"]["status"] == "skipped"


def test_batch_of_a_folder_finds_mappings(tmp_path):
    out = tmp_path / "out"
    r = run_batch([cut_collection(tmp_path / "cmu", 1.0), "-o", out, "--workers", "2",
                   "--max-seconds", "0.5", "--mode", "qp", "--progress", "none"])
    assert r.returncode == 0, r.stdout + r.stderr
    rows = read_summary(out)
    assert sorted(rows) == ["01_01_forward_jumps", "10_01_soccer_kick", "131_01_start_walk_stop"]
    for row in rows.values():
        assert row["status"] == "ok"
        # The QP mode: no pulling contact, friction or torque limit violated.
        assert row["frames_pulling_contact"] == "0" and row["frames_torque_over_limit"] == "0"


def test_batch_passes_package_paths_and_locked_joints_to_the_model(tmp_path):
    """--package-path and --lock-joints reach every worker's model: a biped copied away from
    its meshes with its knees welded filters a reference of its 10 remaining joints, and
    without --package-path the clip fails naming the package it did not find."""
    models = ROOT / "tests" / "models"
    urdf = tmp_path / "biped.urdf"
    urdf.write_text((models / "mesh_sole_biped.urdf").read_text())
    locked = dynfilter.Model(str(urdf), package_paths=[str(models)], lock_joints=["*_knee"])
    assert locked.nj == 10
    clips = tmp_path / "clips"
    clips.mkdir()
    t = np.linspace(0.0, 0.5, 26)
    q = np.tile(np.array(locked.neutral_configuration()), (len(t), 1))
    dynfilter.make_reference(locked, t, q).write_csv(str(clips / "stand.csv"), locked)
    common = [clips, "--model", urdf, "--lock-joints", "*_knee", "--progress", "none"]
    r = run_batch([*common, "-o", tmp_path / "out", "--package-path", models])
    assert r.returncode == 0, r.stdout + r.stderr
    assert read_summary(tmp_path / "out")["stand"]["status"] == "ok"
    r = run_batch([*common, "-o", tmp_path / "missing"])
    assert r.returncode == 1
    row = read_summary(tmp_path / "missing")["stand"]
    assert row["status"] == "failed" and 'package "dynfilter_test_meshes" is in none of' in row["error"]
