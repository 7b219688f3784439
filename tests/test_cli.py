"""The command-line layer :mod:`blendvoca.cli` and every ``python -m`` tool that stands on it.

The tools are found, not listed: every ``__main__.py`` and every module with an
``if __name__ == "__main__":`` block under blendvoca/, benchmark/, leaderboard/ and
baselines/. Each one's ``--help`` runs in-process; each shared option a tool offers
must come from the ``blendvoca.cli.add_*`` helper and be listed under "shared
options" exactly as that helper lists it (the same flags, metavar, default and help).
"""

from __future__ import annotations

import argparse
import ast
import importlib
import io
import sys
from pathlib import Path

import pytest

from blendvoca import cli
from blendvoca.errors import CheckFailed, DataError, MethodError, OutputDirError, UserError

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("blendvoca", "benchmark", "leaderboard", "baselines")

#: The helpers that add shared options, and the flags each one adds.
HELPERS = ("add_data_option", "add_results_option", "add_budget_options", "add_config_options",
           "add_device_option", "add_quiet_option")


# --------------------------------------------------------------------------- discovery


def _is_main_guard(node: ast.stmt) -> bool:
    if not isinstance(node, ast.If) or not isinstance(node.test, ast.Compare):
        return False
    names = [node.test.left, *node.test.comparators]
    return any(isinstance(n, ast.Name) and n.id == "__name__" for n in names) and any(
        isinstance(n, ast.Constant) and n.value == "__main__" for n in names)


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def discover_commands() -> dict[str, Path]:
    """``{"pkg.mod": file}``: what ``python -m pkg.mod`` runs, for every tool of the project."""
    commands = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            if "node_modules" in path.parts or "__pycache__" in path.parts:
                continue
            if path.name == "__main__.py":
                commands[_module_name(path.parent / "__init__.py")] = path
                continue
            tree = ast.parse(path.read_text(encoding="utf-8"))
            if any(_is_main_guard(node) for node in tree.body):
                commands[_module_name(path)] = path
    return commands


COMMANDS = discover_commands()


def main_of(command: str):
    """The ``main`` that ``python -m command`` calls, imported without running it.

    A file that imports ``main`` from elsewhere (``from blendvoca.retarget.cli import
    main``) is not imported itself: some ``__main__.py`` files call ``main()`` at import.
    """
    path = COMMANDS[command]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = _module_name(path.parent / "__init__.py")
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and any(alias.name == "main" for alias in node.names):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module
            return importlib.import_module(source).main
    if not any(isinstance(node, ast.FunctionDef) and node.name == "main" for node in tree.body):
        pytest.fail(f"{path.relative_to(ROOT)}: python -m {command} has no main(argv=None)")
    module = f"{command}.__main__" if path.name == "__main__.py" else command
    return importlib.import_module(module).main


def test_the_known_tools_are_found():
    expected = {"blendvoca.build", "blendvoca.synthetic", "blendvoca.retarget", "blendvoca.export", "blendvoca.assets",
                "benchmark.run", "benchmark.generate", "benchmark.rescore", "benchmark.render", "benchmark.features.train",
                "benchmark.lipsync.train_expert", "leaderboard.build", "leaderboard.reproduce", "leaderboard.site",
                "baselines.said.generate", "baselines.said.train", "baselines.cdface", "baselines.mesh_adapter.export"}
    assert expected <= set(COMMANDS), sorted(expected - set(COMMANDS))


# --------------------------------------------------------------------------- every tool's --help


class _Recorder:
    """Records the parser that prints ``--help`` and every ``cli.add_*`` call with its arguments."""

    def __init__(self, monkeypatch):
        self.printed: list[argparse.ArgumentParser] = []
        #: (helper name, parser, keyword arguments, the actions it added)
        self.calls: list[tuple[str, argparse.ArgumentParser, dict, list[argparse.Action]]] = []
        original_print_help = argparse.ArgumentParser.print_help

        def print_help(parser, file=None):
            self.printed.append(parser)
            return original_print_help(parser, file)

        monkeypatch.setattr(argparse.ArgumentParser, "print_help", print_help)
        for name in HELPERS:
            helper = getattr(cli, name)

            def recording(p, *, _name=name, _helper=helper, **kwargs):
                before = set(map(id, p._actions))
                result = _helper(p, **kwargs)
                self.calls.append((_name, p, kwargs, [a for a in p._actions if id(a) not in before]))
                return result

            monkeypatch.setattr(cli, name, recording)


