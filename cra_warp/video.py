"""Animated GIFs of rollouts through MuJoCo's offscreen renderer (EGL: no display needed), for cra-sim2sim (MuJoCo C
trials) and cra-play (any backend's state drawn through the training robot's MjModel).

The vendor's meshes are not shipped, so a robot is drawn as a skeleton (a capsule from each body to its parent)
with its collision geoms. GIF only: no video encoder is among our dependencies.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering without a display (before mujoco is imported)

SIZE = (240, 320)  # height, width [px]


def add_skeleton(spec) -> None:
    """Something to see without meshes: a massless, non-colliding capsule from each body's parent to it, visible
    collision geoms, a floor where there is none, and a light."""
    import mujoco

    for body in spec.worldbody.find_all(mujoco.mjtObj.mjOBJ_BODY):
        parent = body.parent
        if parent.name != spec.worldbody.name and np.linalg.norm(body.pos) > 1e-3:
            parent.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, *body.pos], size=[0.025, 0, 0],
                            contype=0, conaffinity=0, density=0, group=1, rgba=[0.75, 0.75, 0.8, 1])
        for g in body.geoms:
            if g.rgba[3] == 0:
                g.rgba = [0.8, 0.4, 0.3, 1]
    world = spec.worldbody
    planes = [g for g in world.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE]
    if not planes:
        planes = [world.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], contype=0, conaffinity=0)]
    for g in planes:
        g.rgba, g.material = [0.45, 0.5, 0.55, 1], ""
    world.add_light(pos=[0, 0, 4], dir=[0, 0, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
    spec.visual.headlight.ambient, spec.visual.headlight.diffuse = [0.35] * 3, [0.5] * 3


def offscreen_renderer(model):
    import mujoco
    from mujoco.rendering.classic import gl_context

    if os.environ.get("MUJOCO_GL") == "egl" and "egl" not in gl_context.GLContext.__module__:
        # MuJoCo fixed its GL backend when first imported, before MUJOCO_GL was set here (the simulator or a test
        # imported it first); without a display only EGL renders, so use the EGL context MUJOCO_GL asks for.
        from mujoco.egl import GLContext

        gl_context.GLContext = GLContext
    return mujoco.Renderer(model, *SIZE)


def tracking_camera(body_id: int):
    import mujoco

    camera = mujoco.MjvCamera()
    camera.type, camera.trackbodyid = mujoco.mjtCamera.mjCAMERA_TRACKING, body_id
    camera.distance, camera.elevation, camera.azimuth = 3.0, -15.0, 120.0
    return camera


def frame(renderer, data, camera, lines: list[tuple[str, tuple[int, int, int]]]):
    """The rendered scene of ``data`` with text lines (text, RGB) in the top left corner, as a PIL image."""
    from PIL import Image, ImageDraw

    renderer.update_scene(data, camera)
    img = Image.fromarray(renderer.render())
    draw = ImageDraw.Draw(img)
    for i, (text, color) in enumerate(lines):
        draw.text((6, 4 + 14 * i), text, fill=color)
    return img


def save_gif(frames: list, path: Path, fps: float) -> None:
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=round(1000 / fps), loop=0)


def check_gif_path(path: Path, flag: str = "--video") -> str | None:
    """Why ``path`` cannot take a GIF, or None."""
    if path.suffix.lower() != ".gif":
        return f"{flag} {path}: only .gif is written (no video encoder is installed)"
    if not path.parent.is_dir():
        return f"{flag} {path}: no such directory {path.parent}"
    return None


class RolloutVideo:
    """Robot 0 of a batched world drawn through the training robot's MjModel (the model the MuJoCo C backend runs,
    with the whole terrain), one frame per ``frame()`` call; ``close()`` writes the GIF."""

    def __init__(self, world, terrain, path: Path, fps: float):
        import mujoco

        from cra_warp.sim import mjcf

        spec = mujoco.MjSpec.from_string(mjcf(world.robot, world.cfg, terrain))
        add_skeleton(spec)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.world, self.path, self.fps, self.frames = world, path, fps, []
        self.renderer = offscreen_renderer(self.model)
        self.camera = tracking_camera(int(self.model.jnt_bodyid[0]))

    def frame(self, lines: list[tuple[str, tuple[int, int, int]]]) -> None:
        import mujoco

        q = self.world.joint_q[0].detach().cpu().double().numpy()
        self.data.qpos[:3] = q[:3]
        self.data.qpos[3:7] = q[[6, 3, 4, 5]]  # xyzw -> MuJoCo's wxyz
        self.data.qpos[7:] = q[7:]
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)  # the tracking camera looks at the subtree's centre of mass
        self.frames.append(frame(self.renderer, self.data, self.camera, lines))

    def close(self) -> None:
        self.renderer.close()  # explicitly: its destructor errors at interpreter exit
        if self.frames:
            save_gif(self.frames, self.path, self.fps)
