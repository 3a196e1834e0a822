"""The bindings against the C++ tools on the same input, and their errors."""
import sys
from pathlib import Path

import numpy as np
import pytest

import dynfilter
from conftest import CMU, MODEL, ROOT, SQUAT, cut_bvh, read_csv, run_tool, tool

TIMING = {"solve_time_s", "tick_time_s"}


def assert_same_table(tool_csv, python_csv_or_none, result, model):
    """The tool's CSV against filter_motion's arrays (≤ 1e-12, in fact equal) and, when
    given, against the CSV the binding wrote (identical text but for the timings)."""
    header, rows = read_csv(tool_csv)
    data = np.array([[float(x) for x in r] for r in rows])
    col = {h: i for i, h in enumerate(header)}
    assert data.shape[0] == len(result["time"]) > 100
    nq, nv, nj = model.nq, model.nv, model.nj
    i_q = col["base_x"]
    i_v = col["base_vx"]
    i_a = col["base_ax"]
    i_tau = col[model.joint_names[0] + ".tau"]
    i_err = col["err.base_x"]
    pairs = [("time", data[:, col["time"]]), ("status", data[:, col["status"]]),
             ("q", data[:, i_q:i_q + nq]), ("v", data[:, i_v:i_v + nv]),
             ("vdot", data[:, i_a:i_a + nv]), ("tau", data[:, i_tau:i_tau + nj]),
             ("tracking_error", data[:, i_err:i_err + nv]),
             ("task_error", data[:, col["task_err.x"]:col["task_err.x"] + 6]),
             ("eq12_residual", data[:, col["eq12_residual"]]),
             ("base_residual_n", data[:, col["base_residual_n"]]),
             ("max_penetration_m", data[:, col["max_penetration_m"]]),
             ("num_contacts", data[:, col["num_contacts"]])]
    for key, expected in pairs:
        got = np.asarray(result[key], float)
        assert got.shape == expected.shape, key
        assert np.max(np.abs(got - expected)) <= 1e-12, key
        assert np.array_equal(got, expected), key  # bit-identical: the same loop
    ch, crows = read_csv(str(tool_csv)[:-4] + ".contacts.csv")
    c = result["contacts"]
    assert len(crows) == len(c["time"]) > 0
    cc = {h: i for i, h in enumerate(ch)}
    cdata = np.array([[float(r[i]) if h not in ("body", "kind") else 0.0 for i, h in enumerate(ch)]
                      for r in crows])
    wrench = cdata[:, [cc[k] for k in ("fx", "fy", "fz", "mx", "my", "mz")]]
    assert np.array_equal(c["wrench_W"], wrench)
    assert np.array_equal(c["normal_force_n"], cdata[:, cc["normal_force_n"]])
    assert np.array_equal(c["pivot"], cdata[:, cc["pivot"]])
    assert np.array_equal(c["slide_W"], cdata[:, [cc[k] for k in ("slide_x", "slide_y", "slide_z")]])
    assert [result["body_names"][b] for b in c["body"]] == [r[cc["body"]] for r in crows]
    if python_csv_or_none is not None:
        h2, rows2 = read_csv(python_csv_or_none)
        assert h2 == header
        keep = [i for i, h in enumerate(header) if h not in TIMING]
        assert [[r[i] for i in keep] for r in rows2] == [[r[i] for i in keep] for r in rows]
        assert Path(str(python_csv_or_none)[:-4] + ".contacts.csv").read_text() == \
            Path(str(tool_csv)[:-4] + ".contacts.csv").read_text()


@pytest.mark.parametrize("mode", ["paper", "qp"])
def test_filter_motion_equals_offline_tool_on_the_squat(tmp_path, model, mode):
    offline = tool("offline")
    out_tool = tmp_path / "tool.csv"
    r = run_tool([offline, SQUAT, "-o", out_tool, "--mode", mode, "-q"])
    assert r.returncode == 0, r.stderr
    out_py = tmp_path / "py.csv"
    result = dynfilter.filter_motion(model, str(SQUAT), mode=mode, output_csv=out_py)
    assert_same_table(out_tool, out_py, result, model)
    assert result["counters"]["ticks"] == result["ticks"] == 4 * (len(result["time"]) - 1) + 1


