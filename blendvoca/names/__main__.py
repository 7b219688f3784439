"""``python -m blendvoca.names list|show CONVENTION``: the blendshape naming conventions.

``list`` prints one line per convention (name, count, the ARKit shapes it lacks,
what uses it; ``*`` marks entries with a fact that could not be checked against a
primary source); ``show NAME`` prints its names in column order, as its files spell
them, its source and what was and was not checked.
"""

from __future__ import annotations

import sys

from blendvoca import cli
from blendvoca.names import CONVENTIONS, convention


def _lacks(entry) -> str:
    if entry.lacks is None:
        return "names come with each file"
    return ", ".join(entry.lacks) if entry.lacks else "nothing"


@cli.command
def main(argv: list[str] | None = None) -> int:
    p = cli.parser("blendvoca.names", "The blendshape naming conventions: names, order, count, source.")
    commands = p.add_subparsers(dest="command", required=True, metavar="list|show")
    commands.add_parser("list", help="one line per convention")
    show = commands.add_parser("show", help="one convention's names in column order, its source and checks")
    show.add_argument("convention", help=f"one of: {', '.join(CONVENTIONS)}")
    args = p.parse_args(argv)
    if args.command == "list":
        width = max(len(n) for n in CONVENTIONS)
        for entry in CONVENTIONS.values():
            count = "?" if entry.count is None else str(entry.count)
            mark = "*" if entry.unverified else " "
            print(f"{entry.name:<{width}} {count:>3}{mark} {entry.title}; lacks: {_lacks(entry)}")
        print("* a fact of this entry could not be checked against a primary source: "
              "python -m blendvoca.names show NAME")
        return cli.EXIT_OK
    entry = convention(args.convention)
    print(f"{entry.name}: {entry.title}")
    spelling = "PascalCase" if entry.spelling == "pascal" else "camelCase"
    print(f"count: {'?' if entry.count is None else entry.count}; spelling: {spelling}")
    print(f"lacks (of ARKit's 52): {_lacks(entry)}")
    print(f"source: {entry.source}")
    print(f"checked: {entry.checked}")
    if entry.unverified:
        print(f"not verified: {entry.unverified}")
    if entry.to_arkit:
        print("map onto ARKit (each shape clip(sum of weight x control, 0, 1)):")
        for mapping in entry.to_arkit:
            terms = " + ".join(f"{w:g} {c}" for c, w in mapping.terms)
            print(f"  {mapping.arkit} = {terms}  [{mapping.basis}]")
    columns = entry.columns()
    if columns is not None:
        print("columns:")
        for k, name in enumerate(columns):
            print(f"  {k:2d} {name}")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
