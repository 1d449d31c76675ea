"""Log a MuJoCo model's geometry and motion to Rerun (Rerun has no MJCF loader).

Entity layout under a root path ``ROOT``:

* ``ROOT/bodies/BODY`` — one entity per body, whose ``Transform3D`` is the body's world pose
  (translation in metres, quaternion xyzw), logged per time step;
* ``ROOT/bodies/BODY/geom_NAME`` — a static ``Transform3D`` with the geom's pose in its body's
  frame, and the shape: planes and boxes as ``Boxes3D``, capsules as ``Capsules3D``, cylinders as
  ``Cylinders3D``, spheres and ellipsoids as ``Ellipsoids3D``, meshes as ``Mesh3D``; sites the same
  way as ``site_NAME`` (height fields are skipped).

MuJoCo capsules and cylinders run along the geom's z axis and are centred on it; Rerun's capsules
start at the origin and run along +z, so they are shifted down by the half-length.
"""

from __future__ import annotations

import mujoco
import numpy as np
import rerun as rr

#: Size of an infinite MuJoCo plane when drawn (half-extent, metres).
INFINITE_PLANE = 5.0
#: Thickness of a drawn plane (half, metres).
PLANE_HALF_THICKNESS = 0.001


def wxyz_to_xyzw(quat: np.ndarray) -> np.ndarray:
    """MuJoCo's ``(w, x, y, z)`` quaternions ``(..., 4)`` in Rerun's ``(x, y, z, w)`` order."""
    quat = np.asarray(quat, dtype=float)
    return np.concatenate([quat[..., 1:], quat[..., :1]], axis=-1)


def _name(model: mujoco.MjModel, kind: mujoco.mjtObj, index: int, prefix: str) -> str:
    name = mujoco.mj_id2name(model, kind, index)
    return name if name else f"{prefix}{index}"


def _rgb(rgba: np.ndarray) -> list[int]:
    return [round(255 * float(c)) for c in np.clip(rgba, 0.0, 1.0)]


def _shape(
    model: mujoco.MjModel, kind: int, size: np.ndarray, rgba: np.ndarray, mesh: int = -1
) -> rr.AsComponents | None:
    """The Rerun archetype of one geom or site, in its own frame (None for unsupported kinds)."""
    g = mujoco.mjtGeom
    color = [_rgb(rgba)]
    if kind == g.mjGEOM_PLANE:
        hx = size[0] if size[0] > 0 else INFINITE_PLANE
        hy = size[1] if size[1] > 0 else INFINITE_PLANE
        return rr.Boxes3D(
            half_sizes=[[hx, hy, PLANE_HALF_THICKNESS]],
            centers=[[0, 0, -PLANE_HALF_THICKNESS]],
            colors=color,
            fill_mode="solid",
        )
    if kind == g.mjGEOM_BOX:
        return rr.Boxes3D(half_sizes=[size[:3]], colors=color, fill_mode="solid")
    if kind == g.mjGEOM_SPHERE:
        return rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], colors=color, fill_mode="solid")
    if kind == g.mjGEOM_ELLIPSOID:
        return rr.Ellipsoids3D(half_sizes=[size[:3]], colors=color, fill_mode="solid")
    if kind == g.mjGEOM_CAPSULE:
        return rr.Capsules3D(
            lengths=[2 * size[1]], radii=[size[0]], translations=[[0, 0, -size[1]]], colors=color
        )
    if kind == g.mjGEOM_CYLINDER:
        return rr.Cylinders3D(lengths=[2 * size[1]], radii=[size[0]], colors=color)
    if kind == g.mjGEOM_MESH and mesh >= 0:
        v0, nv = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        f0, nf = model.mesh_faceadr[mesh], model.mesh_facenum[mesh]
        return rr.Mesh3D(
            vertex_positions=model.mesh_vert[v0 : v0 + nv],
            triangle_indices=model.mesh_face[f0 : f0 + nf],
            albedo_factor=color[0],
        )
    return None


class SceneLogger:
    """Logs one MuJoCo model under ``root``: its geometry once, then body poses over time.

    Args:
        model: The compiled model (its current geom sizes, positions and colours are drawn).
        recording: The Rerun recording stream to log to.
        root: Entity path the scene lives under.
    """

    def __init__(self, model: mujoco.MjModel, recording: rr.RecordingStream, root: str) -> None:
        self.model = model
        self.recording = recording
        self.root = root.rstrip("/")
        self._data = mujoco.MjData(model)
        self.body_paths = [
            f"{self.root}/bodies/{_name(model, mujoco.mjtObj.mjOBJ_BODY, b, 'body')}"
            for b in range(model.nbody)
        ]

    def log_geometry(self) -> None:
        """Static shapes of every geom and site, posed in their bodies' frames."""
        m, rec = self.model, self.recording
        for kind, count, prefix, obj in (
            ("geom", m.ngeom, "geom_", mujoco.mjtObj.mjOBJ_GEOM),
            ("site", m.nsite, "site_", mujoco.mjtObj.mjOBJ_SITE),
        ):
            for i in range(count):
                if kind == "geom":
                    body, pos, quat = m.geom_bodyid[i], m.geom_pos[i], m.geom_quat[i]
                    shape = _shape(m, m.geom_type[i], m.geom_size[i], m.geom_rgba[i], m.geom_dataid[i])
                else:
                    body, pos, quat = m.site_bodyid[i], m.site_pos[i], m.site_quat[i]
                    shape = _shape(m, m.site_type[i], m.site_size[i], m.site_rgba[i])
                if shape is None:
                    continue
                path = f"{self.body_paths[body]}/{prefix}{_name(m, obj, i, '')}"
                rec.log(
                    path,
                    rr.Transform3D(translation=pos, quaternion=rr.Quaternion(xyzw=wxyz_to_xyzw(quat))),
                    static=True,
                )
                rec.log(path, shape, static=True)

    def body_poses(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World poses of every body for joint positions ``(T, nq)`` -> translations
        ``(T, nbody, 3)`` (m) and quaternions ``(T, nbody, 4)`` (wxyz), by forward kinematics."""
        qpos = np.atleast_2d(qpos)
        d = self._data
        pos = np.empty((len(qpos), self.model.nbody, 3))
        quat = np.empty((len(qpos), self.model.nbody, 4))
        for t, q in enumerate(qpos):
            d.qpos[:] = q
            mujoco.mj_kinematics(self.model, d)
            pos[t], quat[t] = d.xpos, d.xquat
        return pos, quat

    def site_positions(self, qpos: np.ndarray) -> np.ndarray:
        """World positions ``(nsite, 3)`` (m) of every site at joint positions ``(nq,)``."""
        d = self._data
        d.qpos[:] = qpos
        mujoco.mj_kinematics(self.model, d)
        return d.site_xpos.copy()

    def log_motion(self, qpos: np.ndarray, indexes: list[rr.TimeColumn]) -> None:
        """Body poses for joint positions ``(T, nq)`` at the ``T`` times of ``indexes``."""
        pos, quat = self.body_poses(qpos)
        for b in range(1, self.model.nbody):  # the world body never moves
            self.recording.send_columns(
                self.body_paths[b],
                indexes=indexes,
                columns=rr.Transform3D.columns(translation=pos[:, b], quaternion=wxyz_to_xyzw(quat[:, b])),
            )
