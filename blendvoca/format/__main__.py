"""``python -m blendvoca.format compare A B | manifest DIR``: the tools over BlendVOCA folders.

``compare A B``: are two builds the same dataset (same recipe, every file within its
stored tolerance)? Exit 0 for the same dataset, 4 (naming the first file) otherwise
(:func:`blendvoca.format.compare.compare_builds`).

``manifest DIR``: write ``manifest.json`` for a hand-made SAiD-layout folder, listing
its files once (:func:`blendvoca.format.manifest.write_folder_manifest`).
"""

from __future__ import annotations

import json
import sys

from blendvoca import cli
from blendvoca.errors import CheckFailed
from blendvoca.format.compare import compare_builds
from blendvoca.format.layout import DATA_DIRS
from blendvoca.format.manifest import write_folder_manifest


def _compare(args) -> int:
    found = compare_builds(args.a, args.b)
    if not found.same:
        raise CheckFailed(f"not the same dataset: {found.problem}")
    worst = max(found.max_difference.items(), key=lambda kv: kv[1], default=None)
    detail = f"; largest difference {worst[1]:.3g} in {worst[0]}" if worst else ""
    print(f"same dataset: recipe {found.recipe[0][:12]}, {found.identical} file(s) identical, "
          f"{found.within} within their tolerance{detail}")
    return cli.EXIT_OK


def _manifest(args) -> int:
    path = write_folder_manifest(args.folder)
    print(f"{path}: {len(json.loads(path.read_text())['files'])} files listed")
    return cli.EXIT_OK


@cli.command
def main(argv: list[str] | None = None) -> int:
    p = cli.parser("blendvoca.format", __doc__)
    sub = p.add_subparsers(dest="tool", required=True, metavar="compare|manifest")
    c = sub.add_parser("compare", help="are two builds the same dataset (same recipe, every file within "
                                       "its stored tolerance)?")
    c.add_argument("a", help="a BlendVOCA folder (with manifest.json)")
    c.add_argument("b", help="another BlendVOCA folder")
    c.set_defaults(run=_compare)
    m = sub.add_parser("manifest", help="write manifest.json for a hand-made SAiD-layout folder")
    m.add_argument("folder", help=f"the SAiD-layout folder ({', '.join(f'{d}/' for d in DATA_DIRS)} ...)")
    m.set_defaults(run=_manifest)
    args = p.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