def test_retarget_and_filter_equal_bvh2ref_then_offline(tmp_path, model):
    bvh2ref, offline = tool("bvh2ref"), tool("offline")
    bvh = cut_bvh(CMU / "131_01_start_walk_stop.bvh", tmp_path / "walk.bvh", 2.0)
    mapping = CMU / "mappings" / "131_01.yaml"
    ref_tool = tmp_path / "ref_tool.csv"
    r = run_tool([bvh2ref, bvh, "--mapping", mapping, "-o", ref_tool])
    assert r.returncode == 0, r.stderr
    result = dynfilter.retarget(str(bvh), str(mapping), model)
    ref_py = tmp_path / "ref_py.csv"
    result.write_csv(str(ref_py), model)
    assert ref_py.read_text() == ref_tool.read_text()
    assert (tmp_path / "ref_py.stance.csv").read_text() == (tmp_path / "ref_tool.stance.csv").read_text()
    assert result.cleaned and result.limit_report and len(result.limits) == model.nj
    assert result.cleanup_report in r.stdout
    # Without the clean-up, the retargeted motion itself.
    raw = dynfilter.retarget(str(bvh), str(mapping), model, cleanup=False)
    assert not raw.cleaned and np.array_equal(raw.reference.q, result.raw_reference.q)
    out_tool = tmp_path / "tool.csv"
    r = run_tool([offline, ref_tool, "-o", out_tool, "--mode", "qp", "-q"])
    assert r.returncode == 0, r.stderr
    out = dynfilter.filter_motion(model, str(ref_py), {"mode": "qp"})
    assert_same_table(out_tool, None, out, model)


def test_a_window_of_a_clip_retargets_as_bvh2ref_start_end(tmp_path, model):
    bvh2ref = tool("bvh2ref")
    walk = CMU / "131_01_start_walk_stop.bvh"
    mapping_path = CMU / "mappings" / "131_01.yaml"
    ref_tool = tmp_path / "ref_tool.csv"
    r = run_tool([bvh2ref, walk, "--mapping", mapping_path, "-o", ref_tool, "--start-s", "3.9", "--end-s", "4.9"])
    assert r.returncode == 0, r.stderr
    assert "121 frames (BVH frames from 468)" in r.stdout
    mapping = dynfilter.read_mapping(str(mapping_path))
    for result in (dynfilter.retarget(str(walk), mapping, model, start_s=3.9, end_s=4.9),
                   dynfilter.retarget(dynfilter.read_bvh(str(walk), mapping.length_scale), mapping, model,
                                      start_s=3.9, end_s=4.9)):
        ref_py = tmp_path / "ref_py.csv"
        result.write_csv(str(ref_py), model)
        assert ref_py.read_text() == ref_tool.read_text()
        assert (tmp_path / "ref_py.stance.csv").read_text() == (tmp_path / "ref_tool.stance.csv").read_text()
    kick = dynfilter.read_mapping(str(CMU / "mappings" / "10_01.yaml"))
    assert kick.skip_frames == 5
    part = dynfilter.retarget(dynfilter.read_bvh(str(CMU / "10_01_soccer_kick.bvh"), kick.length_scale), kick,
                              model, cleanup=False, start_s=1.0, end_s=2.0)
    assert part.first_bvh_frame == 5 + 120 and len(part.reference) == 121
    assert kick.skip_frames == 5  # the caller's mapping is not changed
    bvh = dynfilter.read_bvh(str(walk))
    part = bvh.window(2, 1.0, 2.0)
    assert len(part) == 121 and part.skipped_frames == 2 + 120
    assert np.array_equal(part.frames, bvh.frames[122:243])
    with pytest.raises(ValueError, match="131_01_start_walk_stop.bvh"):
        bvh.window(0, 9.0)
    r = run_tool([bvh2ref, walk, "--mapping", mapping_path, "-o", tmp_path / "x.csv", "--start-s", "2", "--end-s", "1"])
    assert r.returncode == 1 and "the start must be >= 0 and before the end" in r.stderr


