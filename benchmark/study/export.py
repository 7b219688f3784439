"""(placeholder: replaced by the module that implements `python -m benchmark.study export`)"""

from blendvoca.errors import UserError


def add_arguments(parser) -> None:
    parser.add_argument("study", help="the study folder")


def run(args) -> int:
    raise UserError("python -m benchmark.study export is not built yet")
