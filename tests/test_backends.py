"""Backends: local processes and Ray give the same rows as a serial run for the same seeds."""

import signal

import pandas as pd
import pytest

from mjsuff.cli import main
from mjsuff.experiment.backend import ReplicateTask, shared_threads
from mjsuff.experiment.backends import BackendError, LocalBackend, SerialBackend, make_backend
from mjsuff.experiment.run_summary import RECORDING
from mjsuff.experiment.runner import run_scenario
from mjsuff.recording import Recording
from tests.conftest import small_scenario


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    directory = tmp_path_factory.mktemp("serial") / "run"
    run_scenario(small_scenario(replicates=3), directory, backend=SerialBackend())
    return directory


def test_local_processes_match_serial(serial_run, tmp_path):
    progress = []
    result = run_scenario(
        small_scenario(replicates=3),
        tmp_path / "local",
        progress=lambda *a: progress.append(a),
        backend=LocalBackend(2),
    )
    assert result.completed == 3
    pd.testing.assert_frame_equal(
        pd.read_parquet(serial_run / "steps.parquet"), pd.read_parquet(tmp_path / "local" / "steps.parquet")
    )
    assert (serial_run / "summary.json").read_bytes() == (tmp_path / "local" / "summary.json").read_bytes()
    # Per-demo progress came back from the workers, and it ends at all replicates done.
    assert any(0 < done % 1 for _, _, done in progress)
    assert progress[-1] == (3, 3, 3)
    # The replicates' recordings were merged into one file holding all of them, parts removed.
    paths = Recording(tmp_path / "local" / RECORDING).entity_paths()
    assert {"/r0/posterior/samples", "/r1/posterior/samples", "/r2/posterior/samples"} <= paths
    assert not (tmp_path / "local" / "recordings").exists()


def test_ray_matches_serial(serial_run, tmp_path):
    pytest.importorskip("ray", reason="the ray extra is not installed")
    backend = make_backend("ray", workers=2)
    sigterm = signal.getsignal(signal.SIGTERM)
    try:
        run_scenario(small_scenario(replicates=3), tmp_path / "ray", backend=backend, record=False)
        # ray.init's own SIGTERM handler does not stay: the caller's acts during the run.
        assert signal.getsignal(signal.SIGTERM) is sigterm
    finally:
        backend.shutdown()
    pd.testing.assert_frame_equal(
        pd.read_parquet(serial_run / "steps.parquet"), pd.read_parquet(tmp_path / "ray" / "steps.parquet")
    )


@pytest.mark.parametrize(
    ("cores", "replicates", "threads"), [(8, 1, 8), (8, 2, 4), (8, 3, 2), (2, 5, 1), (1, 1, 1)]
)
def test_replicates_at_once_share_the_cores(cores, replicates, threads):
    assert shared_threads(cores, replicates) == threads


@pytest.mark.parametrize(("cores", "replicates"), [(4, 0), (0, 2)])
def test_shared_threads_needs_a_core_and_a_replicate(cores, replicates):
    with pytest.raises(ValueError, match="must be ≥ 1"):
        shared_threads(cores, replicates)


def test_backend_choices_are_checked():
    with pytest.raises(BackendError, match="--workers"):
        LocalBackend(0)
    with pytest.raises(BackendError, match="--backend"):
        make_backend("slurm")
    assert isinstance(make_backend("local", workers=1), SerialBackend)
    with pytest.raises(BackendError, match="--cpus-per-task: only with --backend ray"):
        make_backend("local", workers=2, cpus_per_task=2)


def test_cpus_per_task_is_checked_before_any_replicate_runs():
    """A replicate asking for more CPUs than the local instance has would never be scheduled:
    connecting says so (the CLI connects before it writes anything); a cluster may have larger
    nodes, so there it is not checked."""
    pytest.importorskip("ray", reason="the ray extra is not installed")
    from mjsuff.experiment.ray_backend import RayBackend

    with pytest.raises(BackendError, match="--cpus-per-task: expected a positive number, got 0"):
        RayBackend(cpus_per_task=0)
    for address in (None, "local"):
        backend = RayBackend(address, cpus_per_task=4)
        backend.ray = _FakeRay(2)
        with pytest.raises(BackendError, match=r"the local Ray instance has 2 CPUs.*expected at most 2"):
            backend.connect()
    backend = RayBackend("10.0.0.1:6379", cpus_per_task=4)
    backend.ray = _FakeRay(2)
    backend.connect()  # already connected (the fake), a cluster: no check
    assert backend.task_cpus(3) == 4

    class NotStarted(_FakeRay):
        def is_initialized(self):
            return False

        def init(self, **options):
            pytest.fail("started an instance only to refuse it")

    backend = RayBackend(None, num_cpus=2, cpus_per_task=4)
    backend.ray = NotStarted(2)
    with pytest.raises(BackendError, match=r"has 2 CPUs \(--workers sets them\)"):
        backend.connect()


def test_cpus_per_task_with_another_backend_is_one_line_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["run", "gridworld", "--out", str(out), "--cpus-per-task", "2"]) == 2
    assert not out.exists()
    assert (
        capsys.readouterr().err.strip()
        == "error: --cpus-per-task: only with --backend ray (got --backend local)"
    )


class _FakeRay:
    """Ray's calls the backend makes, in this process: records each remote's CPUs and threads."""

    def __init__(self, cpus):
        self.cpus, self.reserved, self.threads = cpus, [], []

    def is_initialized(self):
        return True

    def cluster_resources(self):
        return {"CPU": float(self.cpus)}

    def remote(self, num_cpus):
        self.reserved.append(num_cpus)
        fake = self

        class Remote:
            @staticmethod
            def remote(task, threads):
                fake.threads.append(threads)
                return task.replicate

        return lambda fn: Remote

    def wait(self, refs, num_returns):
        return refs[:num_returns], refs[num_returns:]

    def get(self, ref):
        return ref


@pytest.mark.parametrize(
    ("address", "instance_cpus", "cpus_per_task", "replicates", "cpus"),
    [
        (None, 2, None, 1, 2),  # one replicate on a local instance gets its CPUs (one before stop 61)
        (None, 2, None, 3, 1),
        (None, 8, None, 3, 2),
        ("local", 4, None, 1, 4),
        (None, 8, 3, 1, 3),  # asked for: as asked
        ("10.0.0.1:6379", 8, None, 1, 1),  # a cluster's nodes may each have fewer
    ],
)
def test_ray_tasks_share_the_cpus_of_a_local_instance(
    address, instance_cpus, cpus_per_task, replicates, cpus
):
    """The CPUs are the running instance's (it may be one the caller started with fewer than
    this machine has: a task asking for more would never be scheduled)."""
    pytest.importorskip("ray", reason="the ray extra is not installed")
    from mjsuff.experiment.ray_backend import RayBackend

    backend = RayBackend(address, num_cpus=64, cpus_per_task=cpus_per_task)
    backend.ray = _FakeRay(instance_cpus)
    scenario = small_scenario(replicates=replicates)
    tasks = [ReplicateTask((0, r), scenario, r) for r in range(replicates)]
    assert sorted(result for _, result in backend.run(tasks)) == list(range(replicates))
    assert backend.ray.reserved == [cpus] and backend.ray.threads == [cpus] * replicates
