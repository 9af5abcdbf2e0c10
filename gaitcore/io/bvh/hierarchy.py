"""The HIERARCHY section of a BVH file: joints, offsets and channels, read in linear time.

The parser walks the tokens once, with an explicit stack of open joints instead of
recursion, so a rig nested 100,000 joints deep reads like a flat one, in time and memory
proportional to the section (the MOTION lines are never tokenized). Every problem is a
:class:`~gaitcore.errors.GaitInputError` with its line number.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from gaitcore.errors import GaitInputError

CHANNEL_KINDS = {
    "xposition": ("t", "x"), "yposition": ("t", "y"), "zposition": ("t", "z"),
    "xrotation": ("r", "x"), "yrotation": ("r", "y"), "zrotation": ("r", "z"),
}
"""BVH channel name (lower case) -> (kind: "t"ranslation or "r"otation, axis)."""
_TOKEN = re.compile(r"[{}]|[^\s{}]+")


@dataclass
class Node:
    """One ROOT, JOINT or End Site as parsed; ``channels`` are (kind, axis, motion column)."""

    name: str
    parent: int
    offset: np.ndarray
    line: int
    end_site: bool = False
    channels: list[tuple[str, str, int]] = field(default_factory=list)


class _Tokens:
    """Tokens of the lines before MOTION, one at a time with their (1-based) line numbers.

    Lines are split as they are reached, so only the current line's tokens are held.
    """

    def __init__(self, lines: list[str]) -> None:
        self._lines = lines
        self.motion_line: int | None = None  # 0-based index of the line holding MOTION
        self._row = -1  # index of the line being read
        self._toks: list[str] = []
        self._i = 0
        self._n = 0  # len(self._toks)

    def _advance(self) -> bool:
        """Move to the next line with tokens; False at MOTION or the end of the file."""
        while self._i >= self._n:
            if self.motion_line is not None or self._row + 1 >= len(self._lines):
                return False
            self._row += 1
            line = self._lines[self._row]
            self._toks, self._i = _TOKEN.findall(line), 0
            if "MOTION" in line.upper():  # then look for it as a token
                upper = [t.upper() for t in self._toks]
                if "MOTION" in upper:
                    self.motion_line = self._row
                    self._toks = self._toks[:upper.index("MOTION")]
            self._n = len(self._toks)
        return True

    def peek(self) -> tuple[str, int]:
        """The next token, or ``("", line)`` past the end (the MOTION or last line)."""
        if self._i >= self._n and not self._advance():
            return "", (self._row + 1 if self.motion_line is not None else len(self._lines))
        return self._toks[self._i], self._row + 1

    def take(self) -> tuple[str, int]:
        tok = self.peek()
        self._i += 1
        return tok

    def skip(self) -> None:
        """Pass the token :meth:`peek` just returned."""
        self._i += 1

    def take_on_line(self, n: int) -> list[str]:
        """Up to ``n`` tokens left on the current line, stopping before a brace."""
        got = self._toks[self._i:self._i + n]
        for j, tok in enumerate(got):
            if tok in ("{", "}"):
                got = got[:j]
                break
        self._i += len(got)
        return got


@dataclass
class _Open:
    """A joint whose braces are open: what it has seen so far."""

    index: int
    kind: str
    line: int
    end_site: bool
    seen_offset: bool = False
    seen_channels: bool = False


class _Parser:
    def __init__(self, lines: list[str], where: str) -> None:
        self.toks = _Tokens(lines)
        self.where = where
        self.nodes: list[Node] = []
        self.n_columns = 0

    def fail(self, line: int, message: str) -> GaitInputError:
        return GaitInputError(f"{self.where}, line {line}: {message}")

    def numbers(self, count: int, what: str, line: int) -> tuple[float, ...]:
        """``count`` finite numbers, all on ``line``."""
        got = self.toks.take_on_line(count)
        try:
            if len(got) < count:
                raise ValueError
            vals = tuple(float(t) for t in got)
        except ValueError:
            raise self.fail(line, f"{what} needs {count} numbers on its line") from None
        if not all(map(math.isfinite, vals)):
            raise self.fail(line, f"{what} has a value that is not a finite number")
        return vals

    def open_joint(self, parent: int, line: int, end_site: bool) -> _Open:
        """Read a joint's name and its '{' (the keyword was taken)."""
        name_tokens = self.toks.take_on_line(1 << 30)
        if end_site:
            name_tokens = []  # "End Site" sometimes has a name after it; ignore it
        elif not name_tokens:
            raise self.fail(line, "ROOT/JOINT needs a name")
        kind = "End Site" if end_site else "joint " + repr(" ".join(name_tokens))
        tok, ln = self.toks.peek()
        if tok != "{":
            raise self.fail(ln, f"{kind} (line {line}) must be followed by '{{'")
        self.toks.take()
        self.nodes.append(Node(" ".join(name_tokens), parent, np.zeros(3), line, end_site))
        return _Open(len(self.nodes) - 1, kind, line, end_site)

    def channels(self, joint: _Open, line: int) -> None:
        """Read ``CHANNELS n name...`` (the keyword was taken)."""
        count = self.numbers(1, "CHANNELS", line)[0]
        if not (math.isfinite(count) and count == int(count) and 0 <= count <= 6):
            raise self.fail(line, f"CHANNELS count must be a whole number 0..6, got {count:g}")
        names = self.toks.take_on_line(int(count))
        if len(names) != count:
            raise self.fail(line, f"CHANNELS says {int(count)} but lists {len(names)} on its line")
        node = self.nodes[joint.index]
        for ch in names:
            if ch.lower() not in CHANNEL_KINDS:
                raise self.fail(line, f"unknown channel {ch!r} in {joint.kind}; BVH channels are "
                                      "Xposition Yposition Zposition Xrotation Yrotation Zrotation")
            k, axis = CHANNEL_KINDS[ch.lower()]
            if any(c[:2] == (k, axis) for c in node.channels):
                raise self.fail(line, f"channel {ch!r} is listed twice in {joint.kind}")
            node.channels.append((k, axis, self.n_columns))
            self.n_columns += 1
        joint.seen_channels = True

    def step(self, stack: list[_Open]) -> None:
        """Read one item inside the innermost open joint: OFFSET, CHANNELS, a child or '}'."""
        joint = stack[-1]
        tok, ln = self.toks.peek()
        word = tok.upper()
        if word in ("JOINT", "END", "}") and not joint.seen_offset:
            raise self.fail(ln, f"{joint.kind} (line {joint.line}) has no OFFSET; "
                                "add 'OFFSET x y z'")
        if word in ("JOINT", "END", "}") and not joint.seen_channels and not joint.end_site:
            raise self.fail(ln, f"{joint.kind} (line {joint.line}) has no CHANNELS; add e.g. "
                                "'CHANNELS 3 Zrotation Xrotation Yrotation'")
        if word == "OFFSET":
            self.toks.skip()
            self.nodes[joint.index].offset = np.array(self.numbers(3, "OFFSET", ln))
            joint.seen_offset = True
        elif word == "CHANNELS" and not joint.end_site:
            self.toks.skip()
            self.channels(joint, ln)
        elif word == "JOINT" and not joint.end_site:
            self.toks.skip()
            stack.append(self.open_joint(joint.index, ln, False))
        elif word == "END" and not joint.end_site:
            self.toks.skip()
            if self.toks.peek()[0].upper() != "SITE":
                raise self.fail(ln, "expected 'End Site'")
            self.toks.skip()
            stack.append(self.open_joint(joint.index, ln, True))
        elif tok == "}":
            self.toks.skip()
            stack.pop()
        elif tok == "":
            raise self.fail(ln, f"unbalanced braces: {joint.kind} opened at line {joint.line} "
                                "is never closed; add the missing '}'")
        else:
            raise self.fail(ln, f"unexpected {tok!r} in {joint.kind}; expected OFFSET, "
                                "CHANNELS, JOINT, End Site or '}'")


def parse_hierarchy(lines: list[str], where: str) -> tuple[list[Node], int, int]:
    """Nodes (parents first), the number of motion columns and the index of the MOTION line.

    Parameters
    ----------
    lines : list of str
        The file's lines.
    where : str
        The file, for messages.

    Raises
    ------
    GaitInputError
        With the line number: no HIERARCHY or ROOT, unbalanced braces, a joint without
        OFFSET or CHANNELS, an unknown or repeated channel, anything after the ROOT closed,
        no MOTION section.
    """
    parser = _Parser(lines, where)
    toks = parser.toks
    tok, ln = toks.take()
    if tok.upper() != "HIERARCHY":
        raise parser.fail(ln if tok else 1, "a BVH file starts with HIERARCHY; is this a BVH file?")
    tok, ln = toks.peek()
    if tok.upper() != "ROOT":
        if tok.upper() == "JOINT":
            raise parser.fail(ln, "JOINT outside a ROOT; the hierarchy must start with "
                                  "'ROOT <name>'")
        raise parser.fail(ln, f"expected 'ROOT <name>' after HIERARCHY, found {tok or 'nothing'!r}")
    toks.take()
    stack = [parser.open_joint(-1, ln, False)]
    while stack:
        parser.step(stack)
    tok, ln = toks.peek()
    if tok:
        what = {"ROOT": "a second ROOT; only one skeleton per file is supported",
                "JOINT": "JOINT outside the ROOT's braces",
                "}": "unbalanced braces: one '}' too many"}.get(tok.upper(), f"unexpected {tok!r}")
        raise parser.fail(ln, f"{what} (after the ROOT closed)")
    if toks.motion_line is None:
        raise parser.fail(len(lines), "no MOTION section; a BVH file ends with MOTION, Frames: "
                                      "and Frame Time: lines followed by one line per frame")
    return parser.nodes, parser.n_columns, toks.motion_line
