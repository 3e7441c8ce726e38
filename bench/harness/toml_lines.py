"""Line numbers of keys in a TOML text (``tomllib`` gives none).

:func:`key_lines` maps every key path to the 1-based line where it is
written. A path is a tuple of keys and 0-based array indices, e.g.
``("tests", 1, "excitation", 0, "node")`` for ``node`` in the first
``[[tests.excitation]]`` of the second ``[[tests]]``. The text must already
be valid TOML (parse it with ``tomllib`` first); this scanner only follows
structure: headers, dotted and quoted keys, inline tables, (multi-line)
arrays, strings and comments.
"""
from __future__ import annotations

import re

Path = tuple[str | int, ...]

_BARE = re.compile(r"[A-Za-z0-9_-]+")


class _Scanner:
    def __init__(self, text: str):
        self.text = text
        self.pos = 0
        self._counted = (0, 1)  # (position, its line): line numbers are counted forward, O(text) in all
        self.lines: dict[Path, int] = {}
        self.arrays: dict[Path, int] = {}  # array-of-tables path -> last index

    # ---- low level ---------------------------------------------------
    def line(self) -> int:
        """1-based line of ``pos`` (which only moves forward)."""
        start, line = self._counted
        line += self.text.count("\n", start, self.pos)
        self._counted = (self.pos, line)
        return line

    def peek(self, n: int = 1) -> str:
        return self.text[self.pos:self.pos + n]

    def skip_space(self, newlines: bool) -> None:
        """Skip blanks and comments (and newlines if asked)."""
        while self.pos < len(self.text):
            ch = self.text[self.pos]
            if ch in " \t\r" or (newlines and ch == "\n"):
                self.pos += 1
            elif ch == "#":
                end = self.text.find("\n", self.pos)
                self.pos = len(self.text) if end < 0 else end
            else:
                return

    def string(self) -> str:
        """Consume a string at ``pos`` and return its (raw) content."""
        quote = self.peek()
        if self.peek(3) == quote * 3:
            end = self.text.find(quote * 3, self.pos + 3)
            while self.text[end + 3:end + 4] == quote:  # up to two quotes may close the body
                end += 1
            body, self.pos = self.text[self.pos + 3:end], end + 3
            return body
        i = self.pos + 1
        while self.text[i] != quote:
            i += 2 if quote == '"' and self.text[i] == "\\" else 1
        body, self.pos = self.text[self.pos + 1:i], i + 1
        return body

    def key(self) -> list[str]:
        """A dotted key, e.g. ``a."b.c".d``."""
        parts = []
        while True:
            self.skip_space(False)
            if self.peek() in "\"'":
                parts.append(self.string())
            else:
                m = _BARE.match(self.text, self.pos)
                parts.append(m.group())
                self.pos = m.end()
            self.skip_space(False)
            if self.peek() != ".":
                return parts
            self.pos += 1

    # ---- structure ---------------------------------------------------
    def resolve(self, keys: list[str]) -> Path:
        """Header keys to a path, entering the last element of arrays of tables."""
        path: Path = ()
        for k in keys:
            path += (k,)
            if path in self.arrays:
                path += (self.arrays[path],)
        return path

    def value(self, path: Path) -> None:
        self.skip_space(False)
        ch = self.peek()
        if ch == "{":
            self.pos += 1
            self.skip_space(True)
            while self.peek() != "}":
                self.pair(path)
                self.skip_space(True)
                if self.peek() == ",":
                    self.pos += 1
                    self.skip_space(True)
            self.pos += 1
        elif ch == "[":
            self.pos += 1
            index = 0
            self.skip_space(True)
            while self.peek() != "]":
                self.lines.setdefault(path + (index,), self.line())
                self.value(path + (index,))
                index += 1
                self.skip_space(True)
                if self.peek() == ",":
                    self.pos += 1
                    self.skip_space(True)
            self.pos += 1
        elif ch in "\"'":
            self.string()
        else:
            m = re.compile(r"[^,\]}\s#]+").match(self.text, self.pos)
            self.pos = m.end()
            if re.compile(r"[ T]\d").match(self.text, self.pos):  # date-time with a space
                self.pos = re.compile(r"[^,\]}\s#]+").match(self.text, self.pos + 1).end()

    def pair(self, table: Path) -> None:
        line = self.line()
        keys = self.key()
        path = table
        for k in keys:
            path += (k,)
            self.lines.setdefault(path, line)
        self.skip_space(False)
        self.pos += 1  # "="
        self.value(path)

    def header(self) -> Path:
        line = self.line()
        double = self.peek(2) == "[["
        self.pos += 2 if double else 1
        keys = self.key()
        self.pos += 2 if double else 1
        if double:
            parent = self.resolve(keys[:-1]) + (keys[-1],)
            self.arrays[parent] = self.arrays.get(parent, -1) + 1
            self.lines.setdefault(parent, line)
        path = self.resolve(keys)
        self.lines[path] = line
        return path

    def scan(self) -> dict[Path, int]:
        table: Path = ()
        while True:
            self.skip_space(True)
            if self.pos >= len(self.text):
                return self.lines
            if self.peek() == "[":
                table = self.header()
            else:
                self.pair(table)


def key_lines(text: str) -> dict[Path, int]:
    """Line (1-based) of every key path and array element in a valid TOML text."""
    return _Scanner(text).scan()


def line_of(lines: dict[Path, int], path: Path) -> int | None:
    """Line of ``path``, or of its closest written ancestor (e.g. inside a default)."""
    for end in range(len(path), 0, -1):
        if path[:end] in lines:
            return lines[path[:end]]
    return None
