"""keep_freed_memory: with it, the critic's height maps at N=4096 (many ~3 MB temporaries per call) stop
page-faulting in steady state. Each case runs in a fresh interpreter: the setting is process-wide."""

import subprocess
import sys

import pytest

MAPS = """
import resource, sys, torch
if sys.argv[1] == "keep":
    from cra_warp.host_memory import keep_freed_memory
    assert keep_freed_memory()
torch.set_num_threads(1)
from cra_warp.terrain_sampling import bench_height_maps
bench_height_maps(4096, repeats=1)                      # warm-up
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
bench_height_maps(4096, repeats=3)                      # 5 calls
print((resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 5)
"""


def _faults_per_call(mode: str) -> float:
    out = subprocess.run([sys.executable, "-c", MAPS, mode], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc malloc tuning: Linux only")
def test_kept_memory_stops_the_maps_page_faulting():
    default, kept = _faults_per_call("default"), _faults_per_call("keep")
    assert default > 2000, f"default malloc was expected to re-fault its temporaries, got {default:.0f} per call"
    assert kept < 0.2 * default, f"kept memory still page-faults: {kept:.0f} vs {default:.0f} per call"