def _shared_group(parser: argparse.ArgumentParser):
    return next((g for g in parser._action_groups if g.title == cli.SHARED_TITLE), None)


def _invocation(parser: argparse.ArgumentParser, action: argparse.Action) -> str:
    """The left column of an option's help line, e.g. ``--max-steps N``."""
    return parser._get_formatter()._format_action_invocation(action)


def _reference_actions(helper: str, kwargs: dict) -> list[argparse.Action]:
    """The actions ``blendvoca.cli.<helper>(p, **kwargs)`` adds to a fresh parser."""
    reference = cli.parser("reference")
    before = set(map(id, reference._actions))
    getattr(cli, helper)(reference, **kwargs)
    return [a for a in reference._actions if id(a) not in before]


def _shared_flags() -> set[str]:
    reference = cli.parser("reference")
    for helper in HELPERS:
        getattr(cli, helper)(reference)
    return {flag for action in _shared_group(reference)._group_actions for flag in action.option_strings}


SHARED_FLAGS = _shared_flags()


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_help_lists_the_shared_options_as_blendvoca_cli_does(command, monkeypatch, capsys):
    main = main_of(command)
    recorder = _Recorder(monkeypatch)
    with pytest.raises(SystemExit) as stopped:
        main(["--help"])
    out = capsys.readouterr().out
    assert stopped.value.code == 0, f"python -m {command} --help exited {stopped.value.code}"
    assert out.startswith("usage: python -m "), out[:200]
    assert recorder.printed, f"python -m {command} --help printed no argparse help"
    parser = recorder.printed[-1]
    assert isinstance(parser, cli.Parser), f"python -m {command} does not use blendvoca.cli.parser"

    # Every shared flag the tool offers is in the "shared options" group, from a cli helper.
    group = _shared_group(parser)
    grouped = set(map(id, group._group_actions)) if group else set()
    from_helpers = {id(a) for _, p, _, added in recorder.calls if p is parser for a in added}
    for action in parser._actions:
        shared = [f for f in action.option_strings if f in SHARED_FLAGS]
        if not shared:
            continue
        assert id(action) in grouped, f"python -m {command}: {shared} is not listed under '{cli.SHARED_TITLE}'"
        assert id(action) in from_helpers, f"python -m {command}: {shared} is not added by a blendvoca.cli helper"

    # ... listed as the helper lists it, for the arguments the tool gave the helper.
    for helper, p, kwargs, added in recorder.calls:
        if p is not parser:
            continue
        reference = _reference_actions(helper, kwargs)
        assert [a.option_strings for a in added] == [a.option_strings for a in reference], (command, helper)
        for mine, expected in zip(added, reference):
            where = f"python -m {command} {expected.option_strings[0]}"
            assert _invocation(parser, mine) == _invocation(parser, expected), where
            assert mine.help == expected.help, where
            assert (mine.required, mine.dest, mine.nargs, mine.type) == (
                expected.required, expected.dest, expected.nargs, expected.type), where

    # The printed help shows the heading and each shared option under it.
    if grouped:
        assert f"\n{cli.SHARED_TITLE}:\n" in out
        listed = out.split(f"\n{cli.SHARED_TITLE}:\n", 1)[1]
        for action in group._group_actions:
            if action.help is not argparse.SUPPRESS:
                assert action.option_strings[0] in listed, (command, action.option_strings)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_usage_error_is_one_line_and_exit_2(command, capsys):
    main = main_of(command)
    with pytest.raises(SystemExit) as stopped:
        main(["--no-such-option-anywhere"])
    assert stopped.value.code == cli.EXIT_USER
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    # argparse names the missing required arguments first, else the unknown option
    assert len(err) == 1 and err[0].startswith("error: "), err


# --------------------------------------------------------------------------- the layer itself


def _run(raise_or_return, capsys):
    """Exit code and stderr of a ``cli.command`` whose body raises or returns ``raise_or_return``."""

    @cli.command
    def main(argv=None):
        if isinstance(raise_or_return, BaseException):
            raise raise_or_return
        return raise_or_return

    code = main([])
    return code, capsys.readouterr().err


@pytest.mark.parametrize("error, code", [
    (UserError("bad flag"), cli.EXIT_USER),
    (OutputDirError("not ours"), cli.EXIT_USER),
    (DataError("file.csv: row 3"), cli.EXIT_USER),
    (FileNotFoundError(2, "No such file or directory", "/nowhere/x.csv"), cli.EXIT_USER),
    (MethodError("generate raised"), cli.EXIT_METHOD),
    (CheckFailed("2 assets corrupted"), cli.EXIT_CHECK_FAILED),
])
def test_each_error_branch_has_its_exit_code_and_one_line(error, code, capsys):
    got, err = _run(error, capsys)
    lines = [line for line in err.splitlines() if line.strip()]
    assert got == code and len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in err
    assert cli.exit_code_of(error) == code


