"""The ``camcmm`` command line.

Core commands (serve, plugins, info, run, demo) live in :mod:`camcmm.cli.core`;
plugin packages contribute more (``camcmm fit`` ...) through the ``commands`` list of
their manifest. Every command returns a JSON-able dict: with ``--json`` exactly one
JSON document goes to stdout, otherwise a human-readable text. Errors go to stderr as
one line and the exit code is non-zero (2 for bad input, 1 for anything else).

Exit code 3: the command ran and printed its document, but what it was asked for failed
in a way the document records (``camcmm inspect`` whose alignment failed: its JSON says
``aligned: false`` and ``failure``). A script must not read that document as a result;
the one-line reason goes to stderr. A command module says so with ``failure(result)``,
which returns that reason or None.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
from collections.abc import Callable
from typing import Any

from .. import __version__
from ..errors import CamcmmError
from ..host import default_host
from ..jsonable import to_jsonable
from . import core
from .parser import Parser


def build_parser() -> tuple[argparse.ArgumentParser, dict[str, Any]]:
    parser = Parser(prog="camcmm", description="Camera-based close-range coordinate metrology workbench.")
    parser.add_argument("--version", action="version", version=f"camcmm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    # name -> (run, text) for core commands, the CommandSpec for contributed ones
    handlers: dict[str, Any] = {}
    for name, (summary, configure, run, text) in core.COMMANDS.items():
        p = sub.add_parser(name, help=summary, description=summary)
        configure(p)
        handlers[name] = (run, text)
    # Contributed commands: read from manifests; the module is imported only when the
    # command is used, so `camcmm --help` stays fast and a broken plugin breaks only itself.
    for name, spec in sorted(default_host().commands.items()):
        if name in handlers:
            continue
        sub.add_parser(name, help=spec.summary, description=spec.summary, add_help=False)
        handlers[name] = spec
    return parser, handlers


def _print(result: Any, as_json: bool, text: Callable | None) -> None:
    if as_json:
        json.dump(to_jsonable(result), sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    elif text is not None:
        print(text(result))
    else:
        print(json.dumps(to_jsonable(result), indent=2, allow_nan=False))


FAILED = 3  # ran, printed, but the result is a failure (see the module docstring)


def _contributed(name: str, spec, argv: list[str]) -> tuple[Any, bool, Callable | None, Callable | None]:
    try:
        module = importlib.import_module(spec.entry)
    except Exception as exc:
        raise CamcmmError(
            f"command {name!r} from {spec.distribution} cannot be loaded: {type(exc).__name__}: {exc}"
        ) from exc
    p = Parser(prog=f"camcmm {name}", description=spec.summary)
    module.configure(p)
    p.add_argument("--json", action="store_true", help="print one JSON document on stdout")
    args = p.parse_args(argv)
    return module.run(args), args.json, getattr(module, "text", None), getattr(module, "failure", None)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        parser, handlers = build_parser()
        # A contributed command parses its own arguments (its parser is built lazily).
        first = next((a for a in argv if not a.startswith("-")), None)
        if first in handlers and not isinstance(handlers[first], tuple):
            i = argv.index(first)
            result, as_json, text, failure = _contributed(first, handlers[first], argv[i + 1 :])
        else:
            failure = None
            args = parser.parse_args(argv)
            if not args.command:
                parser.print_help()
                return 0
            run, text = handlers[args.command]
            result = run(args)
            as_json = getattr(args, "json", False)
        if result is not None:
            _print(result, as_json, text)
        reason = failure(result) if failure is not None and result is not None else None
        if reason:
            print(f"camcmm: {reason}", file=sys.stderr)
            return FAILED
        return 0
    except CamcmmError as exc:
        print(f"camcmm: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("camcmm: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 1
    except MemoryError as exc:  # an estimate let it through: still one line, naming the allocation
        what = " ".join(str(exc).split()) or "an allocation failed"
        print(f"camcmm: error: out of memory: {what}; use smaller sizes or counts", file=sys.stderr)
        return 2
    except Exception as exc:  # a bug: still one line for the user, the exit code says so
        print(f"camcmm: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return 1


if __name__ == "__main__":
    raise SystemExit(main())
