"""Safe YAML for batch specs and character files: plain data plus the line of every key,
within budgets.

PyYAML's ``SafeLoader`` (no Python objects), and on top of it what a hostile file could
otherwise turn into minutes and gigabytes or a traceback: at most ``max_aliases`` aliases
and ``max_nodes`` values once aliases are expanded (no "billion laughs"), nesting up to
``max_depth`` (no ``RecursionError``), integers up to ``max_int`` (no 4300-digit
``ValueError``, no ``OverflowError`` later), no NaN or infinity, and every scalar a tag
cannot construct (``!!int 1.0``, ``!!timestamp x``, ``!!foo``) reported at its line.
Every problem is one :class:`~mimika.errors.DataError` (or the subclass the caller names)
with ``file:line``.
"""

from __future__ import annotations

from typing import Any

from mimika import limits
from mimika.errors import DataError
from mimika.io.hints import yaml_hint

Path_ = tuple[str | int, ...]
_INT_TAG = "tag:yaml.org,2002:int"


class _Refused(Exception):
    """A budget ran out while composing (carries the message and the mark)."""

    def __init__(self, message: str, mark: Any):
        super().__init__(message)
        self.mark = mark


def _loader_class(yaml: Any, lim: limits.Limits) -> type:
    class Loader(yaml.SafeLoader):
        aliases = 0
        depth = 0

        def compose_node(self, parent: Any, index: Any) -> Any:
            if self.check_event(yaml.AliasEvent):
                self.aliases += 1
                if self.aliases > lim.max_aliases:
                    raise _Refused(str(limits.over("max_aliases", "the spec uses more than "
                                                   f"{lim.max_aliases} aliases (*name)", lim)),
                                   self.peek_event().start_mark)
            self.depth += 1
            try:
                if self.depth > lim.max_depth:
                    raise _Refused(str(limits.over("max_depth", "the spec is nested more than "
                                                   f"{lim.max_depth} levels deep", lim)),
                                   self.peek_event().start_mark)
                return super().compose_node(parent, index)
            finally:
                self.depth -= 1

    return Loader


def _flow_too_deep(text: str, max_depth: int) -> int:
    """The line where ``[``/``{`` nesting (outside quotes and comments) passes ``max_depth``,
    else 0 — a linear pre-scan before the parser sees it."""
    depth, line, quote = 0, 1, ""
    prev = "\n"
    for ch in text:
        if quote:
            if ch == quote:
                quote = ""
            elif ch == "\n":
                line += 1
        elif ch in "[{":
            depth += 1
            if depth > max_depth:
                return line
        elif ch in "]}":
            depth = max(depth - 1, 0)
        elif ch in "'\"" and prev in " \t\n[{,:":
            quote = ch
        elif ch == "\n":
            line += 1
        prev = ch
    return 0


def where(path: Path_) -> str:
    """A key path as people write it: ``render.size[1]``."""
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else str(p))
    return out or "the document"


def _error(error: type[DataError], source: str, line: int | None, msg: str) -> DataError:
    return error(f"{source}:{line}: {msg}" if line else f"{source}: {msg}")


def read_yaml(text: str, source: str, *, error: type[DataError] = DataError,
              text_keys: bool = False) -> tuple[Any, dict[Path_, int]]:
    """Parse ``text`` into plain data and the 1-based line of every key path and list item.

    ``error`` is the exception class raised (a :class:`DataError`), always as
    ``source:line: message``; ``text_keys`` refuses keys that are not text (else integers
    are keys too).
    """
    try:
        import yaml
    except ImportError as e:
        raise error(f"reading {source} needs PyYAML ({e}); install it with: "
                    "pip install 'mimika[batch]'") from None
    lim = limits.current()
    try:
        limits.check_text(text, source)
    except limits.LimitError as e:
        raise error(f"{source}: {e}") from None
    deep_line = _flow_too_deep(text, lim.max_depth)
    if deep_line:  # PyYAML's scanner is quadratic in the depth of [ and { nesting
        raise _error(error, source, deep_line, str(limits.over(
            "max_depth", f"the file is nested more than {lim.max_depth} levels deep", lim)))
    lines: dict[Path_, int] = {}
    try:
        loader = _loader_class(yaml, lim)(text)
    except yaml.reader.ReaderError as e:  # control characters, checked up front
        line = text.count("\n", 0, max(e.position, 0)) + 1
        raise _error(error, source, line, f"invalid YAML: character #x{e.character:04x} is "
                                          "not allowed (control characters); remove it") from None
    try:
        try:
            root = loader.get_single_node()
        except _Refused as e:
            raise _error(error, source, e.mark.line + 1, str(e)) from None
        except yaml.YAMLError as e:
            mark = getattr(e, "problem_mark", None) or getattr(e, "context_mark", None)
            where = f"{source}:{mark.line + 1}:{mark.column + 1}" if mark else source
            problem = getattr(e, "problem", None) or str(e).splitlines()[0]
            hint = yaml_hint(e)
            raise error(f"{where}: invalid YAML: {problem}" + (f"; {hint}" if hint else "")
                        ) from None
        if root is None:
            return None, lines
        _check_expansion(yaml, root, source, lim, error)
        conv = _Converter(yaml, loader, source, lines, lim, error)
        conv.key_types = (str,) if text_keys else (str, int)
        return conv.conv(root, ()), lines
    finally:
        loader.dispose()


