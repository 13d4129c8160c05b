"""``asmplan import ASSEMBLY -o product.yaml``: a STEP assembly or a folder of per-part meshes
(in assembled pose) becomes a product file, with its recognised features and proposed mates.

Exit codes: 0 written, 2 bad input (missing or unreadable file, an output asmplan did not
write: refused before any work, nothing written).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..knowledge.product_schema import LENGTH_UNITS


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "import", help="turn a STEP assembly or a folder of part meshes into a product file",
        description="Read a STEP (AP203/AP214/AP242) assembly, or a folder of per-part meshes "
                    "(STL, OBJ, PLY, GLB) in their assembled pose, recognise every part's holes, "
                    "bores, pins, shafts, counterbores, chamfers, threads and non-round features, "
                    "propose the mates (coaxial male/female pairs) with their fits, and write the "
                    "product YAML, commented with the evidence, plus one STL per part definition "
                    "in <output stem>_parts/.")
    p.add_argument("assembly", help="STEP file or folder of mesh files")
    p.add_argument("-o", "--output", required=True, help="product YAML to write")
    p.add_argument("--mesh-units", choices=tuple(LENGTH_UNITS), default="mm",
                   help="length unit of mesh files (default mm; STEP carries its own)")
    p.add_argument("--max-clearance-ratio", type=float, default=0.35,
                   help="a drawn clearance up to this fraction of the pin diameter makes a mate "
                        "(default 0.35)")
    p.add_argument("--default-fits", metavar="YAML",
                   help="a YAML file with a default_fits list (a product file, or units: and "
                        "default_fits: only): the fits of line-to-line pairs, tried before the "
                        "built-in rules, and written into the product (docs/product-format.md)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from ..knowledge.errors import ProductError
    from ..knowledge.loader import load_default_fits
    from ..parts.cad_import import CadImportError, ImportSettings, import_assembly
    from ..parts.cad_product import check_outputs, summary_lines, write_product

    rules = None
    if args.default_fits:
        try:
            rules = load_default_fits(args.default_fits)
        except ProductError as exc:
            print(f"asmplan import: {exc}", file=sys.stderr)
            return 2
    settings = ImportSettings(mesh_units_m=LENGTH_UNITS[args.mesh_units],
                              max_clearance_ratio=args.max_clearance_ratio, fit_rules=rules)
    try:
        check_outputs(Path(args.output))  # before any work: never overwrite what asmplan did not write
        result = import_assembly(Path(args.assembly), settings)
        written = write_product(result, Path(args.output))
    except CadImportError as exc:
        print(f"asmplan import: {exc}", file=sys.stderr)
        return 2
    print(f"{args.assembly}: imported \"{result.name}\"")
    for line in summary_lines(result):
        print(f"  {line}")
    mesh_dir = written[-1].parent / (Path(args.output).stem + "_parts")
    print(f"wrote {written[-1]} and {len(written) - 1} part meshes in {mesh_dir}")
    return 0
