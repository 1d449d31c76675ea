"""A Rerun recording of a whole ``mjsuff run``: what the robot saw, believed, planned, and why it
stopped, streamed to ``DIR/recording.rrd`` as the run goes (memory does not grow with its length).

Per replicate ``R`` (entity root ``rR``), on the ``demo`` timeline (the demo step) and, for playing
trajectories back, the ``sim_time`` timeline:

* ``rR/scene`` or ``rR/grid`` — the instance, each demo, and π_MAP (``mjsuff.recording.views``);
* ``rR/posterior/samples`` — posterior samples coloured by their nEVD (blue low, yellow high): the
  weights themselves for k = 3 (the unit sphere is drawn), otherwise their projection on the
  samples' 3 principal axes; ``w_map`` and ``w_true`` marked;
* ``rR/rules/KIND_PARAM/{bound,threshold,true_value}`` — the steps.parquet values as series
  (``true_value`` logged when the replicate ends, against the truth it ends with: a scene's truth
  is raised then, so the values seen at each step would be stale);
* ``rR/log`` — each demo and each rule's first stop as text (the stops logged at the end, with
  that truth), and how the end raised the truth; ``run/scenario`` — the resolved scenario (TOML,
  static).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from mjsuff.domain import Demo, Domain, Policy
from mjsuff.domains import get_domain
from mjsuff.experiment.scenario import Scenario
from mjsuff.recording.views import DomainView

LOW, HIGH = np.array([40, 60, 200]), np.array([250, 220, 40])


def blueprint(
    scenario: Scenario | None = None, replicate: int = 0, eye: tuple[np.ndarray, np.ndarray] | None = None
) -> rrb.Blueprint:
    """The layout a recording opens on: the scene and the decisions log; the posterior; the
    bounds against the truth, one tab per rule kind (of ``scenario``'s rules); the scenario.
    ``eye`` (position, look target) places the scene camera."""
    root = f"/r{replicate}"
    kinds = ("nevd", "piob", "patience", "validation")
    params: dict[str, Sequence[float]] = {"nevd": [], "piob": [], "patience": [], "validation": []}
    if scenario is not None:
        rules = scenario.rules
        params = {
            "nevd": rules.nevd_thresholds,
            "piob": rules.piob_thresholds,
            "patience": rules.patience,
            "validation": rules.validation_intervals,
        }
    series = [
        rrb.TimeSeriesView(
            name=f"{kind} rule",
            origin=f"{root}/rules",
            contents=[f"$origin/{kind}_{p:g}/**" for p in params[kind]] or [f"$origin/{kind}_*"],
        )
        for kind in kinds
        if params[kind] or scenario is None
    ]
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial3DView(
                    name="scene",
                    origin=root,
                    contents=[f"{root}/scene/**", f"{root}/grid/**"],
                    eye_controls=None
                    if eye is None
                    else rrb.EyeControls3D(position=eye[0], look_target=eye[1], eye_up=[0, 0, 1]),
                ),
                rrb.TextLogView(name="decisions", origin=f"{root}/log"),
                row_shares=[3, 1],
            ),
            rrb.Vertical(
                rrb.Spatial3DView(name="posterior", origin=f"{root}/posterior"),
                rrb.Tabs(*series, name="bounds and truth"),
                rrb.TextDocumentView(name="scenario", origin="/run/scenario"),
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


def nevd_colours(nevd: np.ndarray) -> np.ndarray:
    """nEVD per sample -> RGB (blue at 0, yellow at the largest)."""
    top = max(float(np.nanmax(nevd)), 1e-12) if nevd.size else 1.0
    share = np.clip(np.nan_to_num(nevd / top), 0.0, 1.0)[:, None]
    return (LOW + share * (HIGH - LOW)).astype(np.uint8)


def project(samples: np.ndarray, *marks: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """k = 3: unchanged; otherwise coordinates on the samples' 3 principal axes (also applied to
    ``marks``)."""
    if samples.shape[1] == 3:
        return samples, list(marks)
    centre = samples.mean(axis=0)
    _, _, vt = np.linalg.svd(samples - centre, full_matrices=False)
    basis = vt[:3].T
    return (samples - centre) @ basis, [(m - centre) @ basis for m in marks]


def rule_path(row: dict[str, Any]) -> str:
    return f"{row['rule']}_{row['param']:g}"


class ReplicateRecorder:
    """Records one replicate (an observer of ``run_replicate``)."""

    def __init__(self, recording: rr.RecordingStream, replicate: int, scenario: Scenario) -> None:
        self.recording = recording
        self.replicate = replicate
        self.scenario = scenario
        self.root = f"r{replicate}"
        self.view: DomainView | None = None
        self.domain: Domain | None = None

    def begin(self, domain: Domain) -> None:
        self.domain = domain
        load_view = get_domain(self.scenario.domain.name).view
        self.view = (load_view() if load_view else DomainView)(domain, self.recording, self.root)
        self.view.log_instance()
        eye = self.view.eye()
        if self.replicate == 0 and eye is not None:
            # The default layout frames the first replicate's instance.
            self.recording.send_blueprint(
                blueprint(self.scenario, 0, eye), make_active=True, make_default=True
            )
        if domain.num_features == 3:
            self.recording.log(
                f"{self.root}/posterior/unit_sphere",
                rr.Ellipsoids3D(half_sizes=[[1, 1, 1]], colors=[[180, 180, 180]]),
                static=True,
            )

    def step(
        self,
        step: int,
        demo: Demo,
        samples: np.ndarray,
        nevd: np.ndarray,
        map_weights: np.ndarray,
        map_policy: Policy,
        rows: list[dict[str, Any]],
    ) -> None:
        if self.domain is None or self.view is None:
            raise RuntimeError("ReplicateRecorder.step before begin")
        rec, root = self.recording, self.root
        rec.set_time("demo", sequence=step)
        points, (w_map, w_true) = project(samples, map_weights, self.domain.true_weights)
        rec.log(f"{root}/posterior/samples", rr.Points3D(points, colors=nevd_colours(nevd), radii=0.01))
        rec.log(
            f"{root}/posterior/w_map",
            rr.Points3D([w_map], colors=[[20, 170, 60]], radii=0.04, labels=["w_MAP"]),
        )
        rec.log(
            f"{root}/posterior/w_true",
            rr.Points3D([w_true], colors=[[230, 30, 30]], radii=0.04, labels=["w*"]),
        )
        self.view.log_step(step, demo, map_policy)
        poor = " (a poor demo)" if demo.poor else ""
        rec.log(f"{root}/log", rr.TextLog(f"demo {step} from start {demo.start}{poor}", level="INFO"))
        for row in rows:
            path = f"{root}/rules/{rule_path(row)}"
            if np.isfinite(row["bound"]):
                rec.log(f"{path}/bound", rr.Scalars(row["bound"]))
            if row["rule"] in ("nevd", "piob"):
                rec.log(f"{path}/threshold", rr.Scalars(row["param"]))

    def end(self, rows: list[dict[str, Any]]) -> None:
        """The truth the replicate ended with: every row's ``true_value`` at its step, each rule's
        first stop, and how far the end raised the truth (at the last step)."""
        rec, root = self.recording, self.root
        stopped: set[str] = set()
        for row in sorted(rows, key=lambda r: r["step"]):
            path = f"{root}/rules/{rule_path(row)}"
            rec.set_time("demo", sequence=row["step"])
            rec.log(f"{path}/true_value", rr.Scalars(row["true_value"]))
            if row["decision"] and rule_path(row) not in stopped:
                stopped.add(rule_path(row))
                bound = f"bound {row['bound']:.3f}, " if np.isfinite(row["bound"]) else ""
                rec.log(
                    f"{root}/log",
                    rr.TextLog(
                        f"STOP {row['rule']} {row['param']:g} at demo {row['step']}: {bound}"
                        f"true {row['true_value']:.3f}",
                        level="WARN",
                    ),
                )
        if rows and rows[-1]["truth_raised_starts"]:
            last = rows[-1]
            rec.log(
                f"{root}/log",
                rr.TextLog(
                    f"ground truth raised at the replicate's end at {last['truth_raised_starts']} "
                    f"evaluation starts, by at most {last['truth_raise']:.3f} of V* - V_rand "
                    "(every true value above is scored against it)",
                    level="INFO",
                ),
            )


class RunRecorder:
    """The recording file of one run; ``replicate(r)`` gives each replicate's observer.

    The file is written as the run goes; ``close`` (also on Ctrl-C) completes it.
    """

    def __init__(self, path: Path, scenario: Scenario, default_layout: bool = True) -> None:
        self.path = Path(path)
        self.scenario = scenario
        self.recording = rr.RecordingStream(
            application_id="mjsuff", recording_id=f"{scenario.name}-seed{scenario.seed}"
        )
        self.recording.set_log_time_enabled(False)
        # Parts of one run merged later carry the default layout once (replicate 0's part).
        self.recording.save(str(self.path), default_blueprint=blueprint(scenario) if default_layout else None)
        self.recording.log(
            "run/scenario",
            rr.TextDocument(f"```toml\n{scenario.to_toml()}```", media_type=rr.MediaType.MARKDOWN),
            static=True,
        )

    def replicate(self, replicate: int) -> ReplicateRecorder:
        return ReplicateRecorder(self.recording, replicate, self.scenario)

    def close(self) -> None:
        self.recording.flush()
        self.recording.disconnect()
