"""The command-line layer that every ``python -m ...`` tool of the project stands on.

It owns two things:

**Exit codes.** A tool's ``main(argv=None) -> int`` is wrapped in :func:`command`,
which maps what escapes it onto one exit code and one way of printing it:

=====  ==========================================================================
code   meaning
=====  ==========================================================================
0      done
1      an internal bug: the traceback, then a line saying it is a bug to report
2      a user or data error (:class:`~blendvoca.errors.UserError`,
       :class:`~blendvoca.errors.DataError`, an ``OSError`` on a user's path, a bad
       flag): one ``error: ...`` line, nothing written
3      a method plug-in misbehaved (:class:`~blendvoca.errors.MethodError`): one
       ``error: the method misbehaved ...`` line, nothing written
4      a check ran and found a problem (:class:`~blendvoca.errors.CheckFailed`:
       a corrupted asset, a failed sanity or verification check)
5      the job ran to its end but some of its items failed (each listed); the other
       outputs are complete (a build with bad sentences)
130    interrupted (Ctrl-C); long jobs resume when the same command is run again
=====  ==========================================================================

**Shared options.** :func:`parser` makes an ``argparse`` parser whose usage errors are
one ``error:`` line with exit 2; ``add_*_option(s)`` add the options that several
tools share, spelled and explained the same way everywhere and listed under
"shared options" in ``--help``: ``--data``, ``--results``, ``--budget`` /
``--max-steps`` / ``--max-seconds``, ``--config`` / ``--preset``, ``--device`` and
``--quiet``.

**The progress switch.** A :class:`Parser` that has ``--quiet``
(:func:`add_quiet_option`) sets :func:`blendvoca.runtime.progress.set_progress` from it
when it parses the command line, once per command: library code draws its bars with
:func:`blendvoca.runtime.progress.bar` and takes no ``progress`` parameter.
"""

from __future__ import annotations

import argparse
import contextvars
import functools
import json
import re
import sys
import traceback

from blendvoca.errors import (
    CheckFailed,
    DataError,
    MethodError,
    OutOfResources,
    UserError,
    error_line,
    out_of_resources,
    ran_out_of,
)
from blendvoca.runtime.progress import set_progress

__all__ = [
    "EXIT_BUG",
    "EXIT_CHECK_FAILED",
    "EXIT_INTERRUPTED",
    "EXIT_METHOD",
    "EXIT_OK",
    "EXIT_PARTIAL",
    "EXIT_USER",
    "Parser",
    "add_budget_options",
    "add_config_options",
    "add_data_option",
    "add_device_option",
    "add_quiet_option",
    "add_results_option",
    "budget_limits",
    "checked_device",
    "command",
    "exit_code_of",
    "parse_budget_text",
    "parse_config",
    "parser",
    "shared_options",
]

EXIT_OK = 0
EXIT_BUG = 1
EXIT_USER = 2
EXIT_METHOD = 3
EXIT_CHECK_FAILED = 4
EXIT_PARTIAL = 5
EXIT_INTERRUPTED = 130

#: The line printed under the traceback of an internal bug.
BUG_LINE = ("error: internal error (a bug in BlendVOCA, not in your input): please report it with the "
            "traceback above and the command you ran")

SHARED_TITLE = "shared options"
#: Options (by ``dest``) that name a file or folder: an empty string given to one is refused.
PATH_OPTIONS = frozenset({"out", "results", "work", "data", "tables", "vocaset", "checkpoint", "root", "archive",
                          "docs", "frames", "rig", "vae", "sync_expert", "syncnet_weights", "pose_names",
                          "config_file", "corpus", "cache", "output"})


