"""``python -m benchmark.results upgrade FILE...``: rewrite schema-2 result files as schema 3.

Schema 3 holds the fields schema 2 held, so the upgrade sets ``schema_version`` and
checks the file (every number stays as it was); a file already at schema 3 is left
alone. Schema-1 files (protocol v2) are refused: rescore those runs.
"""

from __future__ import annotations

import sys

from benchmark.results.files import check, write
from benchmark.results.record import SCHEMA_VERSION
from blendvoca import cli
from blendvoca.io.json_file import read_json


def upgrade(path) -> bool:
    """Rewrite the schema-2 result file ``path`` as schema 3; False when it already is.

    Raises
    ------
    DataError
        It is not a schema-2 or schema-3 result (:func:`benchmark.results.check`).
    """
    record = read_json(path, what="valid JSON")
    if isinstance(record, dict) and record.get("schema_version") == 2:
        write(path, check({**record, "schema_version": SCHEMA_VERSION}, str(path)))
        return True
    check(record, str(path))
    return False


@cli.command
def main(argv=None) -> int:
    p = cli.parser("benchmark.results", __doc__)
    sub = p.add_subparsers(dest="command", required=True)
    up = sub.add_parser("upgrade", help="rewrite schema-2 result files as schema 3")
    up.add_argument("files", nargs="+", help="result JSON files")
    args = p.parse_args(argv)
    for path in args.files:
        print(f"{path}: {'upgraded to schema 3' if upgrade(path) else 'already schema 3'}")
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
