"""Packaging: the wheel carries the MJCF models and the shipped scenarios, and runs anywhere.

The wheel is built from a copy of the sources (so the checkout gets no build/ folder), installed
into a fresh venv (``--system-site-packages`` for the dependencies, ``--no-deps`` for mjsuff) and
run from a directory outside the checkout: what a user of ``pip install .`` gets.
"""

import json
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from mjsuff.package_data import data_dir

ROOT = Path(__file__).resolve().parent.parent
#: What a build reads: the project files and the three folders that ship.
SOURCES = ("pyproject.toml", "setup.py", "README.md", "mjsuff", "models", "scenarios")
#: The smallest lava-reacher run that still simulates the model, asks the expert and plans.
TINY = [
    "--replicates",
    "1",
    "--backend",
    "serial",
    "--no-record",
    "--set",
    "domain.params.eval_starts=2",
    "--set",
    "domain.params.horizon=1.0",
    "--set",
    "demos.max_demos=1",
    "--set",
    "posterior.num_samples=100",
    "--set",
    "domain.params.planning.planner={population=16, elites=4, iterations=2}",
    "--set",
    "domain.params.planning.seed_planner={population=16, elites=4, iterations=2}",
    "--set",
    "domain.params.planning.seed_directions=1",
    "--set",
    "domain.params.planning.refine_rounds=0",
    "--set",
    "domain.params.planning.truth_scale=1.0",
    "--set",
    "domain.params.expert.refine_rounds=0",
    "--set",
    "rules.validation_intervals=[2]",
    "--set",
    "rules.patience=[1]",
]
#: Without PYTHONPATH, nothing but the venv decides where mjsuff is imported from.
ENV = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}


def sh(*command: str | Path, cwd: Path | None = None, timeout: float = 300) -> str:
    """Run a command; its stdout, or a failure showing its output."""
    proc = subprocess.run(
        [str(c) for c in command],
        cwd=cwd,
        env=ENV,
        capture_output=True,
        text=True,
        timeout=timeout,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, f"{command} exited {proc.returncode}:\n{proc.stdout}\n{proc.stderr}"
    return proc.stdout


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    source = tmp_path_factory.mktemp("source")
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(ROOT / name, source / name)
    out = tmp_path_factory.mktemp("wheel")
    sh(sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", out, source)
    (built,) = out.glob("mjsuff-*.whl")
    return built


def test_data_dirs_are_the_top_level_folders_here():
    # The checkout's own folders, whether through the mapped packages (an install made from this
    # pyproject.toml) or directly (a source checkout or an older editable install).
    assert data_dir("mjsuff.models").resolve() == ROOT / "models"
    assert data_dir("mjsuff.scenarios").resolve() == ROOT / "scenarios"


def test_wheel_carries_models_scenarios_and_every_module(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for folder, pattern in (("models", "*.xml"), ("scenarios", "*.toml")):
        files = sorted(p.name for p in (ROOT / folder).glob(pattern))
        assert files
        assert {f"mjsuff/{folder}/{f}" for f in files} <= names
    modules = {p.relative_to(ROOT).as_posix() for p in (ROOT / "mjsuff").rglob("*.py")}
    assert modules - names == set()  # setup.py finds every subpackage


def test_wheel_runs_a_scene_outside_the_checkout(wheel, tmp_path):
    venv = tmp_path / "venv"
    sh(sys.executable, "-m", "venv", "--without-pip", "--system-site-packages", venv)
    python, mjsuff = venv / "bin" / "python", venv / "bin" / "mjsuff"
    sh(python, "-m", "pip", "install", "-q", "--no-deps", wheel)  # the base's pip, into the venv
    work = tmp_path / "work"
    work.mkdir()
    assert ROOT not in work.parents
    where = json.loads(
        sh(
            python,
            "-c",
            "import json, mjsuff; from mjsuff.scenes.scene import "
            "model_path; print(json.dumps([mjsuff.__file__, "
            "str(model_path('lava_reacher.xml'))]))",
            cwd=work,
        )
    )
    site = venv / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "site-packages"
    assert [Path(p) for p in where] == [
        site / "mjsuff" / "__init__.py",
        site / "mjsuff" / "models" / "lava_reacher.xml",
    ]
    # `mjsuff scenarios` lists the wheel's copies; `mjsuff run NAME` runs one of them.
    shipped = json.loads(sh(mjsuff, "scenarios", "--json", cwd=work))
    assert {s["name"] for s in shipped} == {p.stem for p in (ROOT / "scenarios").glob("*.toml")}
    assert all(Path(s["path"]).parent == site / "mjsuff" / "scenarios" for s in shipped)
    assert "lava_reacher" in sh(mjsuff, "scenarios", cwd=work)
    printed = sh(mjsuff, "run", "lava_reacher", "--out", "run", *TINY, cwd=work)
    assert "steps simulated" in printed
    summary = json.loads((work / "run" / "summary.json").read_text())
    assert {e["rule"] for e in summary["entries"]} == {"nevd", "piob", "patience", "validation"}
    assert 'name = "lava_reacher"' in (work / "run" / "config.toml").read_text()