def _check_expansion(yaml: Any, root: Any, source: str, lim: limits.Limits,
                     error: type[DataError]) -> None:
    """Refuse a node graph that aliases expand past ``max_nodes`` values, or that contains
    itself — counted over the shared nodes, without expanding anything."""
    size: dict[int, int] = {}
    stack: list[tuple[Any, bool]] = [(root, False)]
    open_: set[int] = set()
    while stack:
        node, done = stack.pop()
        key = id(node)
        kids = ([v for kv in node.value for v in kv] if isinstance(node, yaml.MappingNode)
                else node.value if isinstance(node, yaml.SequenceNode) else [])
        if done:
            open_.discard(key)
            size[key] = 1 + sum(size[id(k)] for k in kids)
            if size[key] > lim.max_nodes:
                raise _error(error, source, node.start_mark.line + 1, str(limits.over(
                    "max_nodes", "the spec, with its aliases expanded, has over "
                                 f"{lim.max_nodes} values", lim)))
            continue
        if key in size:
            continue
        if key in open_:
            raise _error(error, source, node.start_mark.line + 1,
                         "an alias refers to the value that contains it (an endless loop)")
        open_.add(key)
        stack.append((node, True))
        stack.extend((k, False) for k in kids if id(k) not in size)


class _Converter:
    """Nodes → plain data, counting values (aliases expand) and checking every scalar."""

    def __init__(self, yaml: Any, loader: Any, source: str, lines: dict[Path_, int],
                 lim: limits.Limits, error: type[DataError]):
        self.yaml, self.loader, self.source, self.lines = yaml, loader, source, lines
        self.lim, self.error, self.nodes = lim, error, 0
        self.key_types: tuple[type, ...] = (str, int)

    def fail(self, node: Any, path: Path_, msg: str) -> DataError:
        return _error(self.error, self.source, node.start_mark.line + 1,
                      f"{where(path)}: {msg}" if path else msg)

    def scalar(self, node: Any, path: Path_) -> Any:
        value = node.value if isinstance(node.value, str) else ""
        digits = len(str(self.lim.max_int))
        if node.tag == _INT_TAG and len(value.lstrip("+-").replace("_", "")) > digits:
            raise self.fail(node, path, f"a {len(value)}-digit integer is beyond the largest "
                                        f"accepted, {self.lim.max_int} (max_int)")
        try:
            v = self.loader.construct_object(node, deep=True)
        except (self.yaml.YAMLError, ValueError, TypeError, IndexError, AttributeError,
                OverflowError, KeyError) as e:
            tag = node.tag.replace("tag:yaml.org,2002:", "!!")
            why = getattr(e, "problem", None) or "not a valid value for this tag"
            raise self.fail(node, path, f"cannot read {value[:40]!r} as {tag}: {why}; fix the "
                                        "value or remove the tag") from None
        problems = limits.check_json_tree(v, lim=self.lim)
        if problems:
            raise self.fail(node, path, problems[0].split(": ", 1)[-1])
        return v

    def conv(self, node: Any, path: Path_) -> Any:
        yaml = self.yaml
        self.nodes += 1
        if self.nodes > self.lim.max_nodes:
            raise self.fail(node, path, str(limits.over(
                "max_nodes", f"the file (with its aliases expanded) has over "
                             f"{self.lim.max_nodes} values", self.lim)))
        if len(path) > self.lim.max_depth:  # an alias inside itself nests forever
            raise self.fail(node, path[:3], str(limits.over(
                "max_depth", "the file (with its aliases expanded) is nested more than "
                             f"{self.lim.max_depth} levels deep", self.lim)))
        self.lines.setdefault(path, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            out: dict[Any, Any] = {}
            for k, v in node.value:
                key = self.scalar(k, path) if isinstance(k, yaml.ScalarNode) else None
                if not isinstance(key, self.key_types) or isinstance(key, bool):
                    raise self.fail(k, path, f"keys must be text, not {key!r}")
                if key in out:
                    raise self.fail(k, (*path, key), "is given twice")
                self.lines[(*path, key)] = k.start_mark.line + 1
                out[key] = self.conv(v, (*path, key))
            return out
        if isinstance(node, yaml.SequenceNode):
            return [self.conv(v, (*path, i)) for i, v in enumerate(node.value)]
        return self.scalar(node, path)
