"""dynfilter.batch on a Ray cluster started here (ray.init on loopback)."""
import pytest

from conftest import make_collection, read_summary, run_batch


def test_batch_on_a_local_ray_cluster(tmp_path):
    pytest.importorskip("ray")
    manifest, errors = make_collection(tmp_path / "in", ("walk", "squat", "broken_csv"))
    out = tmp_path / "out"
    r = run_batch([manifest, "-o", out, "--ray-address", "local", "--workers", "2",
                   "--max-seconds", "1.0", "--progress", "plain"])
    assert r.returncode == 1, r.stdout + r.stderr
    rows = read_summary(out)
    assert rows["walk"]["status"] == "ok" and rows["squat"]["status"] == "ok"
    assert int(rows["walk"]["frames"]) == 121
    assert rows["broken"]["status"] == "failed"
    assert rows["broken"]["error"].startswith(errors["broken"])
    assert (out / "walk" / "filtered.contacts.csv").exists()
    # Done clips are skipped on the cluster too.
    r = run_batch([manifest, "-o", out, "--ray-address", "local", "--workers", "2",
                   "--max-seconds", "1.0", "--progress", "none"])
    assert [read_summary(out)[n]["status"] for n in ("walk", "squat", "broken")] == \
        ["skipped", "skipped", "failed"]
