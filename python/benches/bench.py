"""Benchmarks of the Python package: call overhead against the CLI, and batch throughput.

    python python/benches/bench.py [--cli PATH] [--quick]

1. A 512 px `synth` from a 256 px exemplar: the CLI (a process: start, load, synthesize, save), against
   `patina.synth` from a path and from a numpy array (in-process: arrays written to a scratch file, the run,
   the output PNG still written, arrays returned). Median of 3 runs each.
2. Batch throughput for 16 textures (`synth --size 384x384` of 192 px exemplars): local serial (one task at a
   time with every core), a local pool of 2 workers, and Ray with 2 workers (when Ray is installed).

Exemplars are crops of the photos in ../shared/data when present, else procedural bricks. Prints a table with
peak memory (this process and its children, from getrusage).
"""

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import patina
from patina import batch

HERE = Path(__file__).resolve().parent.parent  # python/
DATA = HERE.parent.parent / "shared" / "data"


def exemplars(count: int, side: int):
    """`count` uint8 RGB exemplars of `side` px: photo crops when available."""
    photos = sorted(
        p for d in ("clean", "weathered") for p in (DATA / d).glob("*") if p.suffix.lower() in {".png", ".jpg", ".jpeg"}
    )
    out = []
    for p in photos:
        a = patina.to_array(p)
        if a.shape[0] < side or a.shape[1] < side or a.shape[2] < 3:
            continue
        # The centre and, where the photo is large enough, its four quadrants' centres.
        h, w = a.shape[:2]
        spots = [((h - side) // 2, (w - side) // 2)]
        if h >= 2 * side and w >= 2 * side:
            spots += [(h * fy // 4 - side // 2, w * fx // 4 - side // 2) for fy in (1, 3) for fx in (1, 3)]
        for y, x in spots:
            out.append((np.clip(a[y : y + side, x : x + side, :3], 0, 1) * 255).round().astype(np.uint8))
            if len(out) == count:
                return out, "photo crops"
    rng = np.random.default_rng(1)
    while len(out) < count:
        tone = rng.uniform(0.3, 0.8, size=(side // 8 + 1, side // 16 + 1))
        y, x = np.mgrid[0:side, 0:side]
        r = tone[y // 8, x // 16] * (((y % 8) > 0) & ((x % 16) > 0)) + rng.normal(0, 0.03, (side, side))
        out.append((np.clip(np.stack([r, 0.8 * r, 0.6 * r], -1), 0, 1) * 255).astype(np.uint8))
    return out, "procedural"


def median_time(fn, runs=3):
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def peak_mb() -> float:
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, children) / 1024


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cli", default=str(HERE.parent / "target" / "release" / "patina"), help="the patina binary")
    parser.add_argument("--quick", action="store_true", help="4 textures instead of 16, 1 run instead of 3")
    args = parser.parse_args()
    runs = 1 if args.quick else 3
    if not Path(args.cli).is_file():
        print(f"no CLI at {args.cli}: cargo build --release -p patina-cli, or pass --cli", file=sys.stderr)
        return 2
    scratch = Path(tempfile.mkdtemp(prefix="patina-bench-"))
    try:
        (ex,), source = exemplars(1, 256)
        path = scratch / "ex.png"
        patina._native.write_image(str(path), ex.tobytes(), 256, 256, 3, "uint8")
        out = scratch / "cli.png"

        def cli():
            subprocess.run(
                [args.cli, "synth", str(path), "-o", str(out), "--size", "512x512", "--seed", "1"],
                check=True,
                capture_output=True,
            )

        rows = [("CLI process", median_time(cli, runs))]
        rows.append(("patina.synth(path)", median_time(lambda: patina.synth(path, size=(512, 512), seed=1), runs)))
        rows.append(("patina.synth(array)", median_time(lambda: patina.synth(ex, size=(512, 512), seed=1), runs)))
        print(f"## synth 256 -> 512 px ({source}), median of {runs}\n")
        print("| call | seconds | vs CLI |\n|---|---:|---:|")
        for name, t in rows:
            print(f"| {name} | {t:.3f} | {t - rows[0][1]:+.3f} s |")

        count = 4 if args.quick else 16
        textures, source = exemplars(count, 192)
        in_dir = scratch / "in"
        in_dir.mkdir()
        for i, t in enumerate(textures):
            patina._native.write_image(str(in_dir / f"tex{i:02d}.png"), t.tobytes(), 192, 192, 3, "uint8")
        flags = ["--size", "384x384"]
        results = []
        quiet = lambda message: None  # noqa: E731
        for name, kw in [
            ("local serial", dict(engine="local", workers=1)),
            ("local, 2 workers", dict(engine="local", workers=2)),
            ("ray, 2 workers", dict(engine="ray", workers=2)),
        ]:
            if kw["engine"] == "ray":
                try:
                    import ray
                except ImportError:
                    results.append((name, None, "Ray not installed"))
                    continue
                ray.init(num_cpus=os.cpu_count(), include_dashboard=False, log_to_driver=False)
                time.sleep(1)  # let the workers start, so the time is the batch's
            start = time.perf_counter()
            summary = batch.run_batch(
                "synth", in_dir, scratch / name.replace(" ", "_").replace(",", ""), flags, log=quiet, **kw
            )
            elapsed = time.perf_counter() - start
            if kw["engine"] == "ray":
                ray.shutdown()
            results.append((name, elapsed, f"{summary['counts']['ok']} ok"))
        print(f"\n## batch: synth {count} textures 192 -> 384 px ({source}), {os.cpu_count()} cores\n")
        print("| engine | seconds | textures/s | status |\n|---|---:|---:|---|")
        for name, t, status in results:
            print(
                f"| {name} | {'-' if t is None else f'{t:.2f}'} | {'-' if t is None else f'{count / t:.2f}'} | {status} |"
            )
        print(f"\npeak memory (largest process): {peak_mb():.0f} MB")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
