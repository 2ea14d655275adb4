"""Batch runs: one patina job per input file, locally or on a Ray cluster.

    python -m patina.batch JOB IN_DIR OUT_DIR [job flags] [--engine local|ray] [--workers N]

    python -m patina.batch ttf SEQUENCE OUT_DIR --chunks N [ttf flags] [--engine local|ray] [--workers N]

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
- **Long time-lapses** (``ttf``): one sequence (a folder of frames or a
  GIF) is split into ``--chunks`` parts of its output frames, one task each
  (the CLI's ``--chunk K/N``), merged into ``OUT_DIR/frames/``,
  ``manifest.json`` and ``sequence.gif``; the chunk folders stay in
  ``OUT_DIR/chunks/``. Every chunk computes the whole run's layout, so the
  merged frames are byte-identical to one ``patina ttf`` run with the same
  ``--seed`` and need no overlap or blending.
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
# Jobs on one long sequence, split into chunks of output frames.
CHUNKED_JOBS = ("ttf",)
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


def _entry(name: str, seed: int, output: Path) -> Dict[str, Any]:
    """One task's batch.json entry, before it runs ("skipped" until a run says otherwise)."""
    return {"input": name, "seed": seed, "output": str(output), "status": "skipped", "error": None, "seconds": 0.0}


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
    _check_engine(engine, workers, threads, flags)
    in_dir, out_dir = Path(in_dir).resolve(), Path(out_dir).resolve()
    inputs = list_inputs(in_dir)
    if out_dir == in_dir or in_dir in out_dir.parents:
        raise ValueError(f"output folder {out_dir} must not be inside the input folder {in_dir}")
    out_dir.mkdir(parents=True, exist_ok=True)
    log = log or _stderr

    entries: List[Dict[str, Any]] = []
    todo = []
    for source, name in zip(inputs, folder_names(inputs)):
        folder = out_dir / name
        s = derive_seed(seed, source.name)
        output = folder / FILE_OUTPUT[job] if job in FILE_OUTPUT else folder
        entry = _entry(source.name, s, output.relative_to(out_dir))
        entries.append(entry)
        if not force and complete(job, folder):
            continue
        words = command(job, source, folder, flags, s)
        if job not in FILE_OUTPUT and folder.exists():
            words.append("--overwrite")
        todo.append((entry, words, str(folder)))

    start = time.perf_counter()
    _run_tasks(todo, job, engine, workers, threads, address, log)
    summary = _summary(job, engine, workers, seed, flags, str(in_dir), entries, start)
    _write_json_atomic(out_dir / "batch.json", summary)
    return summary


def run_chunks(
    job: str,
    sequence: Path,
    out_dir: Path,
    chunks: int,
    flags: Sequence[str] = (),
    *,
    engine: str = "local",
    workers: int = 1,
    threads: Optional[int] = None,
    seed: int = 0,
    address: Optional[str] = None,
    force: bool = False,
    gif_delay_ms: int = 80,
    log=None,
) -> Dict[str, Any]:
    """Run ``job`` on one sequence as ``chunks`` tasks and merge them; returns (and writes) batch.json."""
    if job not in CHUNKED_JOBS:
        raise ValueError(f"'{job}' cannot be chunked (only {', '.join(CHUNKED_JOBS)})")
    if chunks < 1:
        raise ValueError("--chunks must be at least 1")
    _check_engine(engine, workers, threads, flags)
    if any(f == "--chunk" or f.startswith("--chunk=") for f in flags):
        raise ValueError("give --chunks to the batch, not --chunk: the batch assigns each task its chunk")
    sequence, out_dir = Path(sequence).resolve(), Path(out_dir).resolve()
    if not sequence.exists():
        raise ValueError(f"sequence {sequence} does not exist")
    if out_dir == sequence or sequence in out_dir.parents:
        raise ValueError(f"output folder {out_dir} must not be inside the sequence {sequence}")
    (out_dir / "chunks").mkdir(parents=True, exist_ok=True)
    log = log or _stderr

    entries: List[Dict[str, Any]] = []
    todo = []
    for k in range(1, chunks + 1):
        folder = out_dir / "chunks" / f"{k:0{len(str(chunks))}d}"
        entry = _entry(f"{sequence.name} chunk {k}/{chunks}", seed, folder.relative_to(out_dir))
        entries.append(entry)
        if not force and complete(job, folder):
            continue
        # Every chunk gets the batch's seed itself: chunks must share the run's layout.
        words = [job, str(sequence), "-o", str(folder), "--seed", str(seed), "--chunk", f"{k}/{chunks}", *flags]
        if folder.exists():
            words.append("--overwrite")
        todo.append((entry, words, str(folder)))

    start = time.perf_counter()
    _run_tasks(todo, job, engine, workers, threads, address, log)
    summary = _summary(job, engine, workers, seed, flags, str(sequence), entries, start)
    summary["chunks"] = chunks
    if summary["counts"]["failed"] == 0:
        summary["merged"] = _merge_chunks(out_dir, [out_dir / e["output"] for e in entries], gif_delay_ms)
    _write_json_atomic(out_dir / "batch.json", summary)
    return summary


