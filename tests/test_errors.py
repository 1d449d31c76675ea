"""One error family (``mjsuff.errors.MjsuffError``): what the CLI reports as one line, and only that."""

import pytest

from mjsuff.cli import main
from mjsuff.domains import UnknownDomainError
from mjsuff.errors import MjsuffError, UsageError
from mjsuff.experiment.backends import BackendError, ClusterConnectionError
from mjsuff.experiment.results import OutputError
from mjsuff.experiment.scenario import ScenarioError
from mjsuff.experts.demo_set import DemoFileError
from mjsuff.posterior.calibration import CalibrationError
from mjsuff.report.results import ReportError


@pytest.mark.parametrize(
    ("error", "builtin"),
    [
        (ScenarioError, ValueError),
        (DemoFileError, ValueError),
        (CalibrationError, ValueError),
        (ReportError, ValueError),
        (UsageError, ValueError),
        (OutputError, OSError),
        (BackendError, RuntimeError),
        (UnknownDomainError, KeyError),
    ],
)
def test_every_user_facing_error_is_an_mjsuff_error_and_keeps_its_builtin(error, builtin):
    assert issubclass(error, MjsuffError) and issubclass(error, builtin)
    assert error.exit_code == 2


def test_an_unusable_cluster_has_its_own_exit_status():
    assert issubclass(ClusterConnectionError, BackendError) and ClusterConnectionError.exit_code == 69


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (
            ["demos", "lava_reacher", "--replicate", "-1"],
            "--replicate: expected a replicate index ≥ 0, got -1",
        ),
        (["demos", "gridworld"], "gridworld: domain.name: demos are generated for the MuJoCo scenes"),
        (["calibrate", "gridworld", "--instances", "0"], "--instances: expected a positive number, got 0"),
    ],
)
def test_bad_option_values_are_one_line_naming_the_option(args, expected, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert expected in err and "\n" not in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())  # nothing written
