"""Assemble opendbc's Toyota powertrain DBC from the parts in the opendbc wheel.

opendbc (commaai, MIT licence, https://github.com/commaai/opendbc) ships its Toyota networks
as parts: a top file (``toyota_nodsu_pt.dbc``) whose ``CM_ "IMPORT name";`` lines name shared
parts (``_toyota_2017.dbc``, ``_toyota_adas_standard.dbc``). The network is the imported
parts in order, then the top file without its import lines. This script does that from the
installed wheel (``pip install opendbc``) and writes one DBC that cantools loads; pacc's
binding for it is ``dbc/bindings/toyota_nodsu.binding.toml`` (docs/vehicles.md). The DBC is
not vendored in pacc: it is opendbc's work, rebuilt from the wheel on demand.

    python tools/opendbc_toyota.py -o toyota_nodsu_pt_generated.dbc   # by its path, any folder
    pacc drive --dbc toyota_nodsu_pt_generated.dbc --binding toyota_nodsu

Exit status: 0 written, 2 opendbc not installed or the part not found.
"""

from __future__ import annotations

import argparse
import importlib.util
import re
import sys
from pathlib import Path

#: the top part of the network pacc's Toyota binding is written for
DEFAULT_PART = "toyota_nodsu_pt"
_IMPORT = re.compile(r'^CM_ "IMPORT (?P<name>[^"]+)";[ \t]*\r?\n', re.MULTILINE)


class OpendbcError(Exception):
    """opendbc is not installed, or a part is missing."""


def parts_dir() -> Path:
    """The folder of the Toyota parts in the installed opendbc wheel.

    Raises:
        OpendbcError: opendbc is not installed.
    """
    spec = importlib.util.find_spec("opendbc")
    if spec is None or not spec.submodule_search_locations:
        raise OpendbcError("opendbc is not installed: pip install opendbc")
    return Path(next(iter(spec.submodule_search_locations))) / "dbc" / "generator" / "toyota"


def assemble(top: str = DEFAULT_PART, folder: Path | None = None) -> str:
    """The whole network of part ``top`` (without ``.dbc``): its imports, then itself.

    Raises:
        OpendbcError: a part is missing.
    """
    folder = folder or parts_dir()

    def read(name: str) -> str:
        path = folder / name
        try:
            return path.read_text(encoding="utf-8")
        except OSError as exc:
            raise OpendbcError(f"cannot read opendbc part {path}: {exc}") from None

    text = read(f"{top}.dbc")
    pieces = ['CM_ "assembled by pacc tools/opendbc_toyota.py from opendbc (MIT licence)";\n']
    for match in _IMPORT.finditer(text):
        pieces.append(f'\nCM_ "opendbc part {match["name"]}";\n')
        pieces.append(read(match["name"]))
    pieces.append(f'\nCM_ "opendbc part {top}.dbc";\n')
    pieces.append(_IMPORT.sub("", text))
    return "".join(pieces)


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit status."""
    p = argparse.ArgumentParser(prog="python tools/opendbc_toyota.py", description=__doc__)
    p.add_argument("--part", default=DEFAULT_PART, help=f"top part (default {DEFAULT_PART})")
    p.add_argument("-o", "--out", type=Path, help="output DBC (default PART_generated.dbc)")
    args = p.parse_args(argv)
    out = args.out or Path(f"{args.part}_generated.dbc")
    try:
        text = assemble(args.part)
    except OpendbcError as exc:
        print(f"opendbc_toyota: error: {exc}", file=sys.stderr)
        return 2
    try:
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        print(f"opendbc_toyota: error: cannot write {out}: {exc}", file=sys.stderr)
        return 2
    print(f"{out}: {text.count(chr(10) + 'BO_ ')} messages from opendbc's {args.part}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
