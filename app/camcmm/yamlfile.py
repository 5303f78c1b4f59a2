"""The one YAML loader of camcmm: PyYAML's safe loader with limits.

Every YAML document the app reads — manifests, plans, budgets, scenes, sequences, text
typed or uploaded in the GUI — goes through :func:`load_yaml` (text or bytes) or
:func:`read_yaml` (a file). On top of ``yaml.SafeLoader`` they refuse, each with a
one-line :class:`YamlError` (an :class:`~camcmm.errors.InputError`) naming the file and
line:

- input larger than ``max_bytes`` (10 MiB by default), before it is read;
- text that is not UTF-8 (or UTF-16/32 with a byte-order mark);
- syntax errors, several documents, unknown tags (``!!python/...``);
- a mapping that repeats a key (``mpe:`` twice would silently replace the limits);
- anchors and aliases that expand to more than ``max_alias_nodes`` extra nodes, or that
  refer to themselves. PyYAML composes an alias as the *same* node object, so the
  "billion laughs" is cheap to parse and to construct (shared lists) — the blow-up comes
  later, in whatever walks the result (JSON, hashing, deepcopy, a GUI table). The tree
  size the document would have with every alias copied out is therefore counted on the
  composed node graph, once per distinct node, before anything is constructed;
- nesting deeper than ``max_depth`` levels (callers walk results recursively).

Why not a library: ruamel.yaml refuses duplicate keys but has no expansion limit, and
PyYAML (already a dependency) exposes the composed graph, which is all the checks need.
"""

from __future__ import annotations

import codecs
from pathlib import Path
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from .errors import InputError

#: Default input limit [bytes].
MAX_BYTES = 10 * 1024 * 1024
#: Default limit on the nodes that aliases add when expanded (a node reached through k
#: aliases counts k times). 1e5 nodes is a few MB of JSON: the same order as the file cap.
MAX_ALIAS_NODES = 100_000
#: Default nesting limit [levels].
MAX_DEPTH = 100

_MERGE = "tag:yaml.org,2002:merge"
# libyaml parses ~10x faster; the checks below work on the composed graph either way.
_Loader = getattr(yaml, "CSafeLoader", None) or yaml.SafeLoader


class YamlError(InputError):
    """A YAML document refused: one line naming the file (and line) at fault."""


def read_yaml(
    path: str | Path,
    *,
    name: str | None = None,
    max_bytes: int = MAX_BYTES,
    max_alias_nodes: int = MAX_ALIAS_NODES,
    max_depth: int = MAX_DEPTH,
) -> Any:
    """Load the one YAML (or JSON) document in file ``path``; see :func:`load_yaml`.

    The size is checked before reading, and a file that cannot be read is a YamlError
    too. ``name`` is the file's name in messages (default: ``path`` as given).
    """
    p = Path(path)
    name = str(path) if name is None else name
    try:
        with p.open("rb") as fh:
            data = fh.read(max_bytes + 1)  # one byte over tells "too large" without reading it all
    except OSError as exc:
        raise YamlError(f"{name}: cannot read the file ({exc.strerror or exc})") from None
    return load_yaml(data, name=name, max_bytes=max_bytes, max_alias_nodes=max_alias_nodes, max_depth=max_depth)


def load_yaml(
    text: str | bytes,
    *,
    name: str = "YAML text",
    max_bytes: int = MAX_BYTES,
    max_alias_nodes: int = MAX_ALIAS_NODES,
    max_depth: int = MAX_DEPTH,
) -> Any:
    """Load one YAML (or JSON) document from ``text`` with the limits of this module.

    Returns what ``yaml.safe_load`` would (``None`` for an empty document); raises
    :class:`YamlError` with one line starting with ``name`` otherwise.
    """
    size = (
        len(text)
        if isinstance(text, (bytes, bytearray))
        else (len(text) if len(text) > max_bytes else len(text.encode("utf-8", "surrogatepass")))
    )
    if size > max_bytes:
        raise YamlError(f"{name}: larger than the {_mib(max_bytes)} a YAML file may have")
    if isinstance(text, (bytes, bytearray)):
        text = _decode(bytes(text), name)
    loader = _Loader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check(loader, node, name, max_alias_nodes, max_depth)
        return loader.construct_document(node)
    except yaml.MarkedYAMLError as exc:
        what = " ".join(str(x) for x in (exc.context, exc.problem) if x)
        raise YamlError(f"{name}: not valid YAML{_where(exc.problem_mark)}: {_short(what)}") from None
    except yaml.reader.ReaderError as exc:  # a control character; position counts characters
        line = text.count("\n", 0, exc.position) + 1
        raise YamlError(f"{name}: not valid YAML at line {line}: character {exc.character!r} is not allowed") from None
    except yaml.YAMLError as exc:
        raise YamlError(f"{name}: not valid YAML: {_short(str(exc))}") from None
    except RecursionError:  # the pure-Python composer recurses per level
        raise YamlError(f"{name}: nested deeper than {max_depth} levels") from None
    except (ValueError, OverflowError) as exc:  # e.g. an int of more digits than Python converts
        raise YamlError(f"{name}: a value cannot be read ({_short(str(exc))})") from None
    finally:
        loader.dispose()


