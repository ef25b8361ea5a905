"""cra-urdf2usd IN.urdf OUT.usda [--robot auto|adam_lite|none]: URDF -> UsdPhysics stage (cra_warp.usd).

--robot picks the RobotConfig whose PD gains and standing pose become joint drives; `auto` (default) uses the
config named like the URDF's <robot name=...> when there is one, else writes no drives.
Bad input (unreadable file, malformed XML, no links, unknown joint type, dangling parent/child, ...) prints ONE
line to stderr and exits with 2; success prints one line of counts.
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

from pxr import Tf

from cra_warp.usd import ConversionError, convert, parse_urdf


def _robot_configs():
    from robots import ROBOTS  # imported late: the converter itself needs no robot package

    return {name: r.robot for name, r in ROBOTS.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="cra-urdf2usd", description=__doc__.splitlines()[0])
    ap.add_argument("urdf", type=Path, help="input URDF")
    ap.add_argument("out", type=Path, help="output USD (.usda text, .usdc/.usd binary)")
    ap.add_argument("--robot", default="auto", choices=["auto", "none", *_robot_configs()],
                    help="robot config for joint drives (default: auto, by the URDF's robot name)")
    args = ap.parse_args(argv)
    try:
        configs = _robot_configs()
        if args.robot == "auto":
            robot = configs.get(parse_urdf(args.urdf).name)
        else:
            robot = configs.get(args.robot)
        counts = convert(args.urdf, args.out, robot)
    except (OSError, ET.ParseError, ConversionError, Tf.ErrorException) as e:
        msg = e.strerror if isinstance(e, OSError) and e.strerror else str(e)
        print(f"cra-urdf2usd: error: {args.urdf}: {' '.join(msg.split())}", file=sys.stderr)
        raise SystemExit(2) from None
    drives = f"drives from {robot.name}" if robot else "no drives"
    print(f"{args.urdf} -> {args.out}: {counts} ({drives})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