def exit_code_of(error: BaseException) -> int:
    """The exit code for an exception that escaped a tool (see the module's table); memory
    or disk space that ran out (:func:`blendvoca.errors.ran_out_of`) is exit 2, never a bug."""
    if isinstance(error, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    if ran_out_of(error) is not None and not isinstance(error, (MethodError, CheckFailed)):
        return EXIT_USER
    if isinstance(error, MethodError):
        return EXIT_METHOD
    if isinstance(error, CheckFailed):
        return EXIT_CHECK_FAILED
    if isinstance(error, (UserError, DataError, OSError)):
        return EXIT_USER
    return EXIT_BUG


def report(error: BaseException, *, stream=None) -> int:
    """Print ``error`` the way its exit code asks and return that code."""
    stream = sys.stderr if stream is None else stream
    code = exit_code_of(error)
    if code == EXIT_INTERRUPTED:
        print("interrupted: rerun the same command to continue", file=stream)
    elif code == EXIT_BUG:
        traceback.print_exception(type(error), error, error.__traceback__, file=stream)
        print(BUG_LINE, file=stream)
    elif code == EXIT_METHOD:
        print(error_line(error).replace("error: ", "error: the method misbehaved, nothing written: ", 1), file=stream)
    elif ran_out_of(error) is not None and not isinstance(error, OutOfResources):
        print(error_line(out_of_resources(error)), file=stream)
    else:
        print(error_line(error), file=stream)
    return code


def command(main):
    """Wrap a tool's ``main(argv=None) -> int | None`` so that what escapes it becomes
    one exit code (module table); ``SystemExit`` (argparse's ``--help``, usage errors)
    passes through. ``main`` runs in a copy of the caller's context: the progress switch
    its ``--quiet`` sets lasts for that command only (a caller that runs several tools
    in one process, a test, keeps its own)."""

    @functools.wraps(main)
    def wrapped(argv=None) -> int:
        try:
            code = contextvars.copy_context().run(main, argv)
        except SystemExit:
            raise
        except BaseException as error:  # noqa: BLE001 - every escape gets an exit code; bugs keep their traceback
            return report(error)
        return EXIT_OK if code is None else int(code)

    return wrapped


#: The address space (MiB) below which loading PyTorch beside the project's libraries aborts the
#: process (a C++ ``std::bad_alloc``: no Python error to catch). Measured with ``benchmark.run
#: --method mean`` on a 6-sentence build under ``RLIMIT_AS``: 700 MiB aborts at ``import torch``,
#: 850 MiB loses a BLAS worker, 1000 MiB completes with every metric.
TORCH_ADDRESS_SPACE_MIB = 1000


def require_address_space(command: str, minimum_mib: int = TORCH_ADDRESS_SPACE_MIB) -> None:
    """Refuse to start ``command`` (one ``error:`` line, exit 2) under an address-space limit
    (``ulimit -v``) below ``minimum_mib``, where it would abort without a message."""
    import resource

    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft == resource.RLIM_INFINITY or soft >= minimum_mib << 20:
        return
    raise OutOfResources(f"{command} needs an address space of at least {minimum_mib} MiB (it loads PyTorch, "
                         f"which aborts the process below that), and `ulimit -v` allows {soft >> 20} MiB here; "
                         f"raise the limit (`ulimit -v unlimited`, or at least `ulimit -v {minimum_mib * 1024}`)")


class Parser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose usage errors are one ``error:`` line and exit 2, and
    which sets the progress switch from ``--quiet`` (when it has that option)."""

    def parse_known_args(self, args=None, namespace=None):
        raw = list(sys.argv[1:] if args is None else args)
        # "" is no path (and Path("") is the working folder): one clear line, not what it does later
        paths = {flag for action in self._actions if action.dest in PATH_OPTIONS for flag in action.option_strings}
        for index, arg in enumerate(raw):
            flag, equals, value = str(arg).partition("=")
            if flag in paths and ((equals and not value) or (not equals and index + 1 < len(raw)
                                                               and raw[index + 1] == "")):
                self.error(f"{flag}: expected a path, got an empty string")
        namespace, extras = super().parse_known_args(args, namespace)
        if "quiet" in vars(namespace):
            set_progress(not namespace.quiet)
        return namespace, extras

    def error(self, message):
        print(f"error: {' '.join(str(message).split())}", file=sys.stderr)
        raise SystemExit(EXIT_USER)


def parser(prog: str, description: str | None = None, **kwargs) -> Parser:
    """A :class:`Parser` for ``python -m <prog>``; ``description`` is usually the
    first paragraph of the tool's docstring."""
    if description:
        description = description.strip().split("\n\n")[0]
    return Parser(prog=prog if prog.startswith("python ") else f"python -m {prog}", description=description, **kwargs)


def shared_options(p: argparse.ArgumentParser):
    """The argument group that holds the shared options (made once per parser)."""
    for group in p._action_groups:
        if group.title == SHARED_TITLE:
            return group
    return p.add_argument_group(SHARED_TITLE)


def add_data_option(p: argparse.ArgumentParser, *, required: bool = False,
                    help: str = "BlendVOCA build folder (default: the bundled-default build)") -> None:
    """``--data DIR``: the BlendVOCA build a tool reads."""
    shared_options(p).add_argument("--data", required=required, default=None, metavar="DIR", help=help)


def add_results_option(p: argparse.ArgumentParser, *, required: bool = False,
                       help: str = "result folder (default: $BLENDVOCA_RESULTS or "
                                   "~/.local/share/blendvoca/results)", default=None) -> None:
    """``--results DIR``: where result files are (read or written)."""
    shared_options(p).add_argument("--results", required=required, default=default, metavar="DIR", help=help)


def add_budget_options(p: argparse.ArgumentParser, *, default_steps: int | None = None) -> None:
    """``--budget``, ``--max-steps`` and ``--max-seconds``: one training budget spelling.
    Read the result with :func:`budget_limits`.
    """
    group = shared_options(p)
    group.add_argument("--budget", default=None, metavar="BUDGET",
                       help="training budget: '500' steps (deterministic), '300s' / '5m' / '1h' (recorded as "
                            "non-deterministic), or 'steps=500,seconds=300'")
    steps_help = "training steps at most" + ("" if default_steps is None else f" (default {default_steps})")
    group.add_argument("--max-steps", type=int, default=None, metavar="N", help=steps_help)
    p.set_defaults(default_max_steps=default_steps)  # applied by budget_limits when nothing sets the steps
    group.add_argument("--max-seconds", type=float, default=None, metavar="S", help="training seconds at most")


def parse_budget_text(text: str | None) -> tuple[int | None, float | None]:
    """``(max_steps, max_seconds)`` from ``--budget`` text (either may be None).

    Accepted: ``"500"`` or ``"500steps"`` (steps), ``"90s"``, ``"5m"``, ``"1h"``
    (time), or comma-separated ``"steps=500,seconds=300"``.
    """
    steps = seconds = None
    for part in str(text or "").replace(" ", "").split(","):
        if not part:
            continue
        m = re.fullmatch(r"(?:steps=)?(\d+)(?:steps?)?", part)
        if m:
            steps = int(m.group(1))
            continue
        m = re.fullmatch(r"(?:seconds=)?(\d+(?:\.\d*)?)(s|sec|m|min|h)?", part)
        if m and (m.group(2) or part.startswith("seconds=")):
            factor = {"s": 1, "sec": 1, None: 1, "m": 60, "min": 60, "h": 3600}[m.group(2)]
            seconds = float(m.group(1)) * factor
            continue
        raise UserError(f"--budget: expected e.g. '500' (steps), '300s', '5m' or 'steps=500,seconds=300', "
                        f"got {part!r}")
    return steps, seconds


def budget_limits(args: argparse.Namespace) -> tuple[int | None, float | None]:
    """``(max_steps, max_seconds)`` from the options of :func:`add_budget_options`:
    ``--budget`` text first, explicit ``--max-steps`` / ``--max-seconds`` over it, and the
    tool's default step count when no limit is given at all."""
    steps, seconds = parse_budget_text(getattr(args, "budget", None))
    if getattr(args, "max_steps", None) is not None:
        steps = args.max_steps
    if steps is None and seconds is None:
        steps = getattr(args, "default_max_steps", None)
    if getattr(args, "max_seconds", None) is not None:
        seconds = args.max_seconds
    for flag, value in (("--max-steps", steps), ("--max-seconds", seconds)):
        if value is not None and not value > 0:
            raise UserError(f"{flag}: expected a number > 0, got {value!r}")
    return steps, seconds


def add_config_options(p: argparse.ArgumentParser, *, preset_default: str | None = None,
                       preset_help: str = "method preset, passed to the method config as preset=...") -> None:
    """``--config KEY=VALUE`` (repeatable) and ``--preset NAME``; read them with :func:`parse_config`."""
    group = shared_options(p)
    group.add_argument("--preset", default=preset_default, metavar="NAME", help=preset_help)
    group.add_argument("--config", action="append", default=[], metavar="KEY=VALUE",
                       help="method config entry (repeatable; VALUE parsed as JSON when possible)")


def parse_config(pairs=(), *, preset: str | None = None, schema=None, method: str = "method") -> dict:
    """Method config from ``KEY=VALUE`` strings (values parsed as JSON when they can be);
    ``preset`` (``--preset``) is passed through as ``config["preset"]``.

    ``schema``, the method's declaration (a
    :class:`benchmark.methods.config.ConfigSchema`, or any object with its ``parse``
    and ``check``), reads each value against its option's type and refuses an unknown
    key or a wrong type with a :class:`UserError` naming ``method``, the key, the
    expected type and what arrived; None (a method that declares nothing) only parses.
    """
    if schema is not None:
        config = schema.parse(list(pairs or ()), method=method)
        if preset is not None:
            try:
                schema.check({"preset": preset}, method=method)
            except UserError as exc:  # name the option the user typed
                raise UserError(str(exc).replace("--config preset", "--preset", 1)) from None
            config["preset"] = preset
        return config
    config = {}
    for pair in pairs or ():
        key, sep, value = str(pair).partition("=")
        if not sep or not key:
            raise UserError(f"--config: expected KEY=VALUE, got {pair!r}")
        try:
            config[key] = json.loads(value)
        except json.JSONDecodeError:
            config[key] = value
    if preset is not None:
        config["preset"] = preset
    return config


def add_device_option(p: argparse.ArgumentParser, *, default: str = "auto") -> None:
    """``--device auto|cpu|cuda|cuda:N`` for tools that run a network."""
    shared_options(p).add_argument("--device", default=default, metavar="DEVICE",
                                   help="torch device: auto (a GPU when there is one), cpu, cuda or cuda:N "
                                        f"(default {default})")


def checked_device(name) -> str | None:
    """The torch device ``--device`` names, as a string the methods read: ``"cpu"``,
    ``"cuda"`` or ``"cuda:N"``; ``"auto"`` is ``"cuda"`` when torch sees a GPU, else
    ``"cpu"``; None stays None (each method's own choice).

    Raises
    ------
    UserError
        A name that is no such device, or a CUDA device torch does not see here (one
        ``error:`` line, exit status 2, before anything is read or trained).
    """
    if name is None:
        return None
    text = str(name).strip().lower()
    kind, sep, index = text.partition(":")
    if text != "auto" and (kind not in ("cpu", "cuda") or (sep and (kind != "cuda" or not index.isdigit()))):
        raise UserError(f"--device: expected auto, cpu, cuda or cuda:N, got {name!r}")
    if text == "cpu":
        return "cpu"  # torch is not even imported for the CPU
    import torch  # only for a GPU: whether torch sees one

    available = torch.cuda.is_available()
    if text == "auto":
        return "cuda" if available else "cpu"
    if not available:
        raise UserError(f"--device {name}: torch sees no CUDA device here (torch {torch.__version__}, "
                        f"CUDA build {torch.version.cuda or 'none'}); use --device cpu")
    if sep and int(index) >= torch.cuda.device_count():
        raise UserError(f"--device {name}: there are {torch.cuda.device_count()} CUDA devices (cuda:0 .. "
                        f"cuda:{torch.cuda.device_count() - 1})")
    return text


def add_quiet_option(p: argparse.ArgumentParser) -> None:
    """``--quiet``: no progress bars (errors are still printed); the parser sets the progress
    switch from it (:func:`blendvoca.runtime.progress.set_progress`)."""
    shared_options(p).add_argument("--quiet", action="store_true", help="no progress bars")
