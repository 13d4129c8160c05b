"""The ``asmplan`` command line: one entry point, one module per subcommand.

Exit codes: 0 success, 1 a planning/physics/check result that failed (with its reason), 2 bad
input (every problem listed, no traceback), 3 an internal error (a bug: please report it),
130 interrupted (Ctrl-C, at any moment), 141 standard output closed before the command
finished (``asmplan ... | head``; quiet, like a program ended by SIGPIPE).
"""

from __future__ import annotations

import argparse
import importlib
import os
import signal
import sys
from collections.abc import Sequence

from .fileio import OutputPathError
from .knowledge.errors import ProductError

# subcommand name -> module in asmplan.commands defining `register(subparsers)`; the parser
# each registers carries `func(args) -> int` as its default.
COMMANDS = ("run", "validate", "graph", "check", "sequence", "plan", "simulate", "sweep", "bench", "import")
# subcommands whose module is not named like them ("import" is a Python keyword)
_MODULES = {"import": "cad_import"}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="asmplan",
        description="Plan robot assembly of a product described in YAML and prove each step in "
                    "a headless physics simulation.")
    parser.add_argument("--debug", action="store_true",
                        help="show Python tracebacks for internal errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMANDS:
        importlib.import_module(f"asmplan.commands.{_MODULES.get(name, name)}").register(sub)
    return parser


EXIT_INTERRUPTED = 130
EXIT_CLOSED_PIPE = 141


class _Interrupts:
    """SIGINT in this process raises KeyboardInterrupt and is remembered; in a process forked
    from it (a simulator worker, which inherits the handler) it is ignored: the main process
    stops its workers itself, so a worker never dies half-started and breaks the pool."""

    def __init__(self) -> None:
        self.pid = os.getpid()
        self.seen = False

    def __call__(self, signum: int, frame: object) -> None:
        if os.getpid() != self.pid:
            return
        self.seen = True
        raise KeyboardInterrupt

    def install(self) -> None:
        self.pid = os.getpid()
        signal.signal(signal.SIGINT, self)


INTERRUPTS = _Interrupts()


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit code (the console script exits with it)."""
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse already printed usage; bad usage is bad input
        return 2 if exc.code not in (0, None) else 0
    except KeyboardInterrupt:
        print("asmplan: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    try:
        code = int(args.func(args))
    except ProductError as exc:
        for issue in exc.issues:
            print(issue, file=sys.stderr)
        n = len(exc.issues)
        print(f"asmplan: {n} error{'s' if n != 1 else ''} in the input; nothing was planned.",
              file=sys.stderr)
        code = 2
    except OutputPathError as exc:
        print(f"asmplan: output {exc.path}: {exc.reason}. Nothing was written.", file=sys.stderr)
        code = 2
    except KeyboardInterrupt:
        print("asmplan: interrupted", file=sys.stderr)
        code = EXIT_INTERRUPTED
    except BrokenPipeError:
        code = _closed_pipe()
    except Exception as exc:
        if INTERRUPTS.seen:  # e.g. a worker pool broken by the same Ctrl-C
            print("asmplan: interrupted", file=sys.stderr)
            return EXIT_INTERRUPTED
        if getattr(args, "debug", False):
            raise
        print(f"asmplan: internal error: {type(exc).__name__}: {exc} "
              "(run with --debug for the traceback, and please report it)", file=sys.stderr)
        code = 3
    return code


def entry() -> None:
    """Console-script entry point.

    Leaves through ``os._exit`` after flushing, so that the nanobind "leaked instances"
    report printed by OMPL's bindings at interpreter shutdown never reaches the user's
    terminal (field notes); every file we write is closed and replaced atomically before.
    """
    try:
        INTERRUPTS.install()
        code = main()
        sys.stdout.flush()
    except KeyboardInterrupt:
        code = EXIT_INTERRUPTED
        with _quiet():
            print("asmplan: interrupted", file=sys.stderr)
    except BrokenPipeError:
        code = _closed_pipe()
    with _quiet():
        sys.stderr.flush()
    os._exit(code)


def _closed_pipe() -> int:
    """Standard output was closed by its reader: stop quietly (no message, no traceback)."""
    with _quiet():
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    return EXIT_CLOSED_PIPE


def _quiet():
    import contextlib

    return contextlib.suppress(OSError, ValueError, KeyboardInterrupt)
