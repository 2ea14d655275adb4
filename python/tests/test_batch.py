"""`python -m patina.batch`: one task per input, failures reported, resume, and Ray identical to local."""

import json
import subprocess
import sys

import pytest

from conftest import bricks, rusted
from patina import batch


@pytest.fixture
def textures(tmp_path, write_png):
    folder = tmp_path / "in"
    folder.mkdir()
    for k in range(4):
        (folder / f"tex{k}.png").write_bytes(write_png(bricks(40, 40, seed=10 + k), f"t{k}.png").read_bytes())
    return folder


def outputs(folder):
    """Every file under a batch output folder except batch.json and the manifests (which hold timings)."""
    return {
        p.relative_to(folder).as_posix(): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and p.name != "batch.json" and not p.name.endswith("manifest.json")
    }


def test_local_batch_runs_every_input_reports_failures_and_resumes(tmp_path, textures):
    (textures / "broken.png").write_bytes(b"not an image")
    out = tmp_path / "out"
    summary = batch.run_batch("synth", textures, out, ["--size", "56x56"], seed=3)
    by_input = {e["input"]: e for e in summary["inputs"]}
    assert summary["counts"] == {"ok": 4, "failed": 1, "skipped": 0}
    assert by_input["broken.png"]["status"] == "failed" and "broken.png" in by_input["broken.png"]["error"]
    for k in range(4):
        entry = by_input[f"tex{k}.png"]
        assert entry["status"] == "ok" and entry["error"] is None and entry["seconds"] > 0
        assert (out / entry["output"]).is_file()
    # Seeds depend on the file name, so inputs differ and a rerun elsewhere agrees.
    seeds = {e["seed"] for e in summary["inputs"]}
    assert len(seeds) == 5 and by_input["tex0.png"]["seed"] == batch.derive_seed(3, "tex0.png")
    assert json.loads((out / "batch.json").read_text())["counts"] == summary["counts"]
    first = outputs(out)

    # Resume: complete outputs are skipped, the failed one is tried again.
    again = batch.run_batch("synth", textures, out, ["--size", "56x56"], seed=3)
    assert again["counts"] == {"ok": 0, "failed": 1, "skipped": 4}
    # An incomplete output (its image deleted) is redone, identically.
    (out / by_input["tex2.png"]["output"]).unlink()
    third = batch.run_batch("synth", textures, out, ["--size", "56x56"], seed=3)
    assert {e["input"] for e in third["inputs"] if e["status"] == "ok"} == {"tex2.png"}
    assert outputs(out) == first


def test_folder_jobs_and_the_command_line(tmp_path, write_png):
    folder = tmp_path / "in"
    folder.mkdir()
    for k in range(2):
        (folder / f"w{k}.png").write_bytes(write_png(rusted(48, 48, seed=k), f"w{k}.png").read_bytes())
    out = tmp_path / "out"
    p = subprocess.run(
        [sys.executable, "-m", "patina.batch", "weather", str(folder), str(out), "--past", "1", "--future", "1"],
        capture_output=True,
        text=True,
    )
    assert p.returncode == 0, p.stderr
    for k in range(2):
        manifest = json.loads((out / f"w{k}" / "manifest.json").read_text())
        assert len(manifest["frames"]) == 4 and (out / f"w{k}" / "age_map.png").is_file()
    bad = subprocess.run(
        [sys.executable, "-m", "patina.batch", "weather", str(tmp_path / "nowhere"), str(out)],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2 and "does not exist" in bad.stderr


def test_process_pool_workers_match_serial(tmp_path, textures):
    serial = tmp_path / "serial"
    pooled = tmp_path / "pooled"
    batch.run_batch("synth", textures, serial, ["--size", "48x48"], seed=1)
    summary = batch.run_batch("synth", textures, pooled, ["--size", "48x48"], seed=1, workers=2)
    assert summary["counts"]["ok"] == 4
    assert outputs(pooled) == outputs(serial)


@pytest.fixture(scope="module")
def ray_cluster():
    ray = pytest.importorskip("ray", reason="Ray is not installed (pip install './python[ray]')")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray
    ray.shutdown()


def test_ray_batch_is_byte_identical_to_local(tmp_path, textures, ray_cluster):
    local = tmp_path / "local"
    on_ray = tmp_path / "ray"
    batch.run_batch("synth", textures, local, ["--size", "64x64"], seed=7)
    summary = batch.run_batch("synth", textures, on_ray, ["--size", "64x64"], seed=7, engine="ray", workers=2)
    assert summary["counts"] == {"ok": 4, "failed": 0, "skipped": 0}
    assert summary["engine"] == "ray"
    got, want = outputs(on_ray), outputs(local)
    assert len(want) == 4 and got == want


def test_ttf_chunks_merge_into_the_whole_run_byte_for_byte(tmp_path, write_png, cli):
    import numpy as np

    seq = tmp_path / "seq"
    seq.mkdir()
    base = bricks(40, 40, seed=21).astype(np.float32) / 255
    rust = np.array([0.5, 0.22, 0.08], np.float32)
    y, x = np.mgrid[0:40, 0:40]
    for k in range(10):  # a rust front sweeping left to right
        front = (x < 4 * k + 2)[..., None]
        frame = np.where(front, 0.4 * base + 0.6 * rust, base)
        (seq / f"f{k}.png").write_bytes(write_png((frame * 255).round().astype(np.uint8), f"f{k}.png").read_bytes())
    cli("ttf", seq, "-o", tmp_path / "whole", "--size", "64x64", "--seed", "4")
    out = tmp_path / "chunked"
    summary = batch.run_chunks("ttf", seq, out, 3, ["--size", "64x64"], seed=4)
    assert summary["counts"] == {"ok": 3, "failed": 0, "skipped": 0}
    whole = json.loads((tmp_path / "whole" / "manifest.json").read_text())
    merged = json.loads((out / "manifest.json").read_text())
    assert [f["t"] for f in merged["frames"]] == [f["t"] for f in whole["frames"]]
    for entry in whole["frames"]:
        assert (out / entry["path"]).read_bytes() == (tmp_path / "whole" / entry["path"]).read_bytes(), entry["path"]
    # Each chunk made only its own frames.
    made = [len(json.loads((out / e["output"] / "manifest.json").read_text())["frames"]) for e in summary["inputs"]]
    assert made == [3, 3, 4] and (out / "sequence.gif").is_file()
    # A rerun finds every chunk complete.
    assert batch.run_chunks("ttf", seq, out, 3, ["--size", "64x64"], seed=4)["counts"]["skipped"] == 3