def _decode(data: bytes, name: str) -> str:
    # YAML 1.1 allows UTF-16/32 with a BOM; anything else must be UTF-8.
    for bom, codec in (
        (codecs.BOM_UTF32_LE, "utf-32"),
        (codecs.BOM_UTF32_BE, "utf-32"),
        (codecs.BOM_UTF16_LE, "utf-16"),
        (codecs.BOM_UTF16_BE, "utf-16"),
    ):
        if data.startswith(bom):
            try:
                return data.decode(codec)
            except UnicodeDecodeError:
                raise YamlError(f"{name}: not valid {codec.upper()} text") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise YamlError(f"{name}: not UTF-8 text (byte 0x{data[exc.start]:02x} at line {line})") from None


def _check(loader: Any, root: Node, name: str, max_alias_nodes: int, max_depth: int) -> None:
    """Refuse duplicate keys, self-referring aliases, deep nesting and alias expansion
    beyond the limit, walking each distinct node once (iteratively: no recursion)."""
    expanded: dict[int, int] = {}  # id(node) -> nodes in its subtree with aliases copied out
    distinct = 0
    on_path: set[int] = set()
    stack: list[tuple[Node, bool]] = [(root, False)]
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            on_path.discard(key)
            expanded[key] = 1 + sum(expanded[id(c)] for c in _children(node))
            if expanded[key] - distinct > max_alias_nodes:
                raise YamlError(
                    f"{name}: anchors and aliases{_where(node.start_mark)} expand to more than "
                    f"{max_alias_nodes} extra nodes; write the values out or use fewer aliases"
                )
            continue
        if key in expanded:
            continue
        if key in on_path:
            raise YamlError(f"{name}: an alias{_where(node.start_mark)} refers to the node that contains it")
        if len(on_path) >= max_depth:
            raise YamlError(f"{name}: nested deeper than {max_depth} levels{_where(node.start_mark)}")
        distinct += 1
        if isinstance(node, MappingNode):
            _no_duplicate_keys(loader, node, name)
        on_path.add(key)
        stack.append((node, True))
        for child in _children(node):
            if id(child) in on_path:
                raise YamlError(f"{name}: an alias{_where(child.start_mark)} refers to a node that contains it")
            if id(child) not in expanded:
                stack.append((child, False))


def _children(node: Node) -> list[Node]:
    if isinstance(node, SequenceNode):
        return node.value
    if isinstance(node, MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def _no_duplicate_keys(loader: Any, node: MappingNode, name: str) -> None:
    # Checked on the composed node, before SafeConstructor flattens merge keys ('<<'), so
    # a key that overrides a merged one stays allowed, as YAML says. Keys compare as the
    # values they become (``1``/``1.0``, ``yes``/``true`` collide in a dict too); the
    # constructor caches them, so nothing is built twice.
    seen: dict[Any, Any] = {}
    for key_node, _ in node.value:
        if not isinstance(key_node, ScalarNode) or key_node.tag == _MERGE:
            continue
        k = loader.construct_object(key_node)
        if k in seen:
            raise YamlError(
                f"{name}: duplicate key {key_node.value!r}{_where(key_node.start_mark)} "
                f"(first{_where(seen[k])}); each key may appear once"
            )
        seen[k] = key_node.start_mark


def _where(mark: Any) -> str:
    return f" at line {mark.line + 1}" if mark is not None else ""


def _short(text: Any, n: int = 120) -> str:
    s = " ".join(str(text or "").split())
    return s if len(s) <= n else s[: n - 1] + "…"


def _mib(n: int) -> str:
    return f"{n / 2**20:g} MiB" if n >= 2**20 else f"{n} bytes"
