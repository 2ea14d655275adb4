"""Shared fixtures: the `patina` CLI binary (for parity checks) and test images made here."""

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]


def _cli_path() -> Path:
    """The CLI to compare against: $PATINA_BIN, else the binary `cargo test --workspace` builds (asked of cargo,
    which builds it only if that has not run: a plain `cargo build` would resolve features differently and rebuild)."""
    if os.environ.get("PATINA_BIN"):
        return Path(os.environ["PATINA_BIN"])
    cargo = shutil.which("cargo")
    if cargo is None:
        pytest.skip("no cargo to build the patina CLI, and PATINA_BIN is not set")
    out = subprocess.run(
        [cargo, "test", "--workspace", "--no-run", "--message-format=json"],
        cwd=REPO,
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    for line in out.splitlines():
        msg = json.loads(line)
        target = msg.get("target", {})
        if (
            msg.get("reason") == "compiler-artifact"
            and target.get("kind") == ["bin"]
            and target.get("name") == "patina"
            and not msg.get("profile", {}).get("test")  # the CLI itself, not its unit-test harness
        ):
            return Path(msg["executable"])
    raise RuntimeError("cargo did not report the patina binary")


@pytest.fixture(scope="session")
def cli():
    path = _cli_path()

    def run(*args, check=True):
        p = subprocess.run([str(path), *map(str, args)], capture_output=True, text=True)
        if check and p.returncode != 0:
            raise AssertionError(f"patina {' '.join(map(str, args))} failed: {p.stderr}")
        return p

    return run


def bricks(h=64, w=64, seed=0) -> np.ndarray:
    """A structured uint8 RGB texture: running-bond bricks with mortar and per-brick tone and grain."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w]
    row = y // 12
    shifted = x + (row % 2) * 10
    col = shifted // 20
    mortar = ((y % 12) < 2) | ((shifted % 20) < 2)
    tone = rng.uniform(0.45, 0.75, size=(row.max() + 1, col.max() + 1))[row, col]
    grain = rng.normal(0, 0.04, size=(h, w))
    r = np.where(mortar, 0.8, tone + grain)
    rgb = np.stack([r, r * 0.55 + 0.05, r * 0.4 + 0.05], axis=-1)
    return (np.clip(rgb, 0, 1) * 255).round().astype(np.uint8)


def rusted(h=64, w=64, seed=0) -> np.ndarray:
    """Bricks with rust-coloured blotches over a known part: a weathered texture for the weathering jobs."""
    clean = bricks(h, w, seed).astype(np.float32) / 255
    y, x = np.mgrid[0:h, 0:w]
    blot = ((x - w * 0.3) ** 2 + (y - h * 0.4) ** 2 < (0.18 * w) ** 2) | (
        (x - w * 0.75) ** 2 + (y - h * 0.7) ** 2 < (0.12 * w) ** 2
    )
    rust = np.array([0.45, 0.2, 0.08], np.float32)
    out = np.where(blot[..., None], 0.3 * clean + 0.7 * rust, clean)
    return (out * 255).round().astype(np.uint8)


@pytest.fixture
def write_png(tmp_path):
    from patina import _native

    def write(a: np.ndarray, name: str) -> Path:
        a = np.ascontiguousarray(a if a.ndim == 3 else a[..., None])
        path = tmp_path / name
        _native.write_image(str(path), a.tobytes(), a.shape[0], a.shape[1], a.shape[2], str(a.dtype))
        return path

    return write