def test_arrays_give_the_same_result_as_the_csv(model):
    ref = dynfilter.read_reference(str(SQUAT), model)
    a = dynfilter.filter_motion(model, ref, mode="paper", max_seconds=1.0)
    b = dynfilter.filter_motion(model, {"time": ref.time, "q": ref.q, "v": ref.v, "vdot": ref.vdot},
                                mode="paper", max_seconds=1.0)
    for key in ("q", "v", "vdot", "tau"):
        assert np.array_equal(a[key], b[key]), key
    # Without v and vdot the derivatives are estimated exactly as for the CSV (no velocity
    # columns in the squat file).
    c = dynfilter.filter_motion(model, {"time": ref.time, "q": ref.q}, mode="paper", max_seconds=1.0)
    assert np.array_equal(a["q"], c["q"])


def test_a_reference_with_extra_columns_is_rejected_unless_they_are_skipped(model, tmp_path):
    # The squat with one column outside the format (as a filtered motion has many).
    lines = SQUAT.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    extra = lines[:header] + [lines[header] + ",note"] + [line + ",1" for line in lines[header + 1:]]
    csv = tmp_path / "squat_note.csv"
    csv.write_text("\n".join(extra) + "\n")
    with pytest.raises(dynfilter.InputError, match='unknown column "note"'):
        dynfilter.read_reference(str(csv), model)
    read = dynfilter.read_reference(str(csv), model, skip_extra_columns=True)
    plain = dynfilter.read_reference(str(SQUAT), model)
    for key in ("time", "q", "v", "vdot"):
        assert np.array_equal(getattr(read, key), getattr(plain, key)), key


def test_step_by_step_matches_filter_motion_at_the_frame_rate(model):
    ref = dynfilter.read_reference(str(SQUAT), model)
    rate = 1.0 / (ref.time[1] - ref.time[0])
    whole = dynfilter.filter_motion(model, ref, mode="paper", tick_hz=rate, max_seconds=0.5)
    cfg = dynfilter.config({"mode": "paper", "dt_s": 1.0 / rate})
    f = dynfilter.Filter(model, cfg)
    f.reset(ref.q[0], ref.v[0], ref.vdot[0], time=ref.time[0])
    n = len(whole["time"])
    for k in range(n):
        out = f.step(ref.time[k], ref.q[k], ref.v[k], ref.vdot[k])
        # interpolation at a frame's own time may differ from the frame in the last bits
        assert np.max(np.abs(out["q"] - whole["q"][k])) < 1e-9
        assert np.max(np.abs(out["tau"] - whole["tau"][k])) < 1e-6
        assert out["eq12_residual"] < 1e-6
    assert len(out["contacts"]) == whole["num_contacts"][n - 1]


def test_the_leash_moves_a_reference_that_stands_away(model):
    # The squat's base 0.3 m ahead of the state: the leash (max_offset_m 0.1) moves the
    # reference back by 0.2 m on the first tick and says so.
    ref = dynfilter.read_reference(str(SQUAT), model)
    f = dynfilter.Filter(model, dynfilter.config({"mode": "paper", "leash": {"enabled": True}}))
    f.reset(ref.q[0], ref.v[0], ref.vdot[0], time=ref.time[0])
    q = np.array(ref.q[1])
    q[0] += 0.3
    out = f.step(ref.time[1], q, ref.v[1], ref.vdot[1])
    X = out["X_reference_offset"]
    assert X.shape == (4, 4)
    assert abs(X[0, 3] + 0.2) < 1e-3 and abs(X[1, 3]) < 1e-3
    assert np.allclose(X[:3, :3], np.eye(3), atol=1e-9)
    assert out["counters"]["leash_ticks"] == 1
    plain = dynfilter.Filter(model, dynfilter.config({"mode": "paper"}))
    plain.reset(ref.q[0], ref.v[0], ref.vdot[0], time=ref.time[0])
    still = plain.step(ref.time[1], q, ref.v[1], ref.vdot[1])
    assert np.array_equal(still["X_reference_offset"], np.eye(4)) and still["counters"]["leash_ticks"] == 0


def test_model_dynamics_agree_between_backends(model):
    ode = dynfilter.Model(str(MODEL), "ode")
    rng = np.random.default_rng(3)
    q = model.neutral_configuration()
    q[7:] += rng.uniform(-0.3, 0.3, model.nj)
    v = rng.uniform(-1, 1, model.nv)
    A, B = model.mass_matrix(q), ode.mass_matrix(q)
    assert np.allclose(A, A.T) and np.max(np.abs(A - B)) < 1e-9 * np.max(np.abs(A))
    assert np.max(np.abs(model.bias(q, v) - ode.bias(q, v))) < 1e-8
    tau = rng.uniform(-5, 5, model.nj)
    vdot = model.forward_dynamics(q, v, tau)
    # A v̇ + b = [0; τ]
    r = A @ vdot + model.bias(q, v)
    assert np.max(np.abs(r[:6])) < 1e-8 and np.max(np.abs(r[6:] - tau)) < 1e-8


