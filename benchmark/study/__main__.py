"""``python -m benchmark.study``: a perceptual study of stored runs, from stimuli to analysis.

  create    stimuli and design from stored runs (--results DIR --rows A,B --design ab|mos)
  serve     the study's web application (loopback unless --host is given)
  export    the answers as CSV and JSON (STUDY/export)
  analyze   exclusions, preference shares, MOS, Bradley-Terry, agreement, the metrics against people

Each subcommand lives in its own module, which gives ``add_arguments(parser)`` and ``run(args) -> int``.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence

from blendvoca import cli

SUBCOMMANDS = {
    "create": ("benchmark.study.create", "make the stimuli and the design from stored runs"),
    "serve": ("benchmark.study.serve", "serve the study to participants (loopback unless --host)"),
    "export": ("benchmark.study.export", "write the answers as CSV and JSON"),
    "analyze": ("benchmark.study.analyze", "analyse the answers (and hold the board's metrics against them)"),
}


@cli.command
def main(argv: Sequence[str] | None = None) -> int:
    parser = cli.parser("benchmark.study", __doc__)
    sub = parser.add_subparsers(dest="subcommand", required=True, metavar="{" + ",".join(SUBCOMMANDS) + "}")
    modules = {}
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        module = importlib.import_module(module_name)
        modules[name] = module
        module.add_arguments(sub.add_parser(name, help=help_text, description=module.__doc__))
    args = parser.parse_args(argv)
    return modules[args.subcommand].run(args)


if __name__ == "__main__":
    raise SystemExit(main())
