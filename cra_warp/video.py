"""Animated GIFs of rollouts through MuJoCo's offscreen renderer (EGL: no display needed), for cra-sim2sim (MuJoCo C
trials) and cra-play (any backend's state drawn through the training robot's MjModel).

The vendor's meshes are not shipped, so a robot is drawn as a skeleton (a capsule from each body to its parent, left
side blue, right orange) with its collision geoms, on a checker floor (terrain boxes in a second checker) under a
spotlight that follows it and casts its shadow, seen from a camera that follows it. Everything is MuJoCo's own:
textures, materials and lights added through MjSpec, drawn by mujoco.Renderer (on a machine without a GPU, EGL
runs Mesa's llvmpipe, ~0.1-0.3 s per 640 x 360 frame). GIF only: no video encoder is among our dependencies.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering without a display (before mujoco is imported)

SIZE = (360, 640)  # height, width [px]: 16:9, what a README column shows without scaling up
FPS = 50 / 3       # GIF frames per second: every third 50 Hz step, a delay of 60 ms (GIF delays are whole 10 ms);
                   # walking reads at it, and a third fewer frames than at 25/s keeps a 6 s clip near 2 MB
CHECK = 0.5        # side of a floor check [m]: steps and speed read against it
COLORS = 64        # GIF palette size, shared by all frames
FONT_PX = 15       # caption text height
LEFT, RIGHT, MIDDLE = (0.2, 0.45, 0.9, 1), (0.95, 0.5, 0.15, 1), (0.8, 0.8, 0.82, 1)  # skeleton colours by side


def frame_every(dt: float) -> int:
    """Steps of ``dt`` [s] per GIF frame: FPS as nearly as whole steps allow (the GIF's rate is then 1 / (that x dt))."""
    return max(1, round(1 / (FPS * dt)))


def _side_colour(name: str) -> tuple[float, ...]:
    low = name.lower()
    return LEFT if "left" in low else RIGHT if "right" in low else MIDDLE


def add_skeleton(spec) -> None:
    """Something to see without meshes, in a scene that shows motion, all through MjSpec (visual only: the added
    geoms are massless and collide with nothing): a capsule from each body's parent to it and a ball at each joint,
    the left side blue and the right orange; the robot's geoms in its side's colour; a checker floor (every plane)
    and checker terrain (every other world geom: stairs and slopes show their edges); a sky; a directional fill
    light and a spotlight that follows the robot and casts its shadow."""
    import mujoco

    for element in [*spec.lights, *(t for t in spec.textures if t.type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)]:
        spec.delete(element)  # a scene file's own lights and sky (the vendor's scene.xml): ours are set for these
    tex_role = mujoco.mjtTextureRole.mjTEXROLE_RGB
    for name, rgb1, rgb2 in (("video_floor", [0.76, 0.78, 0.8], [0.52, 0.56, 0.6]),
                             ("video_terrain", [0.86, 0.78, 0.64], [0.66, 0.58, 0.46])):
        # the builtin checker is 2 x 2 checks; texuniform repeats it per metre of the surface (not per geom)
        spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                         rgb1=rgb1, rgb2=rgb2, width=64, height=64)
        material = spec.add_material(name=name, texrepeat=[1 / (2 * CHECK)] * 2, texuniform=True, reflectance=0.0)
        material.textures[tex_role] = name
    spec.add_texture(name="video_sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.55, 0.7, 0.88], rgb2=[0.95, 0.96, 0.98], width=64, height=384)

    world = spec.worldbody
    root = None
    for body in spec.worldbody.find_all(mujoco.mjtObj.mjOBJ_BODY):
        parent, colour = body.parent, _side_colour(body.name)
        if parent.name == world.name:
            root = root or body
        elif np.linalg.norm(body.pos) > 1e-3:
            parent.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, *body.pos], size=[0.03, 0, 0],
                            contype=0, conaffinity=0, density=0, group=1, rgba=colour)
            body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.045, 0, 0], contype=0, conaffinity=0, density=0,
                          group=1, rgba=colour)
        for g in body.geoms:
            if g.contype or g.conaffinity or g.rgba[3] == 0:  # its collision geoms (feet), which were not drawn
                g.rgba, g.group = list(colour), min(g.group, 2)
    if not any(g.type == mujoco.mjtGeom.mjGEOM_PLANE for g in world.geoms):
        world.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], contype=0, conaffinity=0)
    for g in world.geoms:
        flat = g.type == mujoco.mjtGeom.mjGEOM_PLANE
        g.material, g.rgba = "video_floor" if flat else "video_terrain", [1, 1, 1, 1]
        if flat:
            g.size = [0, 0, g.size[2] or 0.05]  # drawn without edges (a plane collides as infinite at any size)
    world.add_light(pos=[0, 0, 5], dir=[0.3, 0.2, -1], type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL, castshadow=False,
                    diffuse=[0.3] * 3, specular=[0.1] * 3)
    if root is not None:  # a spot above the walker, its shadow showing which foot is down
        root.add_light(mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM, pos=[1.0, 1.5, 4.0], dir=[-0.25, -0.375, -1],
                       castshadow=True, cutoff=40, exponent=1, diffuse=[0.55] * 3, specular=[0.2] * 3)
    spec.visual.headlight.ambient, spec.visual.headlight.diffuse = [0.35] * 3, [0.2] * 3
    spec.visual.quality.shadowsize = 2048
    spec.visual.global_.offheight = max(spec.visual.global_.offheight, SIZE[0])
    spec.visual.global_.offwidth = max(spec.visual.global_.offwidth, SIZE[1])


