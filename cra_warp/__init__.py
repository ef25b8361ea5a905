"""cra_warp: a batched Warp/Newton simulator and rsl-rl learner for CRA-Loco humanoid locomotion.

The library knows robots (robots/) but no task: sim world, terrain, kinematics, gait clock, learning, USD.
"""

import warp as wp

# Warp logs every kernel module load (hundreds per world); keep the console for our own progress output.
wp.config.quiet = True
wp.config.log_level = wp.LOG_WARNING