def test_crosscheck_filtered_equals_the_crosscheck_tool(tmp_path, model):
    crosscheck = tool("crosscheck")
    csv_path = tmp_path / "squat.csv"
    out = dynfilter.filter_motion(model, str(SQUAT), mode="paper", output_csv=csv_path)
    ode = dynfilter.Model(str(MODEL), "ode")
    from_file = dynfilter.crosscheck_filtered(ode, csv_path)
    from_arrays = dynfilter.crosscheck_filtered(ode, out)
    assert np.array_equal(from_file["residual"], from_arrays["residual"])
    assert from_file["max_residual_rel_bw"] < 1e-8
    r = run_tool([crosscheck, "--filtered", csv_path, "--filtered-backend", "dart"])
    assert r.returncode == 0, r.stdout + r.stderr
    assert f"max {from_file['max_base_residual_n']:.3g} N" in r.stdout
    assert f"all rows:             max {from_file['max_residual']:.3g}" in r.stdout
    # A wrong torque is seen.
    out["tau"][10, 3] += 1.0
    assert dynfilter.crosscheck_filtered(ode, out)["residual"][10] > 0.9


# ----------------------------------------------------------------------------- errors
def tool_error(args):
    r = run_tool(args)
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("error: ")
    return line[len("error: "):]


def test_bad_reference_csv_raises_the_tools_message(tmp_path, model):
    offline = tool("offline")
    lines = SQUAT.read_text().splitlines()
    header_at = next(i for i, l in enumerate(lines) if l.startswith("time,"))
    fields = lines[header_at + 3].split(",")
    fields[5] = "abc"
    lines[header_at + 3] = ",".join(fields)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    expected = tool_error([offline, bad, "-o", tmp_path / "o.csv", "-q"])
    with pytest.raises(dynfilter.InputError) as e:
        dynfilter.filter_motion(model, str(bad))
    assert str(e.value) == expected
    assert e.value.line == header_at + 4 and e.value.column == 6
    assert "base_qx" in str(e.value) and isinstance(e.value, ValueError)


def test_bad_config_raises_the_tools_message(tmp_path, model):
    offline = tool("offline")
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("feedback:\n  joint_kpp: 3\n")
    expected = tool_error([offline, SQUAT, "-o", tmp_path / "o.csv", "-c", cfg, "-q"])
    with pytest.raises(dynfilter.InputError) as e:
        dynfilter.filter_motion(model, str(SQUAT), str(cfg))
    assert str(e.value) == expected
    # A dict goes through the same parser: the same message, labelled <dict>.
    with pytest.raises(dynfilter.InputError) as e:
        dynfilter.config({"feedback": {"joint_kpp": 3}})
    assert str(e.value) == expected.replace(str(cfg), "<dict>")
    with pytest.raises(dynfilter.InputError, match=r"<dict>:1:\d+: dt_s: "):
        dynfilter.config({"dt_s": -1.0})


