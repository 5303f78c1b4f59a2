"""A command's options from a plugin's declared parameters, as ``camcmm run ID`` has them.

The one builder is :func:`camcmm.params.add_cli_options`: from a parameter's declaration
(manifest: type, unit, limits, choices, default, help) it makes ``--name VALUE`` with that
help. The commands plugins contribute (``camcmm inspect``, ``fit``, ``fuse csi``...) had
their flags before the parameters were declared; each flag is named as its parameter and
keeps its shape: :func:`add_declared_options` passes the builder's options through

* ``switches``: a bool given as a flag without a value (``--extract``: true);
* ``negations``: a switch's opposite, sharing its value (``--sparse-only``: dense false);
* ``spread``: a vector given as separate numbers (``--region XMIN ... ZMAX``);
* ``prefix``: another flag prefix (``camcmm run``'s ``--param-out`` for a parameter whose
  name is one of ``run``'s own options).

Values stay text until :func:`declared_values` checks them by the same declaration the
host validates with (CLI, JSON and GUI share one set of rules), naming the option:
``--tolerance: parameter 'tolerance' = 0.0 must be above 0 mm``.
"""

from __future__ import annotations

import argparse
from collections.abc import Collection, Iterable, Mapping, Sequence
from typing import Any

from ..errors import ParameterError
from ..params import Param, add_cli_options, cli_flag

#: Where add_cli_options puts a parameter's value in the namespace (``param__NAME``).
_DEST = "param__"


class _Shaped:
    """An argparse parser (or group) that gives the builder's options their command's shape."""

    def __init__(
        self,
        parser: Any,
        switches: Collection[str],
        negations: Mapping[str, tuple[str, str]],
        spread: Mapping[str, Sequence[str]],
        prefix: str,
    ):
        self.parser = parser
        self.switches, self.negations, self.spread = switches, negations, spread
        self.prefix = prefix

    def add_argument(self, flag: str, **kw: Any) -> Any:
        name = kw["dest"][len(_DEST) :]
        flag = self.prefix + flag[2:]
        if name in self.negations:  # the two flags of one value: not both at once
            group = self.parser.add_mutually_exclusive_group()
            kw.pop("metavar", None)
            action = group.add_argument(flag, action="store_const", const="true", **kw)
            off, text = self.negations[name]
            group.add_argument(off, dest=kw["dest"], action="store_const", const="false", help=text)
            return action
        if name in self.switches:
            kw.pop("metavar", None)
            kw.update(action="store_const", const="true")
        elif name in self.spread:
            kw.update(nargs=len(self.spread[name]), metavar=tuple(self.spread[name]))
        return self.parser.add_argument(flag, **kw)


def add_declared_options(
    parser: argparse.ArgumentParser | Any,
    params: Iterable[Param],
    *,
    switches: Collection[str] = (),
    negations: Mapping[str, tuple[str, str]] | None = None,
    spread: Mapping[str, Sequence[str]] | None = None,
    prefix: str = "--",
) -> None:
    """Add one option per declared parameter to ``parser`` (an argparse parser or group).

    ``switches``: bool names given without a value (``--extract``); ``negations``: bool
    name -> (flag, help) of the flag that sets it false; ``spread``: vector name -> the
    metavars of its numbers (their count is the number of values the option takes);
    ``prefix``: the flag's start instead of ``--``. A parameter not given stays None in the namespace: the host
    then uses its declared default.
    """
    shaped = _Shaped(parser, switches, negations or {}, spread or {}, prefix)
    add_cli_options(shaped, list(params))  # type: ignore[arg-type]  # duck-typed: only add_argument is used


def _number(text: Any) -> Any:
    """A float's text as the float (so that a refusal shows ``nan``, not ``'nan'``)."""
    if isinstance(text, str):
        try:
            return float(text)
        except ValueError:
            return text
    return text


def check_value(param: Param, value: Any, flag: str | None = None) -> Any:
    """``value`` (CLI text) coerced and checked by ``param``; a refusal names the option."""
    if param.type == "float":
        value = _number(value)
    elif param.type == "vector" and isinstance(value, list):
        value = [_number(v) for v in value]
    try:
        return param.coerce(value)
    except ParameterError as exc:
        raise ParameterError(f"{flag or cli_flag(param.name)}: {exc}") from None


def declared_values(args: argparse.Namespace, params: Iterable[Param], plugin: Any = None) -> dict[str, Any]:
    """The values given for ``params`` on the command line (not the defaults), each
    coerced and checked by its declaration; a refusal is one line naming the option and
    the value (ParameterError).

    ``plugin`` (a plugin spec, for options offered for several plugins, such as
    ``camcmm fit``'s for every element): a value is checked by that plugin's own
    declaration; one for a parameter it does not declare is refused
    (``--method: fit.line has no method``), unless it is the offered declaration's
    default, which is what the plugin does anyway (``--method ls`` for a line).
    """
    own = {p.name: p for p in plugin.parameters} if plugin is not None else None
    out: dict[str, Any] = {}
    for p in params:
        value = getattr(args, _DEST + p.name, None)
        if value is None:
            continue
        flag = cli_flag(p.name)
        if own is None:
            out[p.name] = check_value(p, value, flag)
            continue
        if p.name in own:
            out[p.name] = check_value(own[p.name], value, flag)
            continue
        if check_value(p, value, flag) == p.default:
            continue
        takes = ", ".join(cli_flag(q.name) for q in plugin.parameters) or "no options"
        raise ParameterError(f"{flag}: {plugin.id} has no {p.name.replace('_', ' ')} (it takes {takes})")
    return out