def offscreen_renderer(model):
    import mujoco
    from mujoco.rendering.classic import gl_context

    if os.environ.get("MUJOCO_GL") == "egl" and "egl" not in gl_context.GLContext.__module__:
        # MuJoCo fixed its GL backend when first imported, before MUJOCO_GL was set here (the simulator or a test
        # imported it first); without a display only EGL renders, so use the EGL context MUJOCO_GL asks for.
        from mujoco.egl import GLContext

        gl_context.GLContext = GLContext
    return mujoco.Renderer(model, *SIZE)


class FollowCamera:
    """MuJoCo's free camera kept on a body: it looks at the body's subtree centre of mass lowered by ``drop`` from a
    fixed azimuth, elevation and distance. (mjCAMERA_TRACKING looks at the centre of mass itself, which at a
    distance that shows the legs large puts the feet at the frame's lower edge.) The tree's kinematics and
    mj_comPos must be current."""

    def __init__(self, body_id: int, distance: float = 2.6, elevation: float = -12.0, azimuth: float = 110.0,
                 drop: float = 0.25):
        import mujoco

        self.body_id, self.drop = body_id, drop
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.distance, self.camera.elevation, self.camera.azimuth = distance, elevation, azimuth

    def at(self, data):
        self.camera.lookat[:] = data.subtree_com[self.body_id] - (0.0, 0.0, self.drop)
        return self.camera


def tracking_camera(body_id: int) -> FollowCamera:
    return FollowCamera(body_id)


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)  # Pillow's scalable default font (needs FreeType)
    except (TypeError, OSError, ImportError):
        return ImageFont.load_default()


def frame(renderer, data, camera: FollowCamera, lines: list[tuple[str, tuple[int, int, int]]]):
    """The rendered scene of ``data`` with text lines (text, RGB; outlined in black, legible on sky and floor) in the
    top left corner, as a PIL image."""
    from PIL import Image, ImageDraw

    renderer.update_scene(data, camera.at(data))
    img = Image.fromarray(renderer.render())
    draw, font, size = ImageDraw.Draw(img), _font(FONT_PX), FONT_PX + 4
    for i, (text, color) in enumerate(lines):
        draw.text((8, 6 + size * i), text, fill=color, font=font, stroke_width=2, stroke_fill=(0, 0, 0))
    return img


def save_gif(frames: list, path: Path, fps: float, colors: int = COLORS) -> None:
    """``frames`` (PIL RGB images) as a looping GIF with one palette of ``colors`` for all frames, taken from
    frames spread over the clip, and no dithering: a checker floor that scrolls under a tracking camera is most of
    each frame, and dither noise would make every frame's pixels new to the encoder (files several times larger)."""
    from PIL import Image

    sample = frames[:: max(1, len(frames) // 6)][:6]
    w, h = sample[0].size
    mosaic = Image.new("RGB", (w, h * len(sample)))
    for i, f in enumerate(sample):
        mosaic.paste(f, (0, h * i))
    palette = mosaic.quantize(colors=colors, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE)
    indexed = [f.quantize(palette=palette, dither=Image.Dither.NONE) for f in frames]
    indexed[0].save(path, save_all=True, append_images=indexed[1:], duration=round(1000 / fps), loop=0,
                    optimize=False)


def check_gif_path(path: Path, flag: str = "--video") -> str | None:
    """Why ``path`` cannot take a GIF, or None."""
    if path.suffix.lower() != ".gif":
        return f"{flag} {path}: only .gif is written (no video encoder is installed)"
    if not path.parent.is_dir():
        return f"{flag} {path}: no such directory {path.parent}"
    return None


class RolloutVideo:
    """Robot ``robot`` of a batched world drawn through the training robot's MjModel (the model the MuJoCo C backend
    runs, with the whole terrain), one frame per ``frame()`` call, the camera beside its path when it walks along
    ``heading`` [rad] (world yaw); ``close()`` writes the GIF."""

    def __init__(self, world, terrain, path: Path, fps: float, robot: int = 0, heading: float = 0.0):
        import math

        import mujoco

        from cra_warp.sim import mjcf

        spec = mujoco.MjSpec.from_string(mjcf(world.robot, world.cfg, terrain))
        add_skeleton(spec)
        for g in spec.worldbody.geoms:  # drawn only, never stepped: the floor 2 mm under terrain boxes whose tops lie
            if g.type == mujoco.mjtGeom.mjGEOM_PLANE:  # on it (the two surfaces would fight for the same pixels)
                g.pos = [g.pos[0], g.pos[1], g.pos[2] - 0.002]
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        self.world, self.robot, self.path, self.fps, self.frames = world, robot, path, fps, []
        self.renderer = offscreen_renderer(self.model)
        self.camera = tracking_camera(int(self.model.jnt_bodyid[0]))
        self.camera.camera.azimuth += math.degrees(heading)

    def frame(self, lines: list[tuple[str, tuple[int, int, int]]]) -> None:
        import mujoco

        q = self.world.joint_q[self.robot].detach().cpu().double().numpy()
        self.data.qpos[:3] = q[:3]
        self.data.qpos[3:7] = q[[6, 3, 4, 5]]  # xyzw -> MuJoCo's wxyz
        self.data.qpos[7:] = q[7:]
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)  # the camera looks at the subtree's centre of mass
        mujoco.mj_camlight(self.model, self.data)  # the spotlight follows it
        self.frames.append(frame(self.renderer, self.data, self.camera, lines))

    def close(self) -> None:
        self.renderer.close()  # explicitly: its destructor errors at interpreter exit
        if self.frames:
            save_gif(self.frames, self.path, self.fps)