def test_bad_urdf_and_backend(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text('<robot name="arm">\n<link name="a"/>\n<link name="b"/>\n'
                    '<joint name="j" type="ball">\n<parent link="a"/><child link="b"/>\n'
                    '</joint>\n</robot>\n')
    with pytest.raises(dynfilter.ModelError) as e:
        dynfilter.Model(str(urdf))
    assert str(e.value).startswith(f"{urdf}:4: joint \"j\": unknown joint type \"ball\"")
    assert e.value.line == 4
    with pytest.raises(ValueError, match="unknown backend \"bullet\""):
        dynfilter.Model(str(MODEL), "bullet")


def test_package_paths_and_locked_joints(tmp_path):
    """A URDF copied away from its meshes finds them through package_paths (the tools'
    --package-path), and lock_joints welds joints as --lock-joints does."""
    models = ROOT / "tests" / "models"
    urdf = tmp_path / "mesh_sole_biped.urdf"
    urdf.write_text((models / "mesh_sole_biped.urdf").read_text())
    with pytest.raises(dynfilter.ModelError, match="package \"dynfilter_test_meshes\" is in none of"):
        dynfilter.Model(str(urdf))
    m = dynfilter.Model(str(urdf), package_paths=[str(models)])
    assert m.nj == 12
    locked = dynfilter.Model(str(urdf), "ode", package_paths=[str(models)],
                             lock_joints=["*_knee=0.4", "l_ankle_roll"])
    assert locked.nj == 9
    assert "l_knee" not in locked.joint_names and "r_ankle_roll" in locked.joint_names
    # The knees welded at 0.4 rad: the shin hangs where the full model puts it with q_knee = 0.4.
    q = np.array(m.neutral_configuration())
    q[7 + m.joint_names.index("l_knee")] = 0.4
    full = dict(zip(m.body_names, m.body_positions(q)))
    welded = dict(zip(locked.body_names, locked.body_positions(locked.neutral_configuration())))
    assert np.max(np.abs(np.asarray(full["l_foot"]) - np.asarray(welded["l_foot"]))) <= 1e-12
    assert locked.locked_joint_names == ["l_knee", "l_ankle_roll", "r_knee"]  # file order
    assert m.locked_joint_names == []
    # A reference of the whole biped reads into the locked model: the welded joints' columns
    # are skipped and named, the others read as the full model reads them.
    t = np.linspace(0.0, 0.2, 5)
    q_full = np.tile(q, (len(t), 1))
    q_full[:, 7 + m.joint_names.index("r_hip_pitch")] = np.linspace(0.0, 0.1, len(t))
    csv = tmp_path / "whole.csv"
    dynfilter.make_reference(m, t, q_full).write_csv(str(csv), m)
    ref = dynfilter.read_reference(str(csv), locked)
    assert ref.ignored_columns == ["l_knee", "l_ankle_roll", "r_knee"]
    kept = [m.joint_names.index(j) for j in locked.joint_names]
    assert np.array_equal(ref.q[:, 7:], q_full[:, 7:][:, kept])
    assert dynfilter.read_reference(str(csv), m).ignored_columns == []
    with pytest.raises(dynfilter.ModelError, match="no_such"):
        dynfilter.Model(str(urdf), package_paths=[str(models)], lock_joints=["no_such_*"])


def test_suggest_mapping_is_the_tools_and_retargets(tmp_path, model):
    """suggest_mapping gives the text dynfilter-bvh2ref --suggest-mapping writes, and the
    mapping it suggests retargets the clip."""
    bvh = CMU / "10_01_soccer_kick.bvh"
    text, notes = dynfilter.suggest_mapping(str(bvh), model)
    out = tmp_path / "kick.yaml"
    r = run_tool([tool("bvh2ref"), bvh, "--suggest-mapping", out])
    assert r.returncode == 0, r.stderr
    assert out.read_text() == text
    assert notes == []
    assert "{link: l_shank, bvh: lShin}" in text
    result = dynfilter.retarget(str(bvh), str(out), model)
    assert result.reference.q.shape[1] == model.nq
    with pytest.raises(dynfilter.InputError, match="cannot suggest a mapping"):
        armless = tmp_path / "tail.bvh"
        armless.write_text("HIERARCHY\nROOT Body\n{\n OFFSET 0 0 0\n CHANNELS 3 Xposition Yposition "
                           "Zposition\n End Site\n {\n  OFFSET 0 -1 0\n }\n}\nMOTION\nFrames: 2\n"
                           "Frame Time: 0.01\n0 1 0\n0 1 0\n")
        dynfilter.suggest_mapping(str(armless), model)


def test_bad_arrays_name_the_row(model):
    ref = dynfilter.read_reference(str(SQUAT), model)
    with pytest.raises(dynfilter.InputError, match=r"^<arrays>: q has shape \(481, 38\), expected \(481, 39\)"):
        dynfilter.filter_motion(model, {"time": ref.time, "q": ref.q[:, 1:]})
    t = ref.time.copy()
    t[5] = t[4]
    with pytest.raises(dynfilter.InputError, match=r"^<arrays>: row 5: time .* is not after"):
        dynfilter.filter_motion(model, {"time": t, "q": ref.q})
    q = ref.q.copy()
    q[7, 3] = 2.0
    with pytest.raises(dynfilter.InputError, match=r"^<arrays>: row 7: base quaternion norm"):
        dynfilter.filter_motion(model, {"time": ref.time, "q": q})
    q = ref.q.copy()
    q[2, 10] = np.nan
    with pytest.raises(dynfilter.InputError, match=r"^<arrays>: row 2: a value is not finite"):
        dynfilter.filter_motion(model, {"time": ref.time, "q": q})


def test_bad_bvh_and_mapping(tmp_path, model):
    bvh = tmp_path / "x.bvh"
    bvh.write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 3 Xposition Yposition Wrotation\n}\n"
                   "MOTION\nFrames: 1\nFrame Time: 0.01\n0 0 0\n")
    with pytest.raises(dynfilter.InputError, match=rf"^{bvh}:5:.*Wrotation"):
        dynfilter.read_bvh(str(bvh))
    mapping = tmp_path / "m.yaml"
    mapping.write_text("root: {bvh: Hips, link: pelvis}\nsegments:\n  - {link: no_such_link, bvh: Hips}\n")
    with pytest.raises(dynfilter.InputError, match=rf"^{mapping}:3"):
        dynfilter.retarget(str(CMU / "131_01_start_walk_stop.bvh"), str(mapping), model)


