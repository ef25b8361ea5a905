"""cra-soak: the locomotion task under random and adversarial inputs for many env steps; nothing may crash, and
nothing non-finite may reach the learner.

    cra-soak --steps 1000000 --sim mujoco --num-envs 1024 --json soak.json

Every env step draws one action mode per robot: full-scale uniform actions, NaN, +-inf, the previous action with
its sign flipped, or huge gait actions (+-1e6). Every ``--poison-every`` steps one random robot's joint velocities
are set to NaN in the simulator, as a blown-up solve would leave them: that robot alone must be reset and counted.
Checks at every step: observations and rewards finite, the env's count of non-finite resets equal to the number of
poisoned robots (none arises from the physics itself). Prints the counts; exits 1 on a failed check.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from cra_warp.atomic_json import write_json

MODES = ("uniform", "nan", "inf", "sign_flip", "huge_gait")


def soak(steps: int, num_envs: int, sim: str, seed: int, poison_every: int, terrain: str) -> dict:
    import torch

    from cra_warp.host_memory import keep_freed_memory
    from cra_warp.sim import WorldConfig
    from envs.loco_config import LocoConfig
    from envs.locomotion import LocoEnv

    keep_freed_memory()
    torch.set_num_threads(1)
    env = LocoEnv(LocoConfig(num_envs=num_envs, terrain=terrain, seed=seed, world=WorldConfig(backend=sim)))
    gen = torch.Generator().manual_seed(seed)
    N, A, J = num_envs, env.num_actions, env.robot.num_joints
    counts = {m: 0 for m in MODES}
    poisoned, bad_steps, dones_total = 0, 0, 0
    prev = torch.zeros(N, A)
    env_steps = 0
    t0 = time.perf_counter()
    with torch.inference_mode():
        for k in range((steps + N - 1) // N):
            mode = torch.randint(0, len(MODES), (N,), generator=gen)
            a = 2 * torch.rand(N, A, generator=gen) - 1
            a = torch.where((mode == 1).unsqueeze(-1), float("nan"), a)
            inf = torch.where(torch.rand(N, A, generator=gen) < 0.5, float("inf"), float("-inf"))
            a = torch.where((mode == 2).unsqueeze(-1), inf, a)
            a = torch.where((mode == 3).unsqueeze(-1), -prev, a)
            if A > J:
                huge = torch.sign(torch.randn(N, A - J, generator=gen)) * 1e6
                a[:, J:] = torch.where((mode == 4).unsqueeze(-1), huge, a[:, J:])
            for i, m in enumerate(MODES):
                counts[m] += int((mode == i).sum())
            prev = torch.nan_to_num(a, nan=0.0, posinf=1.0, neginf=-1.0)
            if poison_every and k % poison_every == poison_every - 1:
                env.world.joint_qd[int(torch.randint(0, N, (1,), generator=gen)), 6:] = float("nan")
                poisoned += 1
            obs, rew, dones, _ = env.step(a)
            env_steps += N
            dones_total += int(dones.sum())
            finite = bool(torch.isfinite(rew).all()) and all(bool(torch.isfinite(v).all()) for v in obs.values())
            bad_steps += not finite
    seconds = time.perf_counter() - t0
    return {"sim": sim, "terrain": terrain, "num_envs": N, "env_steps": env_steps, "seconds": seconds,
            "env_steps_per_s": env_steps / seconds, "action_modes": counts, "poisoned_worlds": poisoned,
            "nonfinite_resets": env.nonfinite_resets, "episodes_ended": dones_total,
            "steps_with_nonfinite_output": bad_steps,
            "ok": bad_steps == 0 and env.nonfinite_resets == poisoned}


def main(argv: list[str] | None = None) -> int:
    from cra_warp.sim.config import BACKENDS

    p = argparse.ArgumentParser(prog="cra-soak", description=__doc__.split("\n\n")[0])
    p.add_argument("--steps", type=int, default=1_000_000, help="env steps in total (robots x steps)")
    p.add_argument("--num-envs", type=int, default=1024)
    p.add_argument("--sim", choices=BACKENDS, default="mujoco")
    p.add_argument("--terrain", choices=("flat", "rough"), default="flat")
    p.add_argument("--poison-every", type=int, default=50, help="env steps between NaN-poisoned worlds (0: none)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", type=Path)
    a = p.parse_args(argv)
    if a.steps < 1 or a.num_envs < 1 or a.poison_every < 0:
        p.error(f"--steps and --num-envs must be >= 1 and --poison-every >= 0, got {a.steps}, {a.num_envs}, "
                f"{a.poison_every}")
    if a.json is not None and not a.json.parent.is_dir():
        p.error(f"--json {a.json}: no such directory {a.json.parent}")
    r = soak(a.steps, a.num_envs, a.sim, a.seed, a.poison_every, a.terrain)
    print(f"{r['env_steps']} env steps on {r['sim']} ({r['terrain']}, N={r['num_envs']}) in {r['seconds']:.0f} s; "
          f"action modes {r['action_modes']}; {r['episodes_ended']} episodes ended; poisoned worlds "
          f"{r['poisoned_worlds']}, non-finite resets {r['nonfinite_resets']}; steps with a non-finite observation "
          f"or reward: {r['steps_with_nonfinite_output']} -> {'OK' if r['ok'] else 'FAILED'}")
    if a.json is not None:
        write_json(a.json, r)
    return 0 if r["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
