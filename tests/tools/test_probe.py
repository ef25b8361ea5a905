"""cra-probe's linear probe: it finds terrain that is linearly in the inputs and none where there is none."""

import torch

from tests.conftest import one_line_error
from tools import probe as probe_cli


def _data(t=40, n=20, informative=True):
    gen = torch.Generator().manual_seed(0)
    targets = {g: torch.randn(t, n, k, generator=gen) for g, k in (("height_map", 187), ("foot_maps", 50),
                                                                 ("slope", 2), ("step", 1))}
    noise = torch.randn(t, n, 256, generator=gen)
    if informative:  # the latent carries slope and step linearly (plus noise), the maps not at all
        mix = torch.randn(3, 256, generator=gen)
        latent = torch.cat([targets["slope"], targets["step"]], -1) @ mix + 0.1 * noise
    else:
        latent = noise
    return {"latent": latent, "obs": torch.randn(t, n, 84, generator=gen), **targets}


def test_probe_recovers_linear_terrain_and_reports_none_where_absent():
    r2 = probe_cli.probe(_data(), lam=1.0, seed=0)
    assert r2["latent"]["slope"] > 0.95 and r2["latent"]["step"] > 0.95
    assert r2["latent"]["height_map"] < 0.05 and r2["obs"]["slope"] < 0.05
    blind = probe_cli.probe(_data(informative=False), lam=1.0, seed=0)
    assert all(v < 0.05 for v in blind["latent"].values())


def test_probe_bad_input(capsys, tmp_path):
    one_line_error(capsys, probe_cli.main([]), "nothing to probe")
    one_line_error(capsys, probe_cli.main([str(tmp_path / "model_1.pt")]), "not found")
