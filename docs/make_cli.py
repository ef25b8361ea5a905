"""Writes docs/cli.md from every installed command's --help (run from the repository root: .venv/bin/python docs/make_cli.py)."""
import re, subprocess, tomllib, os
scripts = tomllib.load(open("pyproject.toml","rb"))["project"]["scripts"]
ABOUT = {
 "cra-train": "Train a policy. `--method` picks a row of envs/methods.py (docs/paper.md, The methods): `ours`, its ablations (`sequential`, `no_contrast`, `fixed_cycle`, `clock_free`) and the two baselines twice, on our adaptive clock (`dreamwaq`, `dwl`: only the actor differs) and paired with their papers' clocks (`dreamwaq_clock_free`: no clock, with DreamWaQ's AdaBoot; `dwl_fixed_cycle`: a clock of fixed period). `--recipe` picks the named overrides (envs/recipes.py: `walk`, the default for a new run, is what the shipped walkers trained with; `paper` is Table I and the paper's clock); `--override` sets any env setting by its dotted path (e.g. `rewards.weights.contact_momentum=-4.4e-5`) and any learner setting under `learner.` (e.g. `learner.ppo.desired_kl=0.02`), after the recipe's. `--resume` continues the iteration count, the optimizer and the curriculum levels (each robot's terrain level included) under the checkpoint's recipe unless told another; `--init` starts a new run from a checkpoint's networks (a fork into the rough task or another variant; a shipped policy's actor alone) at `learner.fork_learning_rate`, a missing critic first learning alone. The run directory's `config.json` (and every checkpoint) holds the whole resolved configuration and the recipe, which play, eval and export rebuild. It ends by printing the run directory and the exported files (TorchScript, ONNX and its weights, deploy JSON); an unwritable `--log-dir` is a one-line error (exit 2).",
 "cra-play": "Run a policy (or `--agent stand|zero|random`) under the training's random commands or one held command (`--command VX VY`), with the training's randomisation or nominal robots (`--nominal`); report tracking error, falls, distance; write an animated USD (`--usd`) and/or a GIF of robot 0 (`--video`, MuJoCo's offscreen renderer, EGL).",
 "cra-eval": "Success rates on the evaluation course (stairs 5-35 cm, slopes 2-34 deg, uneven ground; reach the target without falling) per policy, speed, kind and level, each with its robot count and 95% Wilson interval (in the table and the JSON); `--agent-stand` adds the scripted stand as a floor. `--trial flat`: the flat walking trial (forward with the heading held, `--lateral` side steps, `--yaw-rates` turns while walking at `--turn-speed`): fall rate with its interval, tracking errors of v_x, v_y and the yaw rate per step and of each robot's trial average with its sign (`offset*`), touchdowns per second and the share of time on one foot. `--protocol paper`: the paper's IV-B (the speed sweep 0.15-1.0 m/s over every kind and level, and the 0.15 m/s stairs/slope ablation); records name each checkpoint's method and seed, and the table and CSV give each cell's mean and std over a method's seeds and the interval of all their robots.",
 "cra-figures": "The paper's four figures, each PNG with its JSON: terrain level over training, success vs speed, success vs stair height and slope at 0.15 m/s (error bars over seeds; shaded, and in the JSON as `robots` and `ci95`, the 95% Wilson interval of all the method's robots at that point), leg-joint velocity-torque scatter of a policy climbing stairs; `--walk`: the flat trial's v_x error vs env steps of a cra-grid --study walk.",
 "cra-grid": "The whole comparison: trains every method and seed on rough ground with one recipe (resumable; on the CPU one core per run), evaluates each run with the paper's protocol as soon as it is trained, draws the figures and the table (CSV, JSON). It prints the recipe each method ran and what of it a method cannot use (clock_free and dreamwaq_clock_free: no clock, so none of the recipe's `gait.*` settings), and trains their fair pair beside them (`ours_as_clock_free`: ours without the same keys; `--no-fair-pairs`: not); table.json records it under `recipes`. `--scale gpu` is the paper's setting (4096 robots, 10k iterations); `--scale cpu` 60 iterations of 128 robots per run on MuJoCo, two at a time, each evaluated with 4 robots per level (docs/results.md). Two smaller studies (train/studies.py says what each writes): `--study fork` fine-tunes every method whose actor can start from one flat walker (`--walker`, flat_walk_v2 by default: ours, sequential, no_contrast, fixed_cycle; the plan says why clock_free and the baselines (dreamwaq, dwl, dreamwaq_clock_free, dwl_fixed_cycle) cannot) on rough ground, the same `--iterations` (300) of 256 robots each, 3 seeds, then runs the paper's protocol (the 0.15 m/s stairs and slope ablation with 50 robots per level, the speed sweep with 10) and cra-probe on each, and draws the terrain level over training and the success figures, with a table of each method's mean and std over seeds and each success rate's robots and 95% interval; `--study walk` trains every method and its fair pair from scratch on flat ground, 2 seeds, in chunks of `--check-every` iterations (100) up to `--budget` env steps (30M), runs the flat trial at 0.5 m/s (32 robots, 10 s) after each chunk and stops a run at the first check with every robot up and v_x error <= `--walk-error` (0.15 m/s); it tables each arm's env steps to walk and draws the v_x error vs env steps. Every study resumes by re-running the same command; on another machine after `cra-campaign save` and `cra-campaign restore` of its run directories.",
 "cra-export": "TorchScript + ONNX (GRU state as explicit input/output, weights in `policy.onnx.data` beside it) + deploy JSON; `--ship` adds the actor-only `checkpoint.pt` and `config.json` (how a policy in `robots/adam_lite/policies/` is written). The ONNX exporter's warnings are summarised in one line.",
 "cra-sim2sim": "The exported policy run by the deploy module (numpy + onnxruntime) in MuJoCo C with PD at 1 kHz, on the vendor's MJCF (`../shared/reference/adam_lite/pnd_mujoco/pnd_robots/adam_lite/scene.xml`; absent meshes dropped) or the training model; per trial fall, time, distance, the ground height it ended on, tracking error, step rate; success: up and, on stairs, on the top step; PASS/FAIL; a GIF rendered offscreen (EGL).",
 "cra-bench": "env-steps/s and peak memory of both backends (Newton 1/2 processes, MuJoCo C 1/2 threads), the bare mujoco.rollout, and the full task on both; flat, stairs, rough. Each record says whether the robots stood while measured (`standing`).",
 "cra-soak": "The task under random and adversarial actions (NaN, inf, sign flips, huge gait actions) and NaN-poisoned worlds: no crash, nothing non-finite reaches the learner, every broken world reset alone and counted.",
 "cra-curves": "An A/B's training curves in one figure (`ARM=RUN[,RUN...]` positional arms; seeds thin, mean thick) and whether the arms differ by more than the seed spread.",
 "cra-bench-learner": "The PPO update's levers (threads, epochs x mini-batches, torch.compile, contrast, CNN strides) against the measured matmul peak; `cra-train` end to end in 1 and 2 processes.",
 "cra-probe": "Linear probe (ridge, held-out robots) from the frozen actor latent m_a, and from the raw actor observation as the reference, to the terrain around the robot on the evaluation course (height map and foot maps as shapes, slope, largest step): R^2 per target.",
 "cra-terrain": "A picture of the terrain curriculum (or `--course`: the evaluation course).",
 "cra-urdf2usd": "A UsdPhysics articulation with drives from a URDF (`cra-urdf2usd in.urdf out.usda`).",
 "cra-campaign": "Long training runs that outlive the machine: `save NAME RUN...` keeps each run's newest checkpoint under `robots/adam_lite/campaigns/NAME/` (replaced on every save), `resume NAME` restarts every run from the arguments its checkpoint stores. A cra-grid study's runs (several run directories under one name: `save NAME <out>/walk/*/`) go with the record beside each (RUN.json: the walk study's checks); `restore NAME --out DIR` puts them back as DIR/<run>/ and DIR/<run>.json without training, and re-running the study's cra-grid command continues them.",
}
def rows(name):
    h = subprocess.run([f".venv/bin/{name}", "--help"], capture_output=True, text=True, env={**os.environ, "COLUMNS": "200"}).stdout
    out, cur, positional = [], None, False
    for raw in h.splitlines():
        line = raw.replace("│", " ").rstrip()
        if "positional" in raw:
            positional = True
        elif "options" in raw:
            positional = False
        if "╭" in raw or "╰" in raw or not line.strip() or line.strip().startswith(("usage", "options:", "positional")):
            continue
        indent = len(line) - len(line.lstrip())
        s = line.strip()
        if cur is not None and cur[0].count("{") > cur[0].count("}"):  # a flag's choices wrapped onto this line
            cur[0] += s; continue
        if indent <= 4 and (positional or s.startswith("-") or s.startswith("[") or s.split()[0].isupper()
                            or s.startswith("{")):
            if cur is not None and not cur[1] and s.startswith("[...]"):
                cur[0] += " " + s; continue
            parts = re.split(r"\s{2,}", s, maxsplit=1)
            cur = [parts[0], parts[1] if len(parts) > 1 else ""]
            out.append(cur)
        elif cur is not None and indent > 4:
            cur[1] = (cur[1] + " " + s).strip()
    return [r for r in out if not r[0].startswith("-h")], h
