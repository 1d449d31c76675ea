"""Demo-set files: the executed demonstrations of one scene instance, validated on load.

A demo set is one ``.npz`` file (arrays only, no pickles) that holds, for ``N`` demos of ``T``
steps: ``start_index (N,)`` (demonstration-pool start), ``start_qpos (N, nq)``, ``qpos (N, T, nq)``,
``qvel (N, T, nv)``, ``controls (N, T, nu)``, ``features (N, k)``, ``intended``/``executed``
``(N, T, d)`` task-space paths (m), ``tracking_error (N,)`` (m), ``poor (N,)`` and ``meta``, a
JSON string: format version, scene, scenario seed and replicate, an instance fingerprint, scene
parameters, expert settings, feature names, mjsuff and MuJoCo versions.

What the learner must not read lives apart, in ``NAME.truth.json`` beside it: the true weights
``w*`` and each demo's value under them. Files are written atomically (a temporary file, then a
rename), so an interrupted write never leaves a half-written demo set.
"""

from __future__ import annotations

import json
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mjsuff.atomic import atomic_write
from mjsuff.errors import MjsuffError

FORMAT_VERSION = 1
ARRAYS = (
    "start_index",
    "start_qpos",
    "qpos",
    "qvel",
    "controls",
    "features",
    "intended",
    "executed",
    "tracking_error",
    "poor",
)


class DemoFileError(MjsuffError, ValueError):
    """A demo-set file that cannot be used; the message names the file and what is wrong."""


@dataclass
class DemoSet:
    """Demonstrations of one scene instance (see the module docs for the arrays' shapes)."""

    arrays: dict[str, np.ndarray]
    meta: dict[str, Any]
    true_weights: np.ndarray | None = None
    values: np.ndarray | None = field(default=None)

    def __len__(self) -> int:
        return len(self.arrays["start_index"])

    def save(self, path: str | Path) -> Path:
        """Write ``path`` (.npz) and, when the truth is known, ``path``'s ``.truth.json``."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_suffix(".npz")
        path.parent.mkdir(parents=True, exist_ok=True)
        meta = json.dumps({**self.meta, "format_version": FORMAT_VERSION})
        # numpy's stubs type savez's **kwds as its allow_pickle flag; they are arrays.
        arrays: dict[str, Any] = {"meta": np.array(meta), **self.arrays}
        atomic_write(path, lambda f: np.savez_compressed(f, **arrays))
        if self.true_weights is not None:
            truth = {
                "true_weights": self.true_weights.tolist(),
                "values": None if self.values is None else self.values.tolist(),
            }
            atomic_write(truth_path(path), lambda f: f.write(json.dumps(truth, indent=1).encode()))
        return path


def truth_path(path: str | Path) -> Path:
    """Where the true weights of demo set ``path`` are kept."""
    path = Path(path)
    return path.with_name(path.stem + ".truth.json")


def load_demo_set(path: str | Path, expect: dict[str, Any] | None = None, truth: bool = False) -> DemoSet:
    """Read and validate a demo set.

    Args:
        path: The ``.npz`` file.
        expect: Metadata it must match (e.g. ``{"scene": ..., "instance": ...}``), or None.
        truth: Also read the true weights (scoring only; the learner never asks for them).

    Raises:
        DemoFileError: Unreadable, truncated or corrupt file, missing or misshapen arrays,
            non-finite values, or metadata that does not match ``expect``.
    """
    path = Path(path)
    if not path.is_file():
        raise DemoFileError(f"{path}: no such demo file")
    try:
        with np.load(path, allow_pickle=False) as data:
            contents = {name: data[name] for name in data.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise DemoFileError(f"{path}: not a readable demo-set file ({type(exc).__name__}: {exc})") from None
    missing = [name for name in ("meta", *ARRAYS) if name not in contents]
    if missing:
        raise DemoFileError(f"{path}: missing arrays {missing}; a demo set holds {['meta', *ARRAYS]}")
    try:
        meta = json.loads(str(contents.pop("meta")))
    except json.JSONDecodeError as exc:
        raise DemoFileError(f"{path}: field 'meta' is not valid JSON ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format_version") != FORMAT_VERSION:
        raise DemoFileError(
            f"{path}: field 'meta.format_version': expected {FORMAT_VERSION}, "
            f"got {meta.get('format_version') if isinstance(meta, dict) else meta!r}"
        )
    _check_shapes(path, contents, meta)
    for key, wanted in (expect or {}).items():
        if meta.get(key) != wanted:
            raise DemoFileError(
                f"{path}: field 'meta.{key}': expected {wanted!r}, got "
                f"{meta.get(key)!r} (a demo set of another scene or instance)"
            )
    demo_set = DemoSet(contents, meta)
    if truth:
        tpath = truth_path(path)
        try:
            data = json.loads(tpath.read_text())
            demo_set.true_weights = np.asarray(data["true_weights"], dtype=float)
            demo_set.values = None if data["values"] is None else np.asarray(data["values"], float)
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise DemoFileError(f"{tpath}: not a readable truth file ({type(exc).__name__}: {exc})") from None
        if demo_set.true_weights.shape != (meta["num_features"],):
            raise DemoFileError(
                f"{tpath}: field 'true_weights': expected {meta['num_features']} "
                f"values, got shape {demo_set.true_weights.shape}"
            )
    return demo_set


def _check_shapes(path: Path, a: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    try:
        nq, nv, nu, k = (int(meta[key]) for key in ("nq", "nv", "nu", "num_features"))
        steps, d = int(meta["steps"]), int(meta["path_dims"])
    except (KeyError, TypeError, ValueError) as exc:
        raise DemoFileError(
            f"{path}: field 'meta' lacks the sizes nq/nv/nu/num_features/steps/path_dims ({exc})"
        ) from None
    n = a["start_index"].shape[0] if a["start_index"].ndim == 1 else -1
    expected = {
        "start_index": (n,),
        "start_qpos": (n, nq),
        "qpos": (n, steps, nq),
        "qvel": (n, steps, nv),
        "controls": (n, steps, nu),
        "features": (n, k),
        "intended": (n, steps, d),
        "executed": (n, steps, d),
        "tracking_error": (n,),
        "poor": (n,),
    }
    for name, shape in expected.items():
        if a[name].shape != shape:
            raise DemoFileError(f"{path}: array '{name}': expected shape {shape}, got {a[name].shape}")
        if a[name].dtype.kind == "f" and not np.isfinite(a[name]).all():
            raise DemoFileError(f"{path}: array '{name}': non-finite values")
    if a["poor"].dtype != bool or a["start_index"].dtype.kind != "i":
        raise DemoFileError(f"{path}: arrays 'poor' and 'start_index' must be bool and int")