def test_os_error_line_names_the_path_and_the_reason(capsys):
    _, err = _run(FileNotFoundError(2, "No such file or directory", "/nowhere/x.csv"), capsys)
    assert err.strip() == "error: /nowhere/x.csv: No such file or directory"


def test_a_method_error_says_the_method_misbehaved(capsys):
    _, err = _run(MethodError("generate raised ZeroDivisionError"), capsys)
    assert err.strip() == "error: the method misbehaved, nothing written: generate raised ZeroDivisionError"


@pytest.mark.parametrize("bug", [ValueError("plain"), KeyError("k"), TypeError("t"), RuntimeError("r"),
                                 ZeroDivisionError()])
def test_an_internal_bug_prints_the_traceback_and_the_report_line(bug, capsys):
    code, err = _run(bug, capsys)
    assert code == cli.EXIT_BUG == 1
    assert err.startswith("Traceback (most recent call last):") and type(bug).__name__ in err
    assert err.rstrip().splitlines()[-1] == cli.BUG_LINE


def test_keyboard_interrupt_is_130_with_a_resume_hint(capsys):
    code, err = _run(KeyboardInterrupt(), capsys)
    assert code == cli.EXIT_INTERRUPTED == 130
    assert "Traceback" not in err and "rerun the same command" in err


@pytest.mark.parametrize("returned, code", [(None, 0), (0, 0), (cli.EXIT_PARTIAL, 5), (cli.EXIT_CHECK_FAILED, 4)])
def test_the_returned_code_is_the_exit_code(returned, code, capsys):
    assert _run(returned, capsys)[0] == code


def test_system_exit_passes_through(capsys):
    @cli.command
    def main(argv=None):
        raise SystemExit(7)

    with pytest.raises(SystemExit) as stopped:
        main([])
    assert stopped.value.code == 7


def test_the_exit_codes_are_distinct():
    codes = [cli.EXIT_OK, cli.EXIT_BUG, cli.EXIT_USER, cli.EXIT_METHOD, cli.EXIT_CHECK_FAILED, cli.EXIT_PARTIAL,
             cli.EXIT_INTERRUPTED]
    assert codes == [0, 1, 2, 3, 4, 5, 130]


def test_usage_error_is_one_line_exit_2(capsys):
    p = cli.parser("tool", "A tool.\n\nMore text that is not the description.")
    p.add_argument("--n", type=int, required=True)
    with pytest.raises(SystemExit) as stopped:
        p.parse_args(["--n", "many"])
    assert stopped.value.code == cli.EXIT_USER
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "--n" in err[0] and "many" in err[0]
    assert p.prog == "python -m tool" and p.description == "A tool."


# --------------------------------------------------------------------------- shared options


def _parse(argv, **budget_kwargs):
    p = cli.parser("tool")
    cli.add_budget_options(p, **budget_kwargs)
    return p.parse_args(argv)


@pytest.mark.parametrize("text, limits", [
    (None, (None, None)),
    ("", (None, None)),
    ("500", (500, None)),
    ("500steps", (500, None)),
    ("1step", (1, None)),
    ("steps=500", (500, None)),
    ("90s", (None, 90.0)),
    ("1.5s", (None, 1.5)),
    ("5m", (None, 300.0)),
    ("2min", (None, 120.0)),
    ("1h", (None, 3600.0)),
    ("seconds=300", (None, 300.0)),
    ("steps=500,seconds=300", (500, 300.0)),
    ("300s, 20", (20, 300.0)),
])
def test_budget_text(text, limits):
    assert cli.parse_budget_text(text) == limits


@pytest.mark.parametrize("text", ["abc", "5x", "steps=", "-3", "1.5"])
def test_budget_text_that_does_not_parse_is_a_user_error(text):
    with pytest.raises(UserError, match="--budget"):
        cli.parse_budget_text(text)


def test_budget_flags():
    assert cli.budget_limits(_parse([])) == (None, None)
    assert cli.budget_limits(_parse(["--budget", "500"])) == (500, None)
    assert cli.budget_limits(_parse(["--budget", "5m"])) == (None, 300.0)
    # explicit --max-steps / --max-seconds win over the --budget text
    assert cli.budget_limits(_parse(["--budget", "steps=500,seconds=60", "--max-steps", "7"])) == (7, 60.0)
    assert cli.budget_limits(_parse(["--budget", "500", "--max-seconds", "2.5"])) == (500, 2.5)
    assert cli.budget_limits(_parse([], default_steps=300)) == (300, None)


