"""Compare the numbers of two report output folders, leaf by leaf, bit for bit.

Usage::

    python scripts/report_diff.py OLD_REPORT_DIR NEW_REPORT_DIR [--ignore KEY]...

Every JSON file and every CSV file under ``data/`` is compared: JSON leaves by
their path (``cases.json:rows[3].alpha_rad``), CSV cells by (row, column).
Numbers must be equal as floats (bit for bit after parsing); strings equal as
text. Leaves whose last key is in the ignore list (code digests, timings,
versions: they say how a number was made, not what it is) are skipped.
Exit 0 when every compared number is equal, 1 otherwise (the differences are
printed), 2 on bad arguments.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
from pathlib import Path

#: Leaves that record provenance or timing, not results.
DEFAULT_IGNORE = {"fem_code", "code", "seconds", "elapsed_s", "wall_s", "versions", "created"}


def _leaves(obj, path: str):
    if isinstance(obj, dict):
        for key, value in obj.items():
            yield from _leaves(value, f"{path}.{key}" if path else str(key))
    elif isinstance(obj, list):
        for i, value in enumerate(obj):
            yield from _leaves(value, f"{path}[{i}]")
    else:
        yield path, obj


def _last_key(path: str) -> str:
    return path.rsplit(".", 1)[-1].split("[", 1)[0]


def _json_leaves(file: Path, ignore: set[str]) -> dict[str, object]:
    data = json.loads(file.read_text())
    return {p: v for p, v in _leaves(data, "") if _last_key(p) not in ignore}


def _csv_leaves(file: Path, ignore: set[str]) -> dict[str, object]:
    with file.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    return {f"[{i}].{k}": v for i, row in enumerate(rows) for k, v in row.items() if k not in ignore}


def _same(a, b) -> bool:
    if isinstance(a, str) and isinstance(b, str):
        try:
            return float(a) == float(b) or a == b
        except ValueError:
            return a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        return float(a) == float(b) or (a != a and b != b)  # NaN equals NaN here
    return a == b


def compare(old: Path, new: Path, ignore: set[str]) -> tuple[int, list[str]]:
    """(number of leaves compared, list of differences) between two report folders."""
    differences, compared = [], 0
    old_files = {p.relative_to(old) for p in (old / "data").rglob("*") if p.suffix in (".json", ".csv")}
    new_files = {p.relative_to(new) for p in (new / "data").rglob("*") if p.suffix in (".json", ".csv")}
    for missing in sorted(old_files ^ new_files):
        differences.append(f"{missing}: only in {'old' if missing in old_files else 'new'}")
    for rel in sorted(old_files & new_files):
        read = _json_leaves if rel.suffix == ".json" else _csv_leaves
        a, b = read(old / rel, ignore), read(new / rel, ignore)
        for path in sorted(set(a) | set(b)):
            compared += 1
            if path not in a or path not in b:
                differences.append(f"{rel}:{path}: only in {'old' if path in a else 'new'}")
            elif not _same(a[path], b[path]):
                differences.append(f"{rel}:{path}: {a[path]!r} != {b[path]!r}")
    return compared, differences


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", type=Path)
    parser.add_argument("new", type=Path)
    parser.add_argument("--ignore", action="append", default=[], help="a leaf key to skip (repeatable)")
    args = parser.parse_args(argv)
    for folder in (args.old, args.new):
        if not (folder / "data").is_dir():
            print(f"report_diff: {folder} has no data/ folder", file=sys.stderr)
            return 2
    compared, differences = compare(args.old, args.new, DEFAULT_IGNORE | set(args.ignore))
    for line in differences:
        print(line)
    print(f"{compared} leaves compared, {len(differences)} differ")
    return 1 if differences else 0


if __name__ == "__main__":
    sys.exit(main())
