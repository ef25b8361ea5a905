"""cra-terrain: render a terrain's heightfield as a height image, levels and types labelled.

    cra-terrain --png terrain.png                     # the default training terrain
    cra-terrain --png t.png --levels 5 --seed 3 --tile-size 6
    cra-terrain --png course.png --course             # the evaluation course, starts (o) and targets (x)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


class _OneLineParser(argparse.ArgumentParser):
    def error(self, message):  # argparse prints the usage too; a bad argument is one line here
        self.exit(2, f"{self.prog}: error: {message}\n")


def render(terrain, path: Path, title: str, course=None) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hf = terrain.field
    nx, ny = hf.shape
    res = hf.resolution
    x0, y0 = hf.origin[0] - res / 2, hf.origin[1] - res / 2
    fig, ax = plt.subplots(figsize=(2 + 1.2 * terrain.num_cols, 1.5 + 1.0 * terrain.num_levels), dpi=110)
    # rows of the image = x (levels, bottom to top), columns = y (types, left to right)
    im = ax.imshow(hf.heights, origin="lower", cmap="terrain", interpolation="nearest",
                   extent=(y0, y0 + ny * res, x0, x0 + nx * res))
    fig.colorbar(im, ax=ax, label="height [m]", shrink=0.8)
    first_row = [terrain.tile(0, c) for c in range(terrain.num_cols)]
    first_col = [terrain.tile(lv, 0) for lv in range(terrain.num_levels)]
    ax.set_xticks([t.centre[1] for t in first_row], [t.kind.replace("_", " ") for t in first_row], rotation=30,
                  ha="right")
    unit = {"stairs": "cm", "slope": "deg", "uneven": "cm"}

    def level_label(lv):
        parts = []
        for c in range(terrain.num_cols):
            t = terrain.tile(lv, c)
            key = t.kind.split("_")[0]
            if key in unit and key not in [p.split(" ")[0] for p in parts]:
                v = t.difficulty * (100 if unit[key] == "cm" else 1)
                parts.append(f"{key} {v:.0f}{unit[key]}")
        return f"L{lv}" + (": " + ", ".join(parts) if parts else "")

    ax.set_yticks([t.centre[0] for t in first_col], [level_label(t.level) for t in first_col], fontsize=7)
    if course is not None:  # one arrow per (kind, level): start -> target
        for s, g in zip(course.starts.reshape(-1, 3), course.targets.reshape(-1, 3)):
            ax.annotate("", xy=(g[1], g[0]), xytext=(s[1], s[0]),
                        arrowprops=dict(arrowstyle="->", color="red", lw=1.2))
            ax.plot(g[1], g[0], "o", color="lime", ms=4)
    ax.set_title(title, fontsize=9)
    fig.savefig(path, bbox_inches="tight")
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    from cra_warp.terrain import TerrainConfig

    d = TerrainConfig()
    p = _OneLineParser(prog="cra-terrain", description=__doc__.splitlines()[0])
    p.add_argument("--png", type=Path, required=True, help="output image")
    p.add_argument("--levels", type=int, default=d.num_levels, help="difficulty levels (rows)")
    p.add_argument("--cols", type=int, default=d.num_cols, help="type columns")
    p.add_argument("--seed", type=int, default=None, help="default: the config's")
    p.add_argument("--tile-size", type=float, default=d.tile_size, help="[m]")
    p.add_argument("--resolution", type=float, default=d.resolution, help="[m]")
    p.add_argument("--course", action="store_true", help="render the evaluation course instead")
    args = p.parse_args(argv)
    if not args.png.parent.exists():
        p.error(f"--png: directory {args.png.parent} does not exist")
    if args.png.suffix.lower() != ".png":
        p.error(f"--png: expected a .png file name, got {args.png.name}")

    from cra_warp.terrain import generate_terrain
    from cra_warp.terrain.boxes import terrain_boxes

    try:
        if args.course:
            from cra_warp.terrain.course import EvalCourse, EvalCourseConfig

            c = EvalCourseConfig()
            course = EvalCourse(EvalCourseConfig(num_levels=args.levels if args.levels != d.num_levels else c.num_levels,
                                                 seed=c.seed if args.seed is None else args.seed))
            terrain = course.terrain
        else:
            course = None
            terrain = generate_terrain(TerrainConfig(num_levels=args.levels, num_cols=args.cols,
                                                     seed=d.seed if args.seed is None else args.seed,
                                                     tile_size=args.tile_size, resolution=args.resolution))
    except ValueError as e:
        p.error(str(e))
    n_boxes = len(terrain_boxes(terrain).centers)
    title = (f"{'evaluation course (start -> target)' if course else 'training terrain'}: {terrain.num_levels} "
             f"levels x {terrain.num_cols} columns\n{terrain.cfg.tile_size:g} m tiles, seed {terrain.cfg.seed}, "
             f"{n_boxes} collision boxes")
    render(terrain, args.png, title, course)
    print(f"wrote {args.png} ({title.replace(chr(10), ', ')})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