@pytest.mark.parametrize("argv", [["--max-steps", "0"], ["--max-seconds", "0"], ["--max-seconds", "-1"],
                                  ["--budget", "0"]])
def test_a_budget_that_is_not_positive_is_a_user_error(argv):
    with pytest.raises(UserError, match="expected a number > 0"):
        cli.budget_limits(_parse(argv))


def test_the_old_steps_spelling_is_gone(capsys):
    # --max-steps is the one spelling: the hidden --steps alias was retired
    with pytest.raises(SystemExit) as info:
        _parse(["--steps", "12"], default_steps=300)
    assert info.value.code == 2 and "--steps" in capsys.readouterr().err
    with pytest.raises(TypeError, match="aliases"):
        _parse([], default_steps=300, aliases=("--steps",))


def test_budget_text_wins_over_the_default_step_count():
    assert cli.budget_limits(_parse(["--budget", "500"], default_steps=300)) == (500, None)
    assert cli.budget_limits(_parse([], default_steps=300)) == (300, None)
    assert cli.budget_limits(_parse(["--budget", "5m"], default_steps=300)) == (None, 300.0)  # a time limit alone


def test_config_entries():
    assert cli.parse_config([]) == {}
    assert cli.parse_config(["steps=3", "name=said", 'nested={"a": [1, 2]}', "flag=true", "empty="],
                            preset="paper") == {"steps": 3, "name": "said", "nested": {"a": [1, 2]}, "flag": True,
                                                "empty": "", "preset": "paper"}
    assert cli.parse_config(["text=a=b"]) == {"text": "a=b"}  # only the first '=' separates


@pytest.mark.parametrize("pair", ["novalue", "=3"])
def test_a_config_entry_without_key_and_value_is_a_user_error(pair):
    with pytest.raises(UserError, match="--config: expected KEY=VALUE"):
        cli.parse_config([pair])


def test_config_and_preset_options():
    p = cli.parser("tool")
    cli.add_config_options(p, preset_default="cpu-demo")
    args = p.parse_args(["--config", "a=1", "--config", "b=two"])
    assert cli.parse_config(args.config, preset=args.preset) == {"a": 1, "b": "two", "preset": "cpu-demo"}
    assert p.parse_args([]).config == []


def test_data_results_device_and_quiet_options():
    p = cli.parser("tool")
    cli.add_data_option(p, required=True)
    cli.add_results_option(p, default="here")
    cli.add_device_option(p, default="cpu")
    cli.add_quiet_option(p)
    args = p.parse_args(["--data", "d"])
    assert (args.data, args.results, args.device, args.quiet) == ("d", "here", "cpu", False)
    group = _shared_group(p)
    assert [a.option_strings[0] for a in group._group_actions] == ["--data", "--results", "--device", "--quiet"]
    assert _shared_group(p) is cli.shared_options(p)  # one group per parser
    buffer = io.StringIO()
    p.print_help(buffer)
    assert "\nshared options:\n  --data DIR" in buffer.getvalue()


def test_the_layer_keeps_tracebacks_off_for_user_errors_even_when_chained(capsys):
    try:
        try:
            raise ValueError("inner")
        except ValueError as inner:
            raise DataError("outer names the file") from inner
    except DataError as error:
        chained = error
    _, err = _run(chained, capsys)
    assert err.strip() == "error: outer names the file"


def test_cli_module_imports_no_tool():
    # blendvoca.cli is imported by every tool: it must stay a leaf (errors and the progress switch it sets only).
    tree = ast.parse(Path(cli.__file__).read_text(encoding="utf-8"))
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.module}
    assert {m for m in imported if m.split(".")[0] in PACKAGES} == {"blendvoca.errors", "blendvoca.runtime.progress"}
    assert "blendvoca.cli" in sys.modules


def test_quiet_sets_the_progress_switch_for_its_command_only():
    from blendvoca.runtime.progress import show_progress

    seen = []

    @cli.command
    def tool(argv=None):
        p = cli.parser("tool")
        cli.add_quiet_option(p)
        p.parse_args(argv)
        seen.append(show_progress())

    assert tool(["--quiet"]) == cli.EXIT_OK and tool([]) == cli.EXIT_OK
    assert seen == [False, True]
    assert show_progress()  # the caller's switch is its own
