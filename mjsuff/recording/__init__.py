"""Rerun recordings of runs: a MuJoCo scene logger, per-domain views, the run recorder, a reader."""

from mjsuff.recording.reader import Recording
from mjsuff.recording.recorder import ReplicateRecorder, RunRecorder, blueprint
from mjsuff.recording.scene_logger import SceneLogger, wxyz_to_xyzw
from mjsuff.recording.views import DomainView, SceneView, TabularView

__all__ = [
    "DomainView",
    "Recording",
    "ReplicateRecorder",
    "RunRecorder",
    "SceneLogger",
    "SceneView",
    "TabularView",
    "blueprint",
    "wxyz_to_xyzw",
]