def _merge_chunks(out_dir: Path, folders: List[Path], gif_delay_ms: int) -> Dict[str, Any]:
    """The chunks' frames together in OUT_DIR/frames, with a manifest and a GIF of the whole."""
    from patina import _native

    manifests = [json.loads((f / "manifest.json").read_text(encoding="utf-8")) for f in folders]
    (out_dir / "frames").mkdir(exist_ok=True)
    frames = []
    for folder, manifest in zip(folders, manifests):
        for entry in manifest["frames"]:
            target = out_dir / entry["path"]
            tmp = target.with_name(f".{target.name}.tmp-{os.getpid()}")
            tmp.write_bytes((folder / entry["path"]).read_bytes())
            os.replace(tmp, target)
            frames.append(entry)
    frames.sort(key=lambda e: e["t"])
    merged = dict(manifests[0])
    merged["frames"] = frames
    merged["outputs"] = ["sequence.gif"]
    merged["params"] = dict(merged["params"], chunk={"merged_from": len(folders)})
    # Per-chunk measurements do not describe the whole.
    merged["metrics"] = {k: v for k, v in merged["metrics"].items() if not k.startswith("flicker")}
    merged["timings_ms"] = {"chunks_total": sum(sum(m["timings_ms"].values()) for m in manifests)}
    _native.write_gif([str(out_dir / e["path"]) for e in frames], str(out_dir / "sequence.gif"), gif_delay_ms)
    _write_json_atomic(out_dir / "manifest.json", merged)
    return {"frames": len(frames), "manifest": "manifest.json", "gif": "sequence.gif"}


def _stderr(message: str) -> None:
    print(message, file=sys.stderr)


def _check_engine(engine: str, workers: int, threads: Optional[int], flags: Sequence[str]) -> None:
    if engine not in ("local", "ray"):
        raise ValueError(f"unknown engine '{engine}' (local or ray)")
    if workers < 1:
        raise ValueError("--workers must be at least 1")
    if threads is not None and threads < 1:
        raise ValueError("--threads must be at least 1")
    if any(f == "--seed" or f.startswith("--seed=") for f in flags):
        raise ValueError("give the batch's --seed, not the job's: each task's seed is derived from it")


def _run_tasks(todo, job: str, engine: str, workers: int, threads: Optional[int], address: Optional[str], log):
    """Run the (entry, words, folder) tasks, recording each result in its entry."""
    file_output = job in FILE_OUTPUT
    if engine == "ray":
        results = _run_on_ray(todo, file_output, workers, threads, address, log)
    elif workers == 1:
        results = []
        for entry, words, folder in todo:
            log(f"patina batch: {job} {entry['input']}")
            results.append(run_task(words, folder, file_output, threads))
    else:
        per_task = threads or max(1, (os.cpu_count() or 1) // workers)
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = [pool.submit(run_task, w, f, file_output, per_task) for _, w, f in todo]
            results = [f.result() for f in futures]
    for (entry, _, _), result in zip(todo, results):
        entry.update(result)
        if result["status"] == "failed":
            log(f"patina batch: {entry['input']} failed: {result['error']}")


def _summary(job, engine, workers, seed, flags, source: str, entries, start: float) -> Dict[str, Any]:
    from patina import _native

    return {
        "tool": {"name": "patina", "version": _native.version()},
        "job": job,
        "engine": engine,
        "workers": workers,
        "seed": seed,
        "flags": list(flags),
        "input": source,
        "counts": {k: sum(e["status"] == k for e in entries) for k in ("ok", "failed", "skipped")},
        "seconds": time.perf_counter() - start,
        "inputs": entries,
    }


def _run_on_ray(todo, file_output: bool, workers: int, threads: Optional[int], address: Optional[str], log):
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
    return ray.get([task.remote(words, folder, file_output, per_task) for _, words, folder in todo])


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m patina.batch",
        description="Run one patina job per image in IN_DIR, writing OUT_DIR/<name>/ and OUT_DIR/batch.json; "
        "or (ttf) one sequence in --chunks tasks. Flags not listed here are the job's own CLI flags "
        "(see `patina JOB --help`).",
    )
    parser.add_argument("job", choices=JOBS + CHUNKED_JOBS, help="the job (ttf: one sequence, in --chunks tasks)")
    parser.add_argument("in_dir", type=Path, help="folder of input images (PNG, JPEG, EXR); for ttf, the sequence")
    parser.add_argument("out_dir", type=Path, help="output folder (created if missing)")
    parser.add_argument(
        "--engine",
        choices=("local", "ray"),
        default="local",
        help="run tasks here (in-process, or a process pool with --workers) or on Ray (default: local)",
    )
    parser.add_argument(
        "--workers", type=int, default=1, help="tasks run at once (default: 1; each then gets CPUs / workers threads)"
    )
    parser.add_argument(
        "--threads", type=int, default=None, help="worker threads (and Ray CPUs) per task (default: CPUs / --workers)"
    )
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="batch seed; each input's seed derives from it and the input's name (default: 0)",
    )
    parser.add_argument(
        "--address",
        default=None,
        help="Ray cluster to use, as ray.init(address=...); 'auto' for the local node's (default: start one)",
    )
    parser.add_argument("--force", action="store_true", help="re-run inputs whose output is already complete")
    parser.add_argument(
        "--chunks",
        type=int,
        default=None,
        help="ttf: split the output frames into this many tasks, merged at the end (default: 1)",
    )
    args, flags = parser.parse_known_args(argv)
    common = dict(
        engine=args.engine,
        workers=args.workers,
        threads=args.threads,
        seed=args.seed,
        address=args.address,
        force=args.force,
    )
    try:
        if args.job in CHUNKED_JOBS:
            summary = run_chunks(args.job, args.in_dir, args.out_dir, args.chunks or 1, flags, **common)
        elif args.chunks is not None:
            raise ValueError(f"--chunks is for {', '.join(CHUNKED_JOBS)}; {args.job} runs one task per input")
        else:
            summary = run_batch(args.job, args.in_dir, args.out_dir, flags, **common)
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
