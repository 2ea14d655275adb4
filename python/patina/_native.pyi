"""The native half of patina (Rust, pyo3): runs the CLI's jobs in-process. Use the functions in `patina` instead."""

from typing import Any, Callable, List, Optional, Tuple

def run(
    args: List[str],
    *,
    threads: Optional[int] = None,
    progress: Optional[Callable[[str, int, int], Any]] = None,
) -> List[Tuple[str, int, int, int, bytearray]]:
    """Run one patina command line (without the program name) in-process.

    Returns the images it wrote as (path, height, width, channels, little-endian float32 samples).
    Raises ValueError for bad input, RuntimeError for internal errors, KeyboardInterrupt when cancelled.
    """

def write_image(path: str, data: bytes, height: int, width: int, channels: int, dtype: str) -> None:
    """Write C-ordered samples as an image the CLI reads back exactly: uint8/uint16 -> PNG, float32 -> EXR."""

def read_image(path: str) -> Tuple[int, int, int, bytearray]:
    """Read an image file the CLI's way: (height, width, channels, little-endian float32 samples)."""

def write_gif(frames: List[str], path: str, delay_ms: int) -> None:
    """Write an animated GIF of image files in order, one palette for all frames, as the CLI's previews."""

def help(args: List[str]) -> str:
    """The CLI's --help text for a command line (e.g. ["synth"])."""

def version() -> str:
    """The patina version this module was built from."""
