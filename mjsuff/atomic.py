"""Atomic files: whatever mjsuff writes appears whole or not at all.

A file is written to a temporary file beside it and renamed over the target (``os.replace``, atomic
on one filesystem), so a killed or failing writer never leaves a half-written file; on any error
the temporary file is removed. The new file gets the mode an ordinary ``open`` would give it under
the process umask (temporary files are created 0600).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

import pandas as pd


def _file_mode() -> int:
    """Mode of a new file under the process umask."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


FILE_MODE = _file_mode()


def atomic_write(path: Path, write: Callable[[BinaryIO], object]) -> None:
    """Call ``write`` on a binary file that becomes ``path`` only once ``write`` returns."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as handle:
            write(handle)
        os.chmod(tmp, FILE_MODE)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    atomic_write(path, lambda handle: handle.write(data))


def atomic_write_text(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    atomic_write_bytes(path, text.encode())


def atomic_write_parquet(path: Path, frame: pd.DataFrame) -> None:
    """Write ``frame`` (without its index) to the parquet file ``path`` atomically."""
    atomic_write(path, lambda handle: frame.to_parquet(handle, index=False))