md = ["# Commands and flags", "",
      "Every command the package installs (`pyproject.toml`'s scripts), what it does, and every flag as its `--help`",
      "gives it (this page is generated from the `--help` texts; tests/test_docs.py checks that it lists every flag).",
      "Bad input is a one-line error naming the problem, exit code 2.", ""]
md += ["| command | what |", "|---|---|"] + [f"| [`{n}`](#{n}) | {ABOUT[n].split('. ')[0].rstrip('.').replace('|', chr(92) + '|')}. |" for n in scripts] + [""]
for n in scripts:
    rs, h = rows(n)
    md += [f"## {n}", "", ABOUT[n], "", "| flag | what |", "|---|---|"]
    for opt, what in rs:
        md.append(f"| `{opt.replace('|', chr(92) + '|')}` | {what.replace('|', '/')} |")
    md.append("")
md += ["## Data-parallel training and the GPU", "",
 "Data-parallel training uses torchrun; on the CPU the processes talk over gloo (one core each), on CUDA over NCCL:", "",
 "```bash", ".venv/bin/torchrun --nproc-per-node 2 -m train.train --num-envs 64     # 2 x 64 robots", "```", "",
 "On a CUDA machine, the first thing to run is `bash tools/gpu_check.sh [cuda:0]`: the simulator and task tests on the",
 "GPU (`CRA_TEST_DEVICE=cuda:0`; every test runs on the CPU by default), 50 training iterations at N=4096 on flat and",
 "rough ground, and `cra-bench` of the Newton world and the task on CUDA (tools/results/bench_cuda.json), with a",
 "summary at the end. It has not run yet: no GPU has been available to this project.", "",
 "TensorBoard: `.venv/bin/tensorboard --logdir runs` (losses, InfoNCE loss and top-1 accuracy with its chance level,",
 "each Table I term per episode second, terrain level, env-steps/s).", ""]
open("docs/cli.md", "w").write("\n".join(md))
