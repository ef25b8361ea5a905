"""cra_warp: a batched Warp/Newton simulator and rsl-rl learner for CRA-Loco humanoid locomotion.

The library knows robots (robots/) but no task: sim world, terrain, kinematics, gait clock, learning, USD, and
the deploy-side policy runner (cra_warp.deploy, numpy only). Importing the package itself imports nothing heavy.
"""
