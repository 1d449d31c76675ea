"""Kinesthetic experts: task-space paths chosen under the hidden reward, mink IK, MuJoCo execution,
and demo-set files."""

from mjsuff.experts.demo_set import DemoFileError, DemoSet, load_demo_set, truth_path
from mjsuff.experts.expert import ExecutedPaths, Expert, ExpertDemo, ExpertError, ExpertSettings
from mjsuff.experts.ik import IKFailure, IKSettings, JointReference, PathTracker
from mjsuff.experts.lander import LanderExpert
from mjsuff.experts.reacher import ReacherExpert

__all__ = [
    "DemoFileError",
    "DemoSet",
    "ExecutedPaths",
    "Expert",
    "ExpertDemo",
    "ExpertError",
    "ExpertSettings",
    "IKFailure",
    "IKSettings",
    "JointReference",
    "LanderExpert",
    "PathTracker",
    "ReacherExpert",
    "load_demo_set",
    "truth_path",
]
