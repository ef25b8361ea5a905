"""Write JSON (or any text) atomically (temp file + rename): a run stopped mid-write never leaves a torn file."""

from __future__ import annotations

import json
import os
from pathlib import Path


def write_json(path: Path, obj, indent: int = 1) -> None:
    write_text(path, json.dumps(obj, indent=indent))


def write_text(path: Path, text: str) -> None:
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text)
    os.replace(tmp, path)
