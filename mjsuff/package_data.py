"""Data files shipped inside the package: the MJCF models and the scenario files.

Their sources are the repository's top-level ``models/`` and ``scenarios/`` folders (one copy in
git); pyproject.toml maps those folders onto the packages ``mjsuff.models`` and
``mjsuff.scenarios`` (``package-dir``), so a wheel, ``pip install .`` and an editable install all
carry them. They are read from wherever those packages were imported from.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

#: The package's folder; its parent is the repository root in a source checkout.
_PACKAGE = Path(__file__).resolve().parent


def data_dir(package: str) -> Path:
    """The folder of a data package (``mjsuff.models``, ``mjsuff.scenarios``) as installed.

    A source checkout whose install predates the mapping (or that is only on ``PYTHONPATH``) has
    no such package: there the repository's top-level folder of that name is the answer. Anywhere
    else the folder the package should have (which may not exist: a broken install).
    """
    folder = package.rpartition(".")[2]
    try:
        return Path(str(resources.files(package)))
    except ModuleNotFoundError:
        checkout = _PACKAGE.parent
        if (checkout / "pyproject.toml").is_file() and (checkout / folder).is_dir():
            return checkout / folder
        return _PACKAGE / folder