def test_invalid_state(model):
    f = dynfilter.Filter(model, dynfilter.config())
    q = model.neutral_configuration()
    q[3] = 0.5
    with pytest.raises(dynfilter.InvalidStateError, match="quaternion"):
        f.reset(q)


def test_lcm_message_types_beside_the_bindings(tmp_path):
    import os
    types = os.environ.get("DYNFILTER_LCMTYPES_PYTHON")
    if not types:
        pytest.skip("DYNFILTER_LCMTYPES_PYTHON not set (run through ctest)")
    pytest.importorskip("lcm")
    import subprocess
    code = ("import dynfilter, dynfilter.lcmtypes as t; m = t.contact_state_t(); c = t.contact_t(); "
            "c.body_name = 'l_foot'; m.contacts = [c]; m.num_contacts = 1; "
            "d = t.contact_state_t.decode(m.encode()); print(d.contacts[0].body_name, dynfilter.Model)")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([env["PYTHONPATH"], types])
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("l_foot <class 'dynfilter._dynfilter.Model'>")


def test_mesh_soles_give_the_same_filtered_motion_in_both_engines():
    """Talos (example-robot-data) stands on convex hulls of its sole meshes. Their ground
    contacts come from the hull vertices in both backends, so the QP mode's virtual links
    and the whole filtered motion are the same in DART and ODE (before, Bullet kept 4
    points of a sole and ODE 16, and the links' frames differed)."""
    found = sorted(Path(sys.prefix).glob(
        "lib/python3*/site-packages/cmeel.prefix/share/example-robot-data/robots/"
        "talos_data/robots/talos_reduced.urdf"))
    if not found:
        pytest.skip("example-robot-data is not installed in this Python")
    runs = {}
    for backend in ("dart", "ode"):
        m = dynfilter.Model(str(found[0]), backend)
        q0 = np.array(m.neutral_configuration())
        q0[2] = 1.0834 - 0.0005  # standing 0.5 mm deep (dynfilter-model-info: 1.0834 m)
        t = np.linspace(0.0, 0.6, 61)
        q = np.tile(q0, (len(t), 1))
        q[:, 2] -= 0.02 * np.sin(np.pi * t / 0.6) ** 2  # a 2 cm bob
        runs[backend] = dynfilter.filter_motion(m, dynfilter.make_reference(m, t, q), {"mode": "qp"})
    a, b = runs["dart"], runs["ode"]
    assert a["counters"]["reseeds"] == b["counters"]["reseeds"] == 0
    assert np.max(np.abs(a["q"] - b["q"])) <= 1e-9
    assert np.max(np.abs(a["tau"] - b["tau"])) <= 1e-6 * np.max(np.abs(a["tau"]))
    ca, cb = a["contacts"], b["contacts"]
    assert len(ca["time"]) == len(cb["time"]) > 0
    assert np.max(np.abs(ca["p_WC"] - cb["p_WC"])) <= 1e-9
    assert np.max(np.abs(ca["support_max_A"] - cb["support_max_A"])) <= 1e-9
