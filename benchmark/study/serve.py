"""(placeholder: replaced by the module that implements `python -m benchmark.study serve`)"""

from blendvoca.errors import UserError


def add_arguments(parser) -> None:
    parser.add_argument("study", help="the study folder")


def run(args) -> int:
    raise UserError("python -m benchmark.study serve is not built yet")
