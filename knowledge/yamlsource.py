"""Read YAML into plain Python values while keeping the line and column of every value.

libyaml (PyYAML's C parser, ``yaml.CSafeLoader``) turns the text into events that carry
their marks; :class:`_Composer` builds dicts, lists and scalars from them without recursion
and keeps a map from key path (a tuple of keys and indices) to the 1-based line and column
of the value there (and of its key, for mapping entries).

The reader refuses, with file:line:column and key path, what would otherwise exhaust time,
memory or the stack, or reach the schema as something it cannot compare (limits in
``docs/product-format.md``, "Limits"):

* nesting deeper than :data:`MAX_DEPTH`;
* aliases (``*name``) that repeat more than :data:`MAX_ALIAS_VALUES` values in all (an
  "alias bomb" of nine aliases per level, seven levels deep, is 4.8 million values from 520
  bytes), and an alias inside the node it names (``loop: &L [1, *L]``);
* files larger than :data:`MAX_FILE_BYTES`;
* control characters, explicit tags whose text is not of their type (``!!float abc``,
  ``!!int ""``, ``!!bool maybe``), tags other than the plain YAML types, integers a float
  cannot hold, more than one document.

Plain scalars written as YAML 1.2 numbers with an exponent and no dot (``1e-3``, ``2E6``),
which YAML 1.1 reads as text, are read as numbers. Merge keys (``<<: *defaults``) are
supported; the values they bring in keep the position where they are written.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
import yaml.constructor
import yaml.resolver

from .errors import InputIssue, ProductError

PathKey = tuple[str | int, ...]

MAX_DEPTH = 64
"""Deepest nesting of lists and mappings (a product needs about 8)."""
MAX_ALIAS_VALUES = 100_000
"""Values that aliases may repeat in one document, counted once per alias use."""
MAX_FILE_BYTES = 64 * 2**20
"""Largest product file read (64 MiB; 2,000 parts are about 1 MB)."""
MAX_ISSUES = 200
"""Issues collected from one file before the reader stops looking."""

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)  # libyaml: ~10x faster, same marks
_RESOLVER = yaml.resolver.Resolver()
_CONSTRUCTOR = yaml.constructor.SafeConstructor()
_TAG = "tag:yaml.org,2002:"
_COLLECTION_TAGS = {None, "!", _TAG + "map", _TAG + "seq"}
# YAML 1.2 floats that YAML 1.1 reads as text: an exponent without a dot (1e-3, -2E+6)
_FLOAT_12 = re.compile(r"[-+]?[0-9]+[eE][-+]?[0-9]+\Z")
# YAML 1.1 printable characters (tab, line feed, carriage return, and the printable ranges)
_NOT_PRINTABLE = re.compile("[^\x09\x0a\x0d\x20-\x7e\x85\xa0-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")
# decimal numbers read the same by YAML 1.1 and 1.2 (no leading zero: "010" is octal in 1.1);
# group 1 is set for a float
_DECIMAL = re.compile(r"[-+]?(?:0|[1-9][0-9]*)((?:\.[0-9]*)?(?:[eE][-+]?[0-9]+)?)\Z")
_SURROGATE = re.compile("[\ud800-\udfff]")
_MAX_INT_DIGITS = 400


def format_path(path: PathKey) -> str:
    """``("parts", 2, "size")`` -> ``"parts[2].size"``."""
    out = ""
    for key in path:
        if isinstance(key, int):
            out += f"[{key}]"
        else:
            out += f".{key}" if out else str(key)
    return out


@dataclass
class Located:
    """A parsed YAML document with positions.

    ``alias_of`` maps the path of a value brought in by an alias or a merge key to the path
    of the value it repeats, so that a position inside it is found where it is written.
    """

    file: str
    data: Any
    marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    key_marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    alias_of: dict[PathKey, PathKey] = field(default_factory=dict)

    def _written(self, path: PathKey) -> PathKey:
        """The path where the value at ``path`` is written (through aliases)."""
        p = tuple(path)
        for _ in range(MAX_DEPTH * 4):
            for k in range(len(p), 0, -1):
                target = self.alias_of.get(p[:k])
                if target is not None and (k < len(p) or p not in self.marks):
                    p = (*target, *p[k:])
                    break
            else:
                return p
        return p

    def where(self, path: PathKey, *, key: bool = False) -> tuple[int, int]:
        """Line and column of the value at ``path`` (or its key), else of the nearest parent."""
        table = self.key_marks if key else self.marks
        p = tuple(path)
        if p not in table and p not in self.marks and self.alias_of:
            p = self._written(p)
        while p:
            if p in table:
                return table[p]
            if p in self.marks:
                return self.marks[p]
            p = p[:-1]
        return self.marks.get((), (1, 1))

    def issue(self, path: PathKey, message: str, *, key: bool = False) -> InputIssue:
        line, col = self.where(path, key=key)
        return InputIssue(self.file, line, col, format_path(path), message)


class _Stop(Exception):
    """Composition cannot go on (a limit was reached); the issues say why."""


def _short(text: str, n: int = 40) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."


@dataclass
class _Frame:
    kind: str  # "map" or "seq"
    value: Any
    path: PathKey
    anchor: str | None
    start_count: int
    mark: Any = None  # where the collection starts
    key: Any = None  # the pending key of a mapping (None: a key comes next)
    is_key: bool = False  # this collection is written where a mapping key belongs
    merges: list[tuple[Any, PathKey]] = field(default_factory=list)
    explicit: set[str] = field(default_factory=set)


_NO_KEY = object()  # the key of a mapping entry whose key was refused
_MERGE = object()  # a "<<" merge key


class _Composer:
    """Build plain values with marks from a stream of YAML events (no recursion)."""

    def __init__(self, name: str):
        self.doc = Located(name, None)
        self.issues: list[InputIssue] = []
        self.stack: list[_Frame] = []
        self.anchors: dict[str, tuple[Any, PathKey, int] | None] = {}  # None: still open
        self.count = 0  # values built, aliases counted with the size of what they repeat
        self.alias_values = 0
        self.documents = 0
        self.handlers: dict[type, Callable[[Any], None]] = {
                         yaml.ScalarEvent: self.scalar, yaml.MappingStartEvent: self.start,
                         yaml.SequenceStartEvent: self.start, yaml.MappingEndEvent: self.end,
                         yaml.SequenceEndEvent: self.end, yaml.AliasEvent: self.alias,
                         yaml.DocumentStartEvent: self.document}

    # -- errors ---------------------------------------------------------------------------
    def error(self, mark: Any, path: PathKey, message: str) -> None:
        line, col = (mark.line + 1, mark.column + 1) if mark is not None else (0, 0)
        self.issues.append(InputIssue(self.doc.file, line, col, format_path(path), message))
        if len(self.issues) >= MAX_ISSUES:
            raise _Stop

    def current_path(self) -> PathKey:
        """Where the next value goes (for errors raised by the parser)."""
        if not self.stack:
            return ()
        top = self.stack[-1]
        if top.kind == "seq":
            return (*top.path, len(top.value))
        if top.key is None or top.key is _NO_KEY or top.key is _MERGE:
            return top.path
        return (*top.path, top.key)

    # -- events ---------------------------------------------------------------------------
    def document(self, event: yaml.DocumentStartEvent) -> None:
        self.documents += 1
        if self.documents > 1:
            self.error(event.start_mark, (), "expected one YAML document, found a second "
                       "one (a line \"---\"); put each product in its own file")
            raise _Stop

    def target(self, mark: Any) -> tuple[PathKey, bool]:
        """Path of the value about to be built, and whether it is a mapping key."""
        if not self.stack:
            return (), False
        top = self.stack[-1]
        if top.kind == "seq":
            return (*top.path, len(top.value)), False
        if top.key is None:
            return top.path, True
        if top.key is _NO_KEY or top.key is _MERGE:
            return (*top.path, "<<"), False
        return (*top.path, top.key), False

    def place(self, value: Any, path: PathKey, mark: Any, *, alias_of: PathKey | None = None) -> None:
        """Put a finished value where it belongs: the document, a list or a mapping."""
        if alias_of is None:
            self.doc.marks[path] = (mark.line + 1, mark.column + 1)
        else:
            self.doc.marks[path] = (mark.line + 1, mark.column + 1)
            self.doc.alias_of[path] = alias_of
        if not self.stack:
            self.doc.data = value
            return
        top = self.stack[-1]
        if top.kind == "seq":
            top.value.append(value)
            return
        key = top.key
        top.key = None
        if key is _MERGE:
            top.merges.append((value, path))
        elif key is not _NO_KEY:
            top.value[key] = value

    def put_key(self, top: _Frame, key: Any, mark: Any) -> None:
        if key is _NO_KEY:
            top.key = _NO_KEY
            return
        child = (*top.path, key)
        if key in top.explicit:
            self.error(mark, child, f'duplicate key "{key}" (first given on line '
                       f"{self.doc.key_marks[child][0]})")
            top.key = _NO_KEY
            return
        top.explicit.add(key)
        self.doc.key_marks[child] = (mark.line + 1, mark.column + 1)
        top.key = key

    def scalar(self, event: yaml.ScalarEvent) -> None:
        path, is_key = self.target(event.start_mark)
        if event.anchor is not None:
            self.anchors[event.anchor] = None
        # a key is the text as written (``1:`` is the key "1"): only a tagged one is checked
        value = self.construct(event, path) if not is_key or event.tag is not None else event.value
        self.count += 1
        if is_key:
            top = self.stack[-1]
            if event.tag is None and event.implicit[0] and event.value == "<<":
                top.key = _MERGE
            else:
                self.put_key(top, _NO_KEY if value is _NO_KEY else event.value, event.start_mark)
            if event.anchor is not None:
                self.anchors[event.anchor] = (event.value, path, 1)
            return
        if event.anchor is not None:
            self.anchors[event.anchor] = (value, path, 1)
        self.place(value, path, event.start_mark)

    def start(self, event: yaml.CollectionStartEvent) -> None:
        path, is_key = self.target(event.start_mark)
        if len(self.stack) >= MAX_DEPTH:
            self.error(event.start_mark, path[:4], f"expected lists and mappings nested at most "
                       f"{MAX_DEPTH} deep, found deeper nesting")
            raise _Stop
        kind = "map" if isinstance(event, yaml.MappingStartEvent) else "seq"
        if event.tag not in _COLLECTION_TAGS:
            self.error(event.start_mark, path, f"expected a plain {'mapping' if kind == 'map' else 'list'}"
                       f", found the unsupported YAML tag {event.tag}")
        if event.anchor is not None:
            self.anchors[event.anchor] = None
        self.count += 1
        self.stack.append(_Frame(kind, {} if kind == "map" else [], path, event.anchor, self.count,
                                 mark=event.start_mark, is_key=is_key))

    def end(self, event: yaml.Event | None = None) -> None:
        frame = self.stack.pop()
        mark = frame.mark
        if frame.kind == "map" and frame.merges:
            self.merge(frame, mark)
        if frame.anchor is not None:
            self.anchors[frame.anchor] = (frame.value, frame.path, self.count - frame.start_count + 1)
        if frame.is_key:
            self.error(mark, frame.path, "expected a plain key, found a nested structure")
            self.stack[-1].key = _NO_KEY
            return
        self.place(frame.value, frame.path, mark)

    def merge(self, frame: _Frame, mark: Any) -> None:
        """Apply ``<<`` merge keys: keys written in the mapping win, then earlier merges."""
        sources: list[tuple[Any, PathKey]] = []
        for value, path in frame.merges:
            if isinstance(value, dict):
                sources.append((value, path))
            elif isinstance(value, list) and all(isinstance(v, dict) for v in value):
                sources.extend((v, (*path, i)) for i, v in enumerate(value))
            else:
                self.error(mark, (*frame.path, "<<"), "expected a mapping or a list of mappings "
                           "after the merge key <<, found another value")
        for value, path in sources:
            written = self.doc.alias_of.get(path, path)
            for k, v in value.items():
                if k not in frame.value:
                    frame.value[k] = v
                    self.doc.alias_of[(*frame.path, k)] = (*written, k)

    def alias(self, event: yaml.AliasEvent) -> None:
        path, is_key = self.target(event.start_mark)
        if event.anchor not in self.anchors:
            self.error(event.start_mark, path, f'expected an alias to an anchor written before it, '
                       f'found *{event.anchor} with no "&{event.anchor}" above')
            value, size, source = None, 1, None
        elif self.anchors[event.anchor] is None:
            self.error(event.start_mark, path, f"expected an alias outside the value it names, found "
                       f"*{event.anchor} inside &{event.anchor} (a recursive alias)")
            raise _Stop
        else:
            value, source, size = self.anchors[event.anchor]  # type: ignore[misc]
        self.alias_values += size
        self.count += size
        if self.alias_values > MAX_ALIAS_VALUES:
            self.error(event.start_mark, path, f"expected aliases to repeat at most "
                       f"{MAX_ALIAS_VALUES:,} values in all, found more at *{event.anchor} "
                       "(nested aliases multiply)")
            raise _Stop
        if is_key:
            top = self.stack[-1]
            if isinstance(value, str):
                self.put_key(top, value, event.start_mark)
            else:
                self.error(event.start_mark, path, "expected a plain key, found an alias to a "
                           "non-text value")
                top.key = _NO_KEY
            return
        self.place(value, path, event.start_mark, alias_of=source)

    # -- scalars --------------------------------------------------------------------------
    # Complexity above C (radon): YAML 1.1 scalar resolution, one branch per tag (decimal fast
    # path, str, null, bool, int and float with their overflow guards).
    def construct(self, event: yaml.ScalarEvent, path: PathKey) -> Any:
        text = event.value
        mark = event.start_mark
        if event.tag is None and event.implicit[0]:  # plain: decimal numbers first (fast)
            m = _DECIMAL.match(text)
            if m is not None and len(text) <= 300:  # a float holds any 300-digit integer
                return float(text) if m.group(1) else int(text)
        if event.tag in (None, "!"):
            tag = _RESOLVER.resolve(yaml.ScalarNode, text, event.implicit)
            if tag == _TAG + "str" and event.implicit[0] and _FLOAT_12.match(text):
                tag = _TAG + "float"
            elif tag in (_TAG + "timestamp", _TAG + "merge", _TAG + "value", _TAG + "yaml"):
                tag = _TAG + "str"  # no date fields: keep the text as written
        else:
            tag = event.tag
        if tag == _TAG + "str":
            if _SURROGATE.search(text):
                self.error(mark, path, "expected text, found an unpaired UTF-16 surrogate "
                           "escape (\\ud800-\\udfff)")
                return _NO_KEY
            return text
        if tag == _TAG + "null":
            return None
        if tag not in (_TAG + "int", _TAG + "float", _TAG + "bool"):
            self.error(mark, path, f"expected a plain value (number, text, true/false, null), "
                       f"found the unsupported YAML tag {tag}")
            return _NO_KEY
        kind = tag[len(_TAG):]
        node = yaml.ScalarNode(tag, text, None, None)
        digits = sum(c.isdigit() for c in text) if len(text) > 300 else len(text)
        try:
            if kind == "int" and digits > _MAX_INT_DIGITS:
                raise OverflowError
            value = {"int": _CONSTRUCTOR.construct_yaml_int, "float": _CONSTRUCTOR.construct_yaml_float,
                     "bool": _CONSTRUCTOR.construct_yaml_bool}[kind](node)
            if kind == "int":
                float(value)
        except OverflowError:
            self.error(mark, path, f"expected a number within +-1.8e308, found an integer of "
                       f"{digits} digits")
            return _NO_KEY
        except (ValueError, KeyError, IndexError, TypeError):
            what = {"int": "an integer", "float": "a number", "bool": "true or false"}[kind]
            self.error(mark, path, f'expected {what} after the tag !!{kind}, found "{_short(text)}"')
            return _NO_KEY
        return value


def load_located(path: Path | str, display_name: str | None = None) -> Located:
    """Parse a YAML file into a :class:`Located` document.

    Raises
    ------
    ProductError
        When the file is missing, unreadable, too large, not UTF-8, not YAML, empty, or
        breaks a limit of the reader (see the module docstring).
    """
    path = Path(path)
    name = display_name or str(path)
    try:
        size = path.stat().st_size
        if size > MAX_FILE_BYTES:
            raise ProductError([InputIssue(name, 0, 0, "", f"expected a product file of at most "
                                           f"{MAX_FILE_BYTES / 2**20:.0f} MiB, found "
                                           f"{size / 2**20:.0f} MiB")])
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ProductError([InputIssue(name, 0, 0, "", "file not found")]) from None
    except UnicodeDecodeError as exc:
        raise ProductError([InputIssue(name, 0, 0, "", f"expected UTF-8 text, found {exc.reason}"
                                       f" at byte {exc.start}")]) from None
    except IsADirectoryError:
        raise ProductError([InputIssue(name, 0, 0, "", "expected a YAML file, found a folder")]) from None
    except OSError as exc:
        raise ProductError([InputIssue(name, 0, 0, "", f"cannot read file: {exc.strerror}")]) from None
    return parse_located(text, name)


def _line_col(text: str, offset: int) -> tuple[int, int]:
    """1-based line and column of a character offset."""
    offset = max(0, min(offset, len(text)))
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def _control_characters(text: str, name: str) -> list[InputIssue]:
    out = []
    for m in _NOT_PRINTABLE.finditer(text):
        line, col = _line_col(text, m.start())
        out.append(InputIssue(name, line, col, "", f"expected printable text, found the control "
                              f"character U+{ord(m.group()):04X}"))
        if len(out) >= 20:
            break
    return out


def parse_located(text: str, name: str) -> Located:
    """Parse YAML text (see :func:`load_located`)."""
    issues = _control_characters(text, name)
    if issues:
        raise ProductError(issues)
    composer = _Composer(name)
    loader = _Loader(text)
    try:
        next_event, handlers = loader.get_event, composer.handlers
        event = next_event()
        while event is not None:
            handler = handlers.get(type(event))
            if handler is not None:
                handler(event)
            event = next_event()
    except _Stop:
        pass
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        problem = exc.problem or "invalid YAML"
        context = f" ({exc.context})" if exc.context else ""
        composer.error(mark, composer.current_path(), f"YAML syntax error: {problem}{context}")
    except yaml.reader.ReaderError as exc:
        line, col = _line_col(text, exc.position)
        composer.issues.append(InputIssue(name, line, col, "", f"expected printable text, "
                                          f"found {exc.reason} (#x{exc.character:04x})"))
    except yaml.YAMLError as exc:  # pragma: no cover - libyaml reports marks for every error
        composer.issues.append(InputIssue(name, 0, 0, "", f"YAML error: {exc}"))
    finally:
        loader.dispose()
    if composer.issues:
        raise ProductError(composer.issues)
    if composer.documents == 0:
        raise ProductError([InputIssue(name, 1, 1, "", "expected a YAML mapping, found an empty file")])
    return composer.doc
