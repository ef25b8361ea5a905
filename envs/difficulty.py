"""A difficulty curriculum: one level in [0, 1] that scales what the task asks of a young policy.

Level 1 is the task as configured. With ``DifficultyConfig.commands`` the sampled velocity commands are scaled by
the level (below ``CommandConfig.min_speed`` they become "stand still"); with ``randomization`` every physical
randomisation range shrinks towards nominal (level 0: the nominal robot) and pushes and shoves scale with it.
The level moves once every ``interval`` env steps, judged on the episodes that ended in that window: up by ``step``
when their mean length reached ``promote`` x the episode length, down by ``step`` when it stayed below ``demote``.
Tensor ops only (no host sync in the step); the level travels in checkpoints so a resumed run keeps it.
"""

from __future__ import annotations

import torch

from envs.loco_config import DifficultyConfig


class Difficulty:
    def __init__(self, cfg: DifficultyConfig, max_episode_length: int, device: torch.device):
        self.cfg = cfg
        self.active = cfg.commands or cfg.randomization
        self.level = torch.tensor(cfg.start if self.active else 1.0, device=device)
        self._max_len = float(max_episode_length)
        self._ended_len = torch.zeros((), device=device)   # summed lengths of the episodes ended in the window
        self._ended = torch.zeros((), device=device)       # their count
        self._steps = 0

    @property
    def command_scale(self) -> torch.Tensor | float:
        return self.level if self.cfg.commands else 1.0

    @property
    def randomization_scale(self) -> torch.Tensor | float:
        return self.level if self.cfg.randomization else 1.0

    def record(self, lengths: torch.Tensor, ended: torch.Tensor) -> None:
        """One env step: episode lengths [N] (steps) of the envs, ``ended`` [N] bool where an episode ended now."""
        if not self.active:
            return
        self._ended_len += (lengths * ended).sum()
        self._ended += ended.sum()
        self._steps += 1
        if self._steps % self.cfg.interval:
            return
        seen = self._ended > 0
        mean = self._ended_len / self._ended.clamp(min=1) / self._max_len
        move = (seen & (mean >= self.cfg.promote)).float() - (seen & (mean < self.cfg.demote)).float()
        self.level.copy_((self.level + self.cfg.step * move).clamp(0.0, 1.0))
        self._ended_len.zero_()
        self._ended.zero_()
