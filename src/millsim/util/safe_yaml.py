"""The one YAML loader of millsim: safe (plain data, no Python objects) and bounded.

A YAML file of a few kB can ask for gigabytes (an alias bomb: anchors that each repeat the one
before ten times) or nest deeper than Python's recursion (a RecursionError of a thousand lines);
a materials or config file is a few kB of plain nesting with no aliases. So a file beyond
MAX_BYTES, nesting beyond MAX_DEPTH, more than MAX_ALIASES aliases or more than MAX_NODES values
once its aliases are expanded is refused before it is built, with one line naming the file, the
line and the limit.
"""

import os

import yaml

MAX_BYTES = 1_000_000
MAX_DEPTH = 32
MAX_ALIASES = 100
MAX_NODES = 1_000_000  # values once every alias is expanded: what a file of MAX_BYTES can hold
BOMB = "a few kB of aliases can stand for gigabytes (an alias bomb)"


class LimitedSafeLoader(yaml.SafeLoader):
    """yaml.SafeLoader that counts nesting and aliases while it composes the document, before
    any of it is built."""

    def __init__(self, stream):
        super().__init__(stream)
        self._depth = 0
        self._aliases = 0
        self._expanded = {}  # id(node) -> nodes it stands for with every alias in it expanded

    def compose_node(self, parent, index):
        mark = self.peek_event().start_mark
        if self.check_event(yaml.AliasEvent):
            self._aliases += 1
            if self._aliases > MAX_ALIASES:
                raise _Refused(mark, f"more than {MAX_ALIASES} aliases (*name); {BOMB}")
            return super().compose_node(parent, index)
        self._depth += 1
        if self._depth > MAX_DEPTH:
            raise _Refused(mark, f"nested deeper than {MAX_DEPTH} levels")
        try:
            node = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        # a few aliases of aliases already multiply: count what the document would expand to
        children = node.value if isinstance(node, yaml.SequenceNode) else \
            [n for pair in node.value for n in pair] if isinstance(node, yaml.MappingNode) else ()
        size = 1 + sum(self._expanded.get(id(child), 1) for child in children)
        if size > MAX_NODES:
            raise _Refused(mark, f"expands to more than {MAX_NODES} values; {BOMB}")
        self._expanded[id(node)] = size
        return node


class _Refused(yaml.YAMLError):
    def __init__(self, mark, problem):
        super().__init__(problem)
        self.mark, self.problem = mark, problem


def check_size(path):
    """Refuse a YAML file larger than MAX_BYTES before reading it."""
    size = os.stat(path).st_size
    if size > MAX_BYTES:
        raise ValueError(f"{path}: {size} bytes, more than the {MAX_BYTES} a YAML file of "
                         "millsim may have; refused")


def load(text, path, loader=LimitedSafeLoader):
    """The document in ``text`` (read from ``path``, which the messages name), with ``loader`` (a
    LimitedSafeLoader or a subclass); ValueError in one line for text that is not YAML or is
    beyond the limits."""
    if len(text) > MAX_BYTES:
        raise ValueError(f"{path}: {len(text)} characters, more than the {MAX_BYTES} a YAML file "
                         "of millsim may have; refused")
    try:
        return yaml.load(text, Loader=loader)
    except _Refused as exc:
        raise ValueError(f"{path}: line {exc.mark.line + 1}: {exc.problem}; refused") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f"line {mark.line + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ValueError(f"{path}: {line}not valid YAML ({' '.join(problem.split())})") from None
