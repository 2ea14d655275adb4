"""patina: make surfaces age.

Example-based texture synthesis and weathering over time, from Python. Every
function runs the ``patina`` command line's job in-process, with the CLI's
flags as keyword arguments and the CLI's defaults, and returns a
:class:`Result` holding the images at full precision (``float32`` HxWxC in
[0, 1]) and the manifest dict the CLI writes::

    import numpy as np, patina

    ex = patina.to_array("rust.png")                      # or any uint8/uint16/float32 array
    big = patina.synth(ex, size=(512, 512), seed=7)       # or a path: "rust.png"
    big.image.shape                                       # (512, 512, 3) float32
    w = patina.weather("peeling.png", past=3, future=3, seed=1, progress=print)
    w.age_map, w.intact, [t for t, _ in w.frames]
    patina.weather("peeling.png", out="peeling-run")      # also keep the CLI's files

Images can be numpy arrays (``uint8``, ``uint16`` scaled to [0, 1], or
``float32``; HxW, HxWx1, HxWx3 or HxWx4) or paths, wherever the CLI takes an
image, including options such as ``mask=`` or ``age_map=``. Keyword
``foo_bar=v`` is the CLI flag ``--foo-bar v``: ``True`` passes a switch,
``None``/``False`` leave the default, a ``(w, h)`` pair is ``WxH``, a
``range(a, b)`` is ``a..b``, and other lists are comma-separated.

Common keywords of every job: ``out`` (where the CLI's files go; by default
a temporary folder that is removed, so only the arrays are kept),
``threads`` (worker threads; default one per core), and ``progress``, a
callable ``progress(stage, done, total)`` called on the calling thread.

Bad input raises ``ValueError`` and internal errors ``RuntimeError``, with
the CLI's one-line message. The GIL is released while a job runs; Ctrl-C
stops it cleanly (no partial output is left) and raises
``KeyboardInterrupt``. Jobs run one at a time per process; each uses every
core it is given. ``patina.help("synth")`` prints the CLI's flag reference.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

import json

import numpy as np

from . import _native

__all__ = [
    "Result",
    "WeatherResult",
    "synth",
    "weather",
    "age_map",
    "intact",
    "weather_transfer",
    "ttf",
    "stone",
    "decay",
    "decay_texture",
    "stbrdf",
    "help",
    "to_array",
]

__version__ = _native.version()

ImageLike = Union[np.ndarray, str, "os.PathLike[str]"]
Progress = Callable[[str, int, int], Any]
PathLike = Union[str, "os.PathLike[str]"]

# Flags whose (a, b) pairs are written WxH, and those written a,b.
_SIZE_FLAGS = {"size", "block", "overlap"}


class Result:
    """What a job made.

    ``manifest``: the manifest dict the CLI writes (``manifest.json`` or
    ``OUT.manifest.json``). ``images``: every image the job wrote, as float32
    HxWxC arrays in [0, 1] at full precision (before 8-bit encoding), keyed
    by path relative to the output folder (or the output file's name).
    ``out``: the output path, or None when the files went to a temporary
    folder that is gone.
    """

    def __init__(self, manifest: Dict[str, Any], images: Dict[str, np.ndarray], out: Optional[Path]):
        self.manifest = manifest
        self.images = images
        self.out = out

    @property
    def image(self) -> np.ndarray:
        """The job's main output image (the file given as ``out``)."""
        outputs = [str(o) for o in self.manifest.get("outputs", [])]
        for name in outputs:
            key = Path(name).name
            if key in self.images:
                return self.images[key]
        if len(self.images) == 1:
            return next(iter(self.images.values()))
        raise AttributeError("this job has no single output image; see .images or .frames")

    @property
    def frames(self) -> List[Tuple[float, np.ndarray]]:
        """A sequence's frames as (t, image), in order."""
        entries = self.manifest.get("frames", [])
        if not entries:
            raise AttributeError("this job wrote no sequence")
        return [(float(f["t"]), self.images[Path(f["path"]).as_posix()]) for f in entries]

    def __repr__(self) -> str:
        return f"<patina.Result {self.manifest.get('command')}: {len(self.images)} images{'' if self.out is None else f', out={self.out}'}>"


class WeatherResult(Result):
    """A weathering sequence: ``age_map``, ``intact`` and ``frames``."""

    @property
    def age_map(self) -> np.ndarray:
        """The age map (1 channel, white = weathered)."""
        return self.images["age_map.png"]

    @property
    def intact(self) -> np.ndarray:
        """The intact (un-weathered) texture."""
        return self.images["intact.png"]


def to_array(image: ImageLike) -> np.ndarray:
    """An image argument as float32 HxWxC in [0, 1] (reading a path the way the CLI does)."""
    if isinstance(image, np.ndarray):
        a = _normalised(image)
        if a.dtype == np.uint8:
            return a.astype(np.float32) / 255.0
        if a.dtype == np.uint16:
            return a.astype(np.float32) / 65535.0
        return a
    h, w, c, data = _native.read_image(os.fspath(image))
    return np.frombuffer(data, dtype="<f4").reshape(h, w, c)


def help(command: str = "") -> str:  # noqa: A001 - mirrors `patina help`
    """The CLI's flag reference for ``command`` (e.g. "synth", "stbrdf fit"), every flag with its default."""
    return _native.help(command.split())


# ----------------------------------------------------------------------------
# Jobs


def synth(
    exemplar: ImageLike,
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> Result:
    """Synthesize a texture from an exemplar (``patina synth``): ``.image``."""
    return _job(["synth"], [exemplar], flags, out, "synth.png", threads, progress)


def weather(
    texture: ImageLike,
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> WeatherResult:
    """Age a weathered texture forwards and backwards in time (``patina weather``): ``.age_map``, ``.intact``, ``.frames``."""
    return _job(["weather"], [texture], flags, out, None, threads, progress, WeatherResult)


def age_map(
    texture: ImageLike,
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> Result:
    """The age map of a weathered texture, white = weathered (``patina age-map``): ``.image``."""
    return _job(["age-map"], [texture], flags, out, "age_map.png", threads, progress)


def intact(
    texture: ImageLike,
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> Result:
    """The intact (un-weathered) texture (``patina intact``): ``.image``."""
    return _job(["intact"], [texture], flags, out, "intact.png", threads, progress)


def weather_transfer(
    source: ImageLike,
    target: ImageLike,
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> Result:
    """Carry ``source``'s weathering onto ``target`` (``patina weather-transfer``): ``.frames``."""
    flags = dict(flags, source=source, target=target)
    return _job(["weather-transfer"], [], flags, out, None, threads, progress)


def ttf(
    sequence: Union[Sequence[ImageLike], str, "os.PathLike[str]"],
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> Result:
    """Synthesize a larger time-lapse (``patina ttf``) from a list of frames, a folder of frames or a GIF: ``.frames``."""
    return _job(["ttf"], [_Frames(sequence)], flags, out, None, threads, progress)


def stone(
    photo: ImageLike,
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> Result:
    """Weather the stone in a photo (``patina stone``): ``.frames`` (and ``.images``: tendency, segments)."""
    return _job(["stone"], [photo], flags, out, None, threads, progress)


def decay(
    photo: ImageLike,
    *,
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    progress: Optional[Progress] = None,
    **flags: Any,
) -> Result:
    """Make an object in a photo decay over time (``patina decay``): ``.frames``."""
    return _job(["decay"], [photo], flags, out, None, threads, progress)


def decay_texture(
    *, out: Optional[PathLike] = None, threads: Optional[int] = None, progress: Optional[Progress] = None, **flags: Any
) -> Result:
    """A decay texture of any size, procedural or from ``exemplar=`` (``patina decay-texture``): ``.image``."""
    return _job(["decay-texture"], [], flags, out, "texture.png", threads, progress)


class _Stbrdf:
    """Spatio-temporal BRDF materials (``patina stbrdf``). Materials are folders."""

    @staticmethod
    def fit(
        capture: Union[Sequence[ImageLike], str, "os.PathLike[str]"],
        *,
        out: PathLike,
        threads: Optional[int] = None,
        progress: Optional[Progress] = None,
        **flags: Any,
    ) -> Result:
        """Fit a material to a time-lapse capture (frames or a folder) into the folder ``out``."""
        return _job(["stbrdf", "fit"], [_Frames(capture)], flags, out, None, threads, progress)

    @staticmethod
    def enlarge(
        material: Union[str, "os.PathLike[str]"],
        *,
        out: PathLike,
        threads: Optional[int] = None,
        progress: Optional[Progress] = None,
        **flags: Any,
    ) -> Result:
        """Enlarge a material folder into the folder ``out``."""
        return _job(["stbrdf", "enlarge"], [material], flags, out, None, threads, progress)

    @staticmethod
    def transfer(
        material: Union[str, "os.PathLike[str]"],
        target: ImageLike,
        *,
        out: PathLike,
        threads: Optional[int] = None,
        progress: Optional[Progress] = None,
        **flags: Any,
    ) -> Result:
        """Carry a material's change over time onto a photo, into the folder ``out``."""
        return _job(["stbrdf", "transfer"], [material, target], flags, out, None, threads, progress)

    @staticmethod
    def render(
        material: Union[str, "os.PathLike[str]"],
        *,
        out: Optional[PathLike] = None,
        threads: Optional[int] = None,
        progress: Optional[Progress] = None,
        **flags: Any,
    ) -> Result:
        """Render a material's previews over time: ``.frames`` and ``.images`` (maps, plane, sphere)."""
        return _job(["stbrdf", "render"], [material], flags, out, None, threads, progress)


stbrdf = _Stbrdf()


# ----------------------------------------------------------------------------
# Plumbing


class _Frames:
    """A sequence argument: a folder or GIF path, or a list of frames to write into a folder."""

    def __init__(self, value):
        self.value = value


def _normalised(a: np.ndarray) -> np.ndarray:
    if a.dtype == np.float64 or a.dtype == np.float16:
        a = a.astype(np.float32)
    if a.dtype not in (np.uint8, np.uint16, np.float32):
        raise ValueError(f"arrays must be uint8, uint16 or float32, not {a.dtype}")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[2] not in (1, 3, 4):
        raise ValueError(f"an image array must be HxW, HxWx1, HxWx3 or HxWx4, not shape {tuple(a.shape)}")
    if a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"an image array must not be empty (shape {tuple(a.shape)})")
    return np.ascontiguousarray(a)


def _write_array(a: np.ndarray, folder: str, name: str) -> str:
    a = _normalised(a)
    ext = ".exr" if a.dtype == np.float32 else ".png"
    path = os.path.join(folder, name + ext)
    _native.write_image(path, a.tobytes(), a.shape[0], a.shape[1], a.shape[2], str(a.dtype))
    return path


class _Inputs:
    """Turns arguments into command-line words, writing arrays to files in a scratch folder."""

    def __init__(self, scratch: str):
        self.scratch = scratch
        self.count = 0

    def word(self, value: Any) -> str:
        if isinstance(value, np.ndarray):
            self.count += 1
            return _write_array(value, self.scratch, f"input{self.count}")
        if isinstance(value, _Frames):
            v = value.value
            if isinstance(v, (str, os.PathLike)):
                return os.fspath(v)
            frames = list(v)
            if not frames:
                raise ValueError("the sequence has no frames")
            self.count += 1
            folder = os.path.join(self.scratch, f"frames{self.count}")
            os.mkdir(folder)
            for i, f in enumerate(frames):
                if isinstance(f, np.ndarray):
                    _write_array(f, folder, f"{i:05d}")
                else:
                    src = os.fspath(f)
                    shutil.copyfile(src, os.path.join(folder, f"{i:05d}{Path(src).suffix.lower()}"))
            return folder
        if isinstance(value, os.PathLike):
            return os.fspath(value)
        return str(value)

    def flag_words(self, flags: Dict[str, Any]) -> List[str]:
        words: List[str] = []
        for key, value in flags.items():
            if value is None or value is False:
                continue
            flag = "--" + key.replace("_", "-")
            if value is True:
                words.append(flag)
            elif isinstance(value, range):
                if value.step != 1:
                    raise ValueError(f"{key}: a frame range must have step 1")
                words += [flag, f"{value.start}..{value.stop}"]
            elif isinstance(value, (tuple, list)) and not isinstance(value, str):
                if key in _SIZE_FLAGS and len(value) == 2:
                    words += [flag, f"{int(value[0])}x{int(value[1])}"]
                else:
                    words += [flag, ",".join(_number(v) for v in value)]
            elif isinstance(value, float):
                words += [flag, _number(value)]
            else:
                words += [flag, self.word(value)]
        return words


def _number(v: Any) -> str:
    return repr(float(v)) if isinstance(v, float) else str(v)


def _job(
    command: List[str],
    positional: List[Any],
    flags: Dict[str, Any],
    out,
    default_name: Optional[str],
    threads: Optional[int],
    progress: Optional[Progress],
    kind=Result,
):
    scratch = tempfile.mkdtemp(prefix="patina-")
    try:
        inputs = _Inputs(scratch)
        words = command + [inputs.word(p) for p in positional] + inputs.flag_words(flags)
        if out is None:
            target = Path(scratch) / (default_name or "out")
            keep = None
        else:
            target = Path(os.fspath(out))
            keep = target
        words += ["-o", str(target)]
        written = _native.run(words, threads=threads, progress=progress)
        folder_output = default_name is None
        base = target if folder_output else target.parent
        manifest_file = target / "manifest.json" if folder_output else Path(str(target) + ".manifest.json")
        with open(manifest_file, encoding="utf-8") as f:
            manifest = json.load(f)
        images = {}
        base_resolved = base.resolve()
        for path, h, w, c, data in written:
            p = Path(path)
            try:
                key = p.resolve().relative_to(base_resolved).as_posix()
            except ValueError:
                key = p.as_posix()
            images[key] = np.frombuffer(data, dtype="<f4").reshape(h, w, c)
        return kind(manifest, images, keep)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def _with_flag_reference(function: Callable[..., Any], command: str) -> None:
    """Append the CLI's flag reference (every flag with its default) to a job's docstring."""
    function.__doc__ = (
        f"{function.__doc__}\n\nKeyword arguments are the flags of `patina {command}` (foo_bar=... is --foo-bar ...):\n\n"
        + _native.help(command.split())
    )


for _function, _command in [
    (synth, "synth"),
    (weather, "weather"),
    (age_map, "age-map"),
    (intact, "intact"),
    (weather_transfer, "weather-transfer"),
    (ttf, "ttf"),
    (stone, "stone"),
    (decay, "decay"),
    (decay_texture, "decay-texture"),
    (_Stbrdf.fit, "stbrdf fit"),
    (_Stbrdf.enlarge, "stbrdf enlarge"),
    (_Stbrdf.transfer, "stbrdf transfer"),
    (_Stbrdf.render, "stbrdf render"),
]:
    _with_flag_reference(_function, _command)
