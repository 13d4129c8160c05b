"""Read YAML into plain Python values while keeping the line and column of every value.

PyYAML's ``compose`` gives nodes with ``start_mark``; we convert them to dicts, lists and
scalars and keep a map from key path (a tuple of keys and indices) to the 1-based line and
column of the value there (and of its key, for mapping entries).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast

import yaml

from .errors import InputIssue, ProductError

PathKey = tuple[str | int, ...]


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
    """A parsed YAML document with positions."""

    file: str
    data: Any
    marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)
    key_marks: dict[PathKey, tuple[int, int]] = field(default_factory=dict)

    def where(self, path: PathKey, *, key: bool = False) -> tuple[int, int]:
        """Line and column of the value at ``path`` (or its key), else of the nearest parent."""
        table = self.key_marks if key else self.marks
        p = tuple(path)
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


_SCALAR_TAGS = {
    "tag:yaml.org,2002:int",
    "tag:yaml.org,2002:float",
    "tag:yaml.org,2002:bool",
    "tag:yaml.org,2002:null",
    "tag:yaml.org,2002:str",
}


def _convert(node: yaml.Node, path: PathKey, doc: Located, issues: list[InputIssue]) -> Any:
    doc.marks[path] = (node.start_mark.line + 1, node.start_mark.column + 1)
    if isinstance(node, yaml.MappingNode):
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                line, col = key_node.start_mark.line + 1, key_node.start_mark.column + 1
                issues.append(InputIssue(doc.file, line, col, format_path(path),
                                         "expected a plain key, found a nested structure"))
                continue
            key = key_node.value
            child = (*path, key)
            kline, kcol = key_node.start_mark.line + 1, key_node.start_mark.column + 1
            if key in out:
                issues.append(InputIssue(doc.file, kline, kcol, format_path(child),
                                         f'duplicate key "{key}" (first given on line '
                                         f"{doc.key_marks[child][0]})"))
                continue
            doc.key_marks[child] = (kline, kcol)
            out[key] = _convert(value_node, child, doc, issues)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_convert(item, (*path, i), doc, issues) for i, item in enumerate(node.value)]
    # Scalars: let PyYAML's resolver decide the type, without building arbitrary objects.
    if node.tag not in _SCALAR_TAGS:
        issues.append(InputIssue(doc.file, *doc.marks[path], format_path(path),
                                 f"unsupported YAML tag {node.tag}"))
        return None
    return yaml.SafeLoader.construct_scalar(_LOADER, cast(yaml.ScalarNode, node)) \
        if node.tag.endswith(":str") else \
        _LOADER.construct_object(node, deep=True)


_LOADER = yaml.SafeLoader("")


def load_located(path: Path | str, display_name: str | None = None) -> Located:
    """Parse a YAML file into a :class:`Located` document.

    Raises
    ------
    ProductError
        When the file is missing, unreadable, not UTF-8, not YAML, or empty.
    """
    path = Path(path)
    name = display_name or str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ProductError([InputIssue(name, 0, 0, "", "file not found")]) from None
    except UnicodeDecodeError as exc:
        raise ProductError([InputIssue(name, 0, 0, "", f"expected UTF-8 text, found {exc.reason}"
                                       f" at byte {exc.start}")]) from None
    except OSError as exc:
        raise ProductError([InputIssue(name, 0, 0, "", f"cannot read file: {exc.strerror}")]) from None
    return parse_located(text, name)


def parse_located(text: str, name: str) -> Located:
    """Parse YAML text (see :func:`load_located`)."""
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (0, 0)
        problem = exc.problem or "invalid YAML"
        context = f" ({exc.context})" if exc.context else ""
        raise ProductError([InputIssue(name, line, col, "",
                                       f"YAML syntax error: {problem}{context}")]) from None
    except yaml.YAMLError as exc:
        raise ProductError([InputIssue(name, 0, 0, "", f"YAML error: {exc}")]) from None
    if node is None:
        raise ProductError([InputIssue(name, 1, 1, "", "expected a YAML mapping, found an empty file")])
    doc = Located(name, None)
    issues: list[InputIssue] = []
    doc.data = _convert(node, (), doc, issues)
    if issues:
        raise ProductError(issues)
    return doc
