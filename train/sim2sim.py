"""cra-sim2sim: run an exported policy in MuJoCo C on another model, as the robot's deploy program would.

    cra-sim2sim runs/<run>/exported --model ../shared/reference/adam_lite/pnd_mujoco/pnd_robots/adam_lite/scene.xml
    cra-sim2sim robots/adam_lite/policies/<name> --terrain stairs --trials 5 --json s2s.json --video s2s.gif

The policy runs through cra_warp.deploy (numpy + onnxruntime, reading only the export) at its control period; the
drives' PD law runs at every physics step (1 kHz by default: the vendor's simulation and drive rate). The model is
any MJCF with the policy's joint names (a prefix such as "adam_lite_" is allowed). Mesh geoms whose files are
missing are dropped (the vendor's collision geoms are primitives), its actuators are replaced by torque motors on
the policy's joints and the held joints, and terrain is added with mjSpec. Default model: the training model (the
robot's MJCF as cra_warp builds it for both backends).
Each trial starts at the reference pose with small joint offsets (uniform +-0.02 rad, its seed), commanded forward
at the speed with its heading held at 0 by the training's heading controller. Per trial: fell, time survived,
distance along x, mean forward-velocity tracking error after the first second, step frequency (touchdowns per
second), the ground height under it at the end (climbed_m). A trial succeeds when it does not fall and, on stairs,
ends on the flight's top step. --export-armature gives each driven joint at least the rotor inertia the export
trained with (its JSON's pd.armature), which the vendor's files leave out. PASS needs --min-success of the trials
to succeed and, with --max-tracking-error, that error or less.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tyro.conf import Positional

from cra_warp import video  # first: it sets MUJOCO_GL before mujoco is imported
from cra_warp.atomic_json import write_json
from cra_warp.deploy import DeployError, DeployPolicy, load_export, pd_torque
from cra_warp.cli import UsageError, parse_args

TERRAINS = ("flat", "stairs", "slope")
# Held joints (not driven by the policy; welded in training) get this PD on the robot: soft, they carry only a hand.
HELD_KP, HELD_KD = 20.0, 0.5
# The command generator of training (envs/loco_config.py CommandConfig): heading P-gain and yaw-rate range.
HEADING_GAIN, YAW_RATE_MAX = 0.5, 0.5
TERRAIN_START = 1.0  # [m] ahead of the start, where stairs and slopes begin


@dataclass
class Sim2SimArgs:
    export: Positional[Path]                     # an export directory (cra-export / cra-train) or its JSON
    model: Path | None = None                    # MJCF (adam_lite.xml or scene.xml); default: the training model
    speeds: tuple[float, ...] = (0.5,)           # forward commands [m/s]
    terrain: str = "flat"                        # flat | stairs | slope
    step_height: float = 0.05                    # stairs [m]
    step_depth: float = 0.3                      # stairs [m]
    slope_deg: float = 10.0                      # slope [deg]
    trials: int = 5                              # per speed
    seconds: float = 20.0
    physics_dt: float = 0.001                    # [s]; must divide the policy's control period
    seed: int = 0
    export_armature: bool = False                # give the driven joints at least the export's rotor inertia
    min_success: float = 0.9                     # PASS: share of trials that succeed (up; on stairs, on the top step)
    max_tracking_error: float | None = None      # PASS: mean forward-velocity error [m/s], e.g. 1.5 x cra-eval's
    json: Path | None = None
    video: Path | None = None                    # GIF of the first trial (MuJoCo's offscreen renderer)


class Terrain:
    """The ground: a floor plane, plus stairs or a slope from x = TERRAIN_START; ``height(x)`` is its surface."""

    def __init__(self, a: Sim2SimArgs):
        self.kind, self.h, self.d, self.theta = a.terrain, a.step_height, a.step_depth, math.radians(a.slope_deg)
        self.steps = 10

    @property
    def top_x(self) -> float | None:
        """Where a stair flight's top step begins (a trial that ends upright beyond it climbed the flight); None on
        flat ground and slopes, whose ramp is longer than a trial walks."""
        return TERRAIN_START + (self.steps - 1) * self.d if self.kind == "stairs" else None

    def succeeded(self, record: dict) -> bool:
        """A trial succeeds when the robot did not fall and, on stairs, stands on the top step at the end: upright at
        the foot of a flight is not climbing it."""
        return not record["fell"] and (self.top_x is None or record["distance"] >= self.top_x)

    def height(self, x: float) -> float:
        u = x - TERRAIN_START
        if self.kind == "flat" or u < 0:
            return 0.0
        if self.kind == "stairs":
            return self.h * min(int(u // self.d) + 1, self.steps)
        return u * math.tan(self.theta)

    def add_to(self, spec) -> None:
        import mujoco

        world = spec.worldbody
        if not any(g.type == mujoco.mjtGeom.mjGEOM_PLANE for g in world.geoms):
            world.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05], rgba=[0.3, 0.35, 0.4, 1])
        if self.kind == "stairs":
            end = TERRAIN_START + self.steps * self.d + 3.0
            for k in range(self.steps):
                x0, top = TERRAIN_START + k * self.d, (k + 1) * self.h
                world.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[(end - x0) / 2, 2.0, top / 2],
                               pos=[(x0 + end) / 2, 0, top / 2], rgba=[0.5, 0.45, 0.4, 1])
        elif self.kind == "slope":  # a 14 m ramp whose top face starts at the floor at x = TERRAIN_START
            half, t, c, s = 7.0, 0.1, math.cos(self.theta), math.sin(self.theta)
            world.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[half, 2.0, t],
                           pos=[TERRAIN_START + half * c + t * s, 0, half * s - t * c],
                           quat=[math.cos(-self.theta / 2), 0, math.sin(-self.theta / 2), 0], rgba=[0.5, 0.45, 0.4, 1])


def _find(names: list[str], name: str, what: str, model_path) -> int:
    hits = [i for i, n in enumerate(names) if n == name or n.endswith("_" + name)]
    if len(hits) != 1:
        raise UsageError(f"{model_path}: {len(hits)} {what}s named like {name!r} (expected one)")
    return hits[0]


def build_model(a: Sim2SimArgs, spec_json: dict):
    """The MjModel: the given MJCF (meshes present or dropped), torque motors on the driven and held joints, the
    terrain, the physics step. Returns (model, joint qpos addresses, dof addresses, held (qpos, dof, angle))."""
    import mujoco

    if a.model is None:
        from cra_warp.sim import mjcf
        from robots.adam_lite import ADAM_LITE

        spec, where = mujoco.MjSpec.from_string(mjcf(ADAM_LITE)), None
    else:
        try:
            spec, where = mujoco.MjSpec.from_file(str(a.model)), a.model.parent
        except Exception as e:  # noqa: BLE001 - MuJoCo's parse errors
            raise UsageError(f"--model {a.model}: MuJoCo cannot parse it ({str(e).splitlines()[0]})") from None
    if where is not None:  # drop what refers to files that are not there (the vendor's meshes are not shipped)
        mesh_dir = where / (spec.meshdir or "")
        gone = {m.name or Path(m.file).stem for m in spec.meshes if not (mesh_dir / m.file).is_file()}
        for g in spec.worldbody.find_all(mujoco.mjtObj.mjOBJ_GEOM):
            if g.type == mujoco.mjtGeom.mjGEOM_MESH and g.meshname in gone:
                spec.delete(g)
        for m in list(spec.meshes):
            if (m.name or Path(m.file).stem) in gone:
                spec.delete(m)
        tex_dir = where / (spec.texturedir or "")
        lost = {t.name for t in spec.textures if t.file and not (tex_dir / t.file).is_file()}
        for t in list(spec.textures):
            if t.name in lost:
                spec.delete(t)
        for mat in spec.materials:
            mat.textures = ["" if x in lost else x for x in mat.textures]
    for act in list(spec.actuators):
        spec.delete(act)
    all_joints = spec.worldbody.find_all(mujoco.mjtObj.mjOBJ_JOINT)
    joint_names = [j.name for j in all_joints]
    # held joints the model has (the training model welds them: nothing to hold)
    held = {n: v for n, v in spec_json["pd"].get("held_joints", {}).items()
            if any(j == n or j.endswith("_" + n) for j in joint_names)}
    driven = []
    for name in [*spec_json["joint_names"], *held]:
        i = _find(joint_names, name, "joint", a.model or "the training model")
        spec.add_actuator(name=f"motor_{name}", target=joint_names[i], trntype=mujoco.mjtTrn.mjTRN_JOINT)
        driven.append(all_joints[i])
    if a.export_armature:  # the vendor's MJCF carries no rotor inertia (0.001 on ankle pitch); the drives do
        arm = np.broadcast_to(np.asarray(spec_json["pd"]["armature"], dtype=float), (len(spec_json["joint_names"]),))
        for j, value in zip(driven, arm):  # the policy's joints come first
            j.armature = max(float(j.armature), float(value))
    Terrain(a).add_to(spec)
    if a.video is not None:
        video.add_skeleton(spec)
    model = spec.compile()
    model.opt.timestep = a.physics_dt
    names = [model.joint(i).name for i in range(model.njnt)]
    if model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE:
        raise UsageError(f"{a.model}: the first joint must be the base's free joint")
    jid = [_find(names, n, "joint", a.model) for n in spec_json["joint_names"]]
    hid = [_find(names, n, "joint", a.model) for n in held]
    return (model, model.jnt_qposadr[jid], model.jnt_dofadr[jid],
            (model.jnt_qposadr[hid], model.jnt_dofadr[hid], np.array(list(held.values()), dtype=float)))


def _quat_to_mat(wxyz: np.ndarray) -> np.ndarray:
    m = np.zeros(9)
    import mujoco

    mujoco.mju_quat2Mat(m, wxyz)
    return m.reshape(3, 3)


class Trial:
    """One robot, one speed: the deploy loop on MuJoCo C, with the outcome measures."""

    def __init__(self, model, joints, held, policy: DeployPolicy, spec_json: dict, terrain: Terrain):
        import mujoco

        self.m, self.d = model, mujoco.MjData(model)
        self.qadr, self.vadr = joints
        self.held = held
        self.policy, self.terrain = policy, terrain
        self.substeps = round(policy.control_dt / model.opt.timestep)
        if self.substeps < 1 or abs(self.substeps * model.opt.timestep - policy.control_dt) > 1e-9:
            raise UsageError(f"--physics-dt {model.opt.timestep} must divide the control period {policy.control_dt}")
        from envs.loco_config import SIT_FRACTION

        term = spec_json.get("termination", {"fall_height": 0.45, "fall_gravity_z": -0.5})
        self.fall_height, self.fall_gz = term["fall_height"], term["fall_gravity_z"]
        self.sit_height = SIT_FRACTION * self.fall_height   # judged as cra-eval does, whatever the export trained with
        self.base_height = spec_json.get("base_height", 0.9)
        self.base_body = int(model.jnt_bodyid[0])
        feet = spec_json.get("bodies", {}).get("feet", ["toeLeft", "toeRight"])
        bodies = [model.body(i).name for i in range(model.nbody)]
        self.feet = [_find(bodies, f, "body", "the model") for f in feet]

    def run(self, speed: float, seconds: float, seed: int, frames: list | None = None) -> dict:
        import mujoco

        m, d, p = self.m, self.d, self.policy
        mujoco.mj_resetData(m, d)
        rng = np.random.default_rng(seed)
        d.qpos[0:3] = (0.0, 0.0, self.base_height + 0.01)
        d.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
        d.qpos[self.qadr] = p.default_q + rng.uniform(-0.02, 0.02, p.num_joints)
        d.qpos[self.held[0]] = self.held[2]
        mujoco.mj_forward(m, d)
        p.reset()
        steps = round(seconds / p.control_dt)
        errors, touchdowns, in_contact, fell_at = [], 0, np.ones(len(self.feet), bool), None
        renderer = camera = None
        every = video.frame_every(p.control_dt)
        if frames is not None:
            renderer, camera = video.offscreen_renderer(m), video.tracking_camera(self.base_body)
        try:
            for k in range(steps):
                rot = _quat_to_mat(d.qpos[3:7])
                yaw = math.atan2(rot[1, 0], rot[0, 0])
                wz = float(np.clip(HEADING_GAIN * math.remainder(0.0 - yaw, 2 * math.pi), -YAW_RATE_MAX, YAW_RATE_MAX))
                gravity = rot.T @ np.array([0.0, 0.0, -1.0])
                q, qd = d.qpos[self.qadr], d.qvel[self.vadr]
                # the free joint's angular velocity is in the body frame
                target = p.step((speed, 0.0, wz), gravity, q, qd, d.qvel[3:6])
                for _ in range(self.substeps):
                    d.ctrl[:p.num_joints] = p.torque(d.qpos[self.qadr], d.qvel[self.vadr], target)
                    d.ctrl[p.num_joints:] = pd_torque(d.qpos[self.held[0]], d.qvel[self.held[1]], self.held[2],
                                                      HELD_KP, HELD_KD, np.inf)
                    mujoco.mj_step(m, d)
                t = (k + 1) * p.control_dt
                contact = self._feet_in_contact()
                touchdowns += int((contact & ~in_contact).sum())
                in_contact = contact
                if t > 1.0:
                    c, s = math.cos(yaw), math.sin(yaw)
                    errors.append(abs(c * d.qvel[0] + s * d.qvel[1] - speed))
                if renderer is not None and k % every == 0:
                    frames.append(self._frame(renderer, camera, speed, t, fell_at))
                # the pelvis above the lowest ground under it or a foot (the evaluators' fall rule,
                # LocoConfig.fall_ground; a foot body's origin stands in for its sole centre, a few cm away), or sat
                # down (SIT_FRACTION)
                height = d.qpos[2] - min(self.terrain.height(x) for x in (d.qpos[0], *d.xpos[self.feet, 0]))
                seated = d.qpos[2] - self.terrain.height(d.qpos[0]) < self.sit_height
                if height < self.fall_height or seated or gravity[2] > self.fall_gz or not np.isfinite(d.qpos).all():
                    fell_at = t
                    break
        finally:
            if renderer is not None:
                if fell_at is not None:
                    frames.extend([self._frame(renderer, camera, speed, fell_at, fell_at)] * 12)
                renderer.close()  # explicitly: its destructor errors at interpreter exit
        alive = fell_at if fell_at is not None else steps * p.control_dt
        return {"speed": speed, "seed": seed, "fell": fell_at is not None, "time_survived": round(alive, 3),
                "distance": round(float(d.qpos[0]), 3),
                "climbed_m": round(self.terrain.height(float(d.qpos[0])), 3),
                "tracking_error": round(float(np.mean(errors)), 4) if errors else None,
                "step_frequency": round(touchdowns / alive, 3)}

    def _feet_in_contact(self) -> np.ndarray:
        d, m = self.d, self.m
        out = np.zeros(len(self.feet), bool)
        for c in d.contact[:d.ncon]:
            for g in (c.geom1, c.geom2):
                b = m.geom_bodyid[g]
                if b in self.feet:
                    out[self.feet.index(b)] = True
        return out

    def _frame(self, renderer, camera, speed: float, t: float, fell_at: float | None):
        lines = [(f"cmd {speed:.2f} m/s   t {t:5.2f} s", (255, 255, 255))]
        if fell_at is not None:
            lines.append((f"FELL at {fell_at:.2f} s", (255, 60, 60)))
        return video.frame(renderer, self.d, camera, lines)


def run(a: Sim2SimArgs) -> dict:
    spec_json, _ = load_export(a.export)
    policy = DeployPolicy(a.export)
    model, qadr, vadr, held = build_model(a, spec_json)
    trial = Trial(model, (qadr, vadr), held, policy, spec_json, Terrain(a))
    frames = [] if a.video is not None else None
    records = []
    for speed in a.speeds:
        for r in range(a.trials):
            records.append(trial.run(speed, a.seconds, a.seed + r, frames if not records else None))
    if frames:
        video.save_gif(frames, a.video, fps=1 / (video.frame_every(policy.control_dt) * policy.control_dt))
    success = float(np.mean([trial.terrain.succeeded(r) for r in records]))
    errs = [r["tracking_error"] for r in records if r["tracking_error"] is not None]
    err = float(np.mean(errs)) if errs else None
    tracked = a.max_tracking_error is None or (err is not None and err <= a.max_tracking_error)
    passed = success >= a.min_success and tracked
    return {"export": str(a.export), "model": str(a.model or "training model"), "terrain": a.terrain,
            "armature": "at least the export's" if a.export_armature else "the model's",
            "physics_dt": a.physics_dt, "control_dt": policy.control_dt, "seconds": a.seconds,
            "success": success, "tracking_error": err, "pass": passed,
            "criteria": {"min_success": a.min_success, "max_tracking_error": a.max_tracking_error},
            "trials": records}


def _table(result: dict) -> str:
    lines = [f"{'speed':>6} {'seed':>5} {'fell':>5} {'alive s':>8} {'dist m':>7} {'up m':>5} {'v err':>6} "
             f"{'steps/s':>8}"]
    for r in result["trials"]:
        e = "-" if r["tracking_error"] is None else f"{r['tracking_error']:.3f}"
        lines.append(f"{r['speed']:6.2f} {r['seed']:5d} {str(r['fell']):>5} {r['time_survived']:8.2f} "
                     f"{r['distance']:7.2f} {r['climbed_m']:5.2f} {e:>6} {r['step_frequency']:8.2f}")
    err = "-" if result["tracking_error"] is None else f"{result['tracking_error']:.3f} m/s"
    lines.append(f"{result['terrain']} on {result['model']}: success {result['success']:.0%}, "
                 f"tracking error {err} -> {'PASS' if result['pass'] else 'FAIL'}")
    return "\n".join(lines)


def validate(a: Sim2SimArgs) -> None:
    if a.terrain not in TERRAINS:
        raise UsageError(f"--terrain must be one of {', '.join(TERRAINS)}, got {a.terrain!r}")
    if a.model is not None and not a.model.is_file():
        raise UsageError(f"--model {a.model}: no such file")
    if not a.speeds or not all(math.isfinite(v) and v >= 0 for v in a.speeds):
        raise UsageError(f"--speeds must be finite and >= 0 m/s, got {a.speeds}")
    for name in ("trials",):
        if getattr(a, name) < 1:
            raise UsageError(f"--{name} must be >= 1, got {getattr(a, name)}")
    for name in ("seconds", "physics_dt", "step_height", "step_depth"):
        v = getattr(a, name)
        if not (math.isfinite(v) and v > 0):
            raise UsageError(f"--{name.replace('_', '-')} must be finite and > 0, got {v}")
    if not 0 <= a.slope_deg < 45:
        raise UsageError(f"--slope-deg must be in [0, 45), got {a.slope_deg}")
    if a.json is not None and not a.json.parent.is_dir():
        raise UsageError(f"--json {a.json}: no such directory {a.json.parent}")
    if a.video is not None and (why := video.check_gif_path(a.video)):
        raise UsageError(why)


def main(argv: list[str] | None = None) -> int:
    try:
        a = parse_args(Sim2SimArgs, argv, __doc__)
        validate(a)
        result = run(a)
    except (UsageError, DeployError) as e:
        print(f"cra-sim2sim: {e}", file=sys.stderr)
        return 2
    print(_table(result))
    if a.json is not None:
        write_json(a.json, result, indent=2)
    return 0 if result["pass"] else 1


if __name__ == "__main__":
    sys.exit(main())
