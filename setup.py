"""Packages: those under mjsuff/, plus the data folders pyproject.toml maps into the package.

pyproject.toml cannot list packages it finds *and* packages mapped from other folders (its
``packages`` is either a ``find`` or a list), so the list is built here: a new subpackage under
mjsuff/ ships without editing a list.
"""

from setuptools import find_namespace_packages, setup

setup(
    packages=[*find_namespace_packages(include=["mjsuff", "mjsuff.*"]), "mjsuff.models", "mjsuff.scenarios"]
)
