"""Batch runs: one patina job per input file, locally or on a Ray cluster.

    python -m patina.batch JOB IN_DIR OUT_DIR [job flags] [--engine local|ray] [--workers N]

JOB is ``synth``, ``weather``, ``decay-texture`` or ``stone``. Every image in
IN_DIR (PNG, JPEG, EXR; sorted by name) gets its own output folder
``OUT_DIR/<name>/``, and ``OUT_DIR/batch.json`` records, per input, its
status (``ok``, ``failed`` or ``skipped``), error, time, seed and output.
Job flags are the CLI's (``patina help JOB``), e.g. ``--size 1024x1024``.

- **Seeds** are derived per input from ``--seed`` and the input's file name,
  so an input gets the same output whichever engine, worker count or order
  runs it: Ray and local runs are byte-identical.
- **A failed input** is reported and the rest go on (the exit code is 1 if
  any failed).
- **Resume**: re-running skips inputs whose output manifest is complete
  (every output it lists exists); ``--force`` re-runs them.
- **Ray**: ``--engine ray`` sends each task file paths (never images), so
  IN_DIR and OUT_DIR must be on storage every node sees. Each task declares
  ``--threads`` CPUs (default: the cluster's CPUs / ``--workers``).
  ``--address`` connects to an existing cluster (``ray.init(address=...)``;
  ``auto`` finds the local node's cluster); without it a local Ray instance
  starts. If Ray is already initialised in this process, that is used.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

JOBS = ("synth", "weather", "decay-texture", "stone")
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".exr"}
# Jobs writing one file (into the input's folder) rather than a whole folder.
FILE_OUTPUT = {"synth": "synth.png", "decay-texture": "texture.png"}


def derive_seed(base: int, name: str) -> int:
    """The seed for input ``name``: from the batch seed and the file name only."""
    digest = hashlib.sha256(f"patina-batch/{base}/{name}".encode()).digest()
    return int.from_bytes(digest[:8], "little") >> 1


def list_inputs(in_dir: Path) -> List[Path]:
    if not in_dir.is_dir():
        raise ValueError(f"input folder {in_dir} does not exist")
    files = sorted(p for p in in_dir.iterdir() if p.is_file() and p.suffix.lower() in IMAGE_SUFFIXES)
    if not files:
        raise ValueError(f"input folder {in_dir} holds no PNG, JPEG or EXR images")
    return files


def folder_names(inputs: Sequence[Path]) -> List[str]:
    """One output folder name per input: its stem, or its whole name where stems collide."""
    stems = [p.stem for p in inputs]
    return [p.stem if stems.count(p.stem) == 1 else p.name for p in inputs]


def command(job: str, source: Path, folder: Path, flags: Sequence[str], seed: int) -> List[str]:
    """The CLI words of one task."""
    if job in FILE_OUTPUT:
        out = folder / FILE_OUTPUT[job]
        head = [job, "--exemplar", str(source)] if job == "decay-texture" else [job, str(source)]
        return head + ["-o", str(out), "--seed", str(seed)] + list(flags)
    return [job, str(source), "-o", str(folder), "--seed", str(seed)] + list(flags)


def manifest_file(job: str, folder: Path) -> Path:
    if job in FILE_OUTPUT:
        return folder / (FILE_OUTPUT[job] + ".manifest.json")
    return folder / "manifest.json"


def complete(job: str, folder: Path) -> bool:
    """Whether a previous run left a whole output: a manifest whose every output and frame exists."""
    try:
        manifest = json.loads(manifest_file(job, folder).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    if manifest.get("tool", {}).get("name") != "patina":
        return False
    paths = [Path(p) for p in manifest.get("outputs", [])] + [Path(f["path"]) for f in manifest.get("frames", [])]
    return all((p if p.is_absolute() else folder / p).exists() for p in paths)


def run_task(words: List[str], folder: str, file_output: bool, threads: Optional[int]) -> Dict[str, Any]:
    """Run one input's job; never raises for the job's own failure."""
    from patina import _native

    start = time.perf_counter()
    try:
        if file_output:
            os.makedirs(folder, exist_ok=True)
        _native.run(words, threads=threads)
        return {"status": "ok", "error": None, "seconds": time.perf_counter() - start}
    except (ValueError, RuntimeError) as e:
        return {"status": "failed", "error": str(e), "seconds": time.perf_counter() - start}


def _write_json_atomic(path: Path, value: Any) -> None:
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(json.dumps(value, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, path)


def run_batch(
    job: str,
    in_dir: Path,
    out_dir: Path,
    flags: Sequence[str] = (),
    *,
    engine: str = "local",
    workers: int = 1,
    threads: Optional[int] = None,
    seed: int = 0,
    address: Optional[str] = None,
    force: bool = False,
    log=None,
) -> Dict[str, Any]:
    """Run ``job`` on every image in ``in_dir``; returns (and writes) the batch.json summary."""
    if job not in JOBS:
        raise ValueError(f"unknown batch job '{job}' (one of {', '.join(JOBS)})")
    if engine not in ("local", "ray"):
        raise ValueError(f"unknown engine '{engine}' (local or ray)")
    if workers < 1:
        raise ValueError("--workers must be at least 1")
    if threads is not None and threads < 1:
        raise ValueError("--threads must be at least 1")
    if any(f == "--seed" or f.startswith("--seed=") for f in flags):
        raise ValueError("give the batch's --seed before the job flags; each input's seed is derived from it")
    in_dir, out_dir = Path(in_dir).resolve(), Path(out_dir).resolve()
    inputs = list_inputs(in_dir)
    if out_dir == in_dir or in_dir in out_dir.parents:
        raise ValueError(f"output folder {out_dir} must not be inside the input folder {in_dir}")
    out_dir.mkdir(parents=True, exist_ok=True)
    log = log or (lambda msg: print(msg, file=sys.stderr))

    entries: List[Dict[str, Any]] = []
    todo = []
    for source, name in zip(inputs, folder_names(inputs)):
        folder = out_dir / name
        s = derive_seed(seed, source.name)
        output = folder / FILE_OUTPUT[job] if job in FILE_OUTPUT else folder
        entry = {
            "input": source.name,
            "seed": s,
            "output": str(output.relative_to(out_dir)),
            "status": "skipped",
            "error": None,
            "seconds": 0.0,
        }
        entries.append(entry)
        if not force and complete(job, folder):
            continue
        words = command(job, source, folder, flags, s)
        if job not in FILE_OUTPUT and folder.exists():
            words.append("--overwrite")
        todo.append((entry, words, str(folder)))

    start = time.perf_counter()
    if engine == "local":
        cpus = os.cpu_count() or 1
        per_task = threads or max(1, cpus // workers)
        if workers == 1:
            results = []
            for entry, words, folder in todo:
                log(f"patina batch: {job} {entry['input']}")
                results.append(run_task(words, folder, job in FILE_OUTPUT, threads))
        else:
            with ProcessPoolExecutor(max_workers=workers) as pool:
                futures = [pool.submit(run_task, w, f, job in FILE_OUTPUT, per_task) for _, w, f in todo]
                results = [f.result() for f in futures]
    else:
        results = _run_on_ray(todo, job, workers, threads, address, log)
    for (entry, _, _), result in zip(todo, results):
        entry.update(result)
        if result["status"] == "failed":
            log(f"patina batch: {entry['input']} failed: {result['error']}")

    summary = {
        "tool": {"name": "patina", "version": _version()},
        "job": job,
        "engine": engine,
        "workers": workers,
        "seed": seed,
        "flags": list(flags),
        "input_dir": str(in_dir),
        "counts": {k: sum(e["status"] == k for e in entries) for k in ("ok", "failed", "skipped")},
        "seconds": time.perf_counter() - start,
        "inputs": entries,
    }
    _write_json_atomic(out_dir / "batch.json", summary)
    return summary


def _version() -> str:
    from patina import _native

    return _native.version()


def _run_on_ray(todo, job: str, workers: int, threads: Optional[int], address: Optional[str], log):
    try:
        import ray
    except ImportError as e:
        raise ValueError("--engine ray needs Ray: pip install './python[ray]'") from e
    if not ray.is_initialized():
        ray.init(address=address, log_to_driver=False)
    cpus = int(ray.cluster_resources().get("CPU", 1))
    per_task = threads or max(1, cpus // workers)
    task = ray.remote(num_cpus=per_task)(run_task)
    log(f"patina batch: {len(todo)} tasks on Ray, {per_task} CPUs each ({cpus} in the cluster)")
    refs = [task.remote(words, folder, job in FILE_OUTPUT, per_task) for _, words, folder in todo]
    return ray.get(refs)


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m patina.batch",
        description="Run one patina job per image in IN_DIR, writing OUT_DIR/<name>/ and OUT_DIR/batch.json. "
        "Flags not listed here are the job's own CLI flags (see `patina JOB --help`).",
    )
    parser.add_argument("job", choices=JOBS, help="the job to run on every input")
    parser.add_argument("in_dir", type=Path, help="folder of input images (PNG, JPEG, EXR)")
    parser.add_argument("out_dir", type=Path, help="output folder (created if missing)")
    parser.add_argument(
        "--engine",
        choices=("local", "ray"),
        default="local",
        help="run tasks in this process / a local process pool, or on Ray (default: local)",
    )
    parser.add_argument(
        "--workers", type=int, default=1, help="tasks run at once (default: 1; each then gets CPUs / workers threads)"
    )
    parser.add_argument(
        "--threads", type=int, default=None, help="worker threads (and Ray CPUs) per task (default: CPUs / --workers)"
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="batch seed; each input's seed derives from it and its name (default: 0)"
    )
    parser.add_argument(
        "--address",
        default=None,
        help="Ray cluster to connect to, as ray.init(address=...); 'auto' for the local node's (default: start one)",
    )
    parser.add_argument("--force", action="store_true", help="re-run inputs whose output is already complete")
    args, flags = parser.parse_known_args(argv)
    try:
        summary = run_batch(
            args.job,
            args.in_dir,
            args.out_dir,
            flags,
            engine=args.engine,
            workers=args.workers,
            threads=args.threads,
            seed=args.seed,
            address=args.address,
            force=args.force,
        )
    except ValueError as e:
        print(f"patina batch: {e}", file=sys.stderr)
        return 2
    c = summary["counts"]
    print(
        f"patina batch: {c['ok']} ok, {c['failed']} failed, {c['skipped']} skipped in {summary['seconds']:.1f} s "
        f"-> {args.out_dir / 'batch.json'}",
        file=sys.stderr,
    )
    return 1 if c["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
