"""One large generated function as several C files, so that a compiler runs on each at once.

CasADi writes an SX function as one flat C function: local variables ``a00000 ...`` assigned in
sequence, the inputs read as ``arg[i][j]`` and the outputs written as ``res[i][j]``. gcc's time
on one function grows faster than its length (the stage Hessian: half a million statements, about
a minute at ``-O1``), so the body is cut into consecutive parts, each a function in its own file.
The values alive across a cut (assigned before it, read after it before any new assignment) pass
through a buffer on the caller's stack: each part loads those it reads and stores those it
assigned. Every statement is kept as written, in its order: the parts compute what the one
function computed, operation for operation.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

_HEAD = re.compile(r"^static int casadi_f0\(const casadi_real\*\* arg, casadi_real\*\* res, casadi_int\* iw, "
                   r"casadi_real\* w, int mem\) \{$")
_DECL = re.compile(r"^  casadi_real a\d+(, a\d+)*;$")
_VAR = re.compile(r"\ba\d+\b")
_ASSIGN = re.compile(r"^  (a\d+)=(.*);$")
_OUTPUT = re.compile(r"^  if \(res\[\d+\]!=0\) res\[\d+\]\[\d+\]=(a\d+);$")
_HELPER = re.compile(r"^casadi_real (casadi_\w+)\(")
_NAME = re.compile(r"(?<![\w.])[A-Za-z_]\w*")  # an identifier (not an exponent's e)
# what a part's statement may name besides its variables: the inputs, C's math and the file's helpers
_KNOWN = {"arg", "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "asinh", "acosh",
          "atanh", "exp", "log", "log1p", "expm1", "sqrt", "pow", "fabs", "floor", "ceil", "fmin", "fmax", "erf",
          "copysign", "hypot", "fmod"}


SCALAR_PRELUDE = "#include <math.h>\n#define casadi_real double"  # what a part's file starts with
# a part is called only from its own library's driver: not exported from it
_HIDDEN = '#if defined(__GNUC__)\n__attribute__((visibility("hidden")))\n#endif'


@dataclass(frozen=True)
class SplitSource:
    """A generated file with its function's body in parts: ``main`` (the file, its function now
    calling the parts in order) and each part's own file."""

    main: str
    parts: tuple[str, ...]


Stmt = tuple[str | None, str, list[str]]  # what it assigns (None: an output), its text after "=", what it reads


def _statements(lines: list[str], start: int) -> tuple[list[Stmt], int] | None:
    """The body's statements after the declarations (from line ``start``, the function's head) and
    the line of its ``return 0;``; None when a statement is not one this module knows."""
    i = start + 1
    while i < len(lines) and _DECL.match(lines[i]):
        i += 1
    body: list[Stmt] = []
    while i < len(lines) and lines[i] != "  return 0;":
        m = _ASSIGN.match(lines[i])
        if m:
            body.append((m.group(1), m.group(2), _VAR.findall(m.group(2))))
        elif _OUTPUT.match(lines[i]):
            body.append((None, lines[i], _VAR.findall(lines[i])))
        else:
            return None
        i += 1
    return (body, i) if i + 1 < len(lines) and lines[i + 1] == "}" else None


def _live_at(body: list[Stmt], cuts: list[int]) -> list[set[str]]:
    """At each cut (a statement index), the variables read at or after it before any assignment."""
    live: set[str] = set()
    out: dict[int, set[str]] = {}
    wanted = set(cuts)
    for k in range(len(body) - 1, -1, -1):
        write, _, reads = body[k]
        if write is not None:
            live.discard(write)
        live.update(reads)
        if k in wanted:
            out[k] = set(live)
    return [out[c] for c in cuts]


def _helpers(lines: list[str], head: int) -> dict[str, str]:
    """The file's one-line helper functions (``casadi_sq`` ...) above the function by name, made
    static for a part's file."""
    return {m.group(1): f"static {ln}" for ln in lines[:head]
            if (m := _HELPER.match(ln)) and ln.rstrip().endswith("}")}


def _self_contained(body: list[Stmt], helpers: dict[str, str]) -> bool:
    """Whether the statements name nothing but their variables, the inputs, C's math functions and
    the helpers a part's file has (no work vector, no other function)."""
    names = {x for lhs, text, _ in body if lhs is not None for x in _NAME.findall(text)}
    return not {x for x in names if not re.fullmatch(r"a\d+", x)} - _KNOWN - set(helpers)


def _part(name: str, body: list[Stmt], live: tuple[set[str], set[str]], slots: dict[str, int],
          helpers: dict[str, str], prelude: str) -> str:
    """A part's file: its statements, a value from an earlier part read from the buffer where the
    statement reads it, a value a later part reads stored right after its last assignment (each
    local then lives as long as in the one function)."""
    live_in, live_out = live
    last = {lhs: k for k, (lhs, _, _) in enumerate(body) if lhs is not None and lhs in live_out}
    out, assigned = [], set()
    for k, (lhs, text, reads) in enumerate(body):
        if any(v in live_in and v not in assigned for v in reads):
            text = _VAR.sub(lambda v: f"s[{slots[v.group()]}]" if v.group() in live_in and v.group() not in assigned
                            else v.group(), text)
        if lhs is None:
            out.append(text)
            continue
        out.append(f"  {lhs}={text};")
        assigned.add(lhs)
        if last.get(lhs) == k:
            out.append(f"  s[{slots[lhs]}]={lhs};")
    names = sorted(assigned, key=lambda v: int(v[1:]))
    decl = [f"  casadi_real {', '.join(names[i:i + 12])};" for i in range(0, len(names), 12)]
    return "\n".join([prelude, *helpers.values(),
                      _HIDDEN, f"void {name}(const casadi_real** arg, casadi_real** res, casadi_real* s) {{",
                      *decl, *out, "}", ""])


@dataclass(frozen=True)
class Parsed:
    """A generated file's lines, its function's head (a line index), statements and ``return 0;`` line."""

    lines: list[str]
    head: int
    body: list[Stmt]
    ret: int

    @property
    def declarations(self) -> list[str]:
        """The lines declaring the function's variables, right after its head."""
        end = self.head + 1
        while _DECL.match(self.lines[end]):
            end += 1
        return self.lines[self.head + 1:end]


def parse(text: str) -> Parsed | None:
    """The function of ``text`` (a CasADi file of one SX function) as statements; None when the
    file is not of the form this module knows."""
    lines = text.split("\n")
    head = next((i for i, ln in enumerate(lines) if _HEAD.match(ln)), None)
    parsed = _statements(lines, head) if head is not None else None
    return None if head is None or parsed is None else Parsed(lines, head, *parsed)


def split_source(text: str, prefix: str, cuts: Sequence[float], prelude: str = SCALAR_PRELUDE
                 ) -> SplitSource | None:
    """``text`` (a CasADi file of one SX function, ``prefix`` its generator's name) with its body cut
    at the fractions ``cuts`` (increasing, between 0 and 1) of its statements, each part's file
    starting with ``prelude`` (its includes and ``casadi_real``); None when the file is not of the
    form this module knows (the caller then compiles it whole)."""
    parsed = parse(text)
    if parsed is None:
        return None
    lines, head, body, ret = parsed.lines, parsed.head, parsed.body, parsed.ret
    helpers = _helpers(lines, head)
    if not _self_contained(body, helpers):
        return None
    at = sorted({int(len(body) * f) for f in cuts} - {0, len(body)})
    if not at:
        return None
    live = _live_at(body, at)
    slots: dict[str, int] = {}
    for v in sorted(set().union(*live), key=lambda v: int(v[1:])):
        slots[v] = len(slots)
    bounds, ins, outs = [0, *at, len(body)], [set(), *live], [*live, set()]
    names = [f"{prefix}_part{k}" for k in range(len(bounds) - 1)]
    parts = tuple(_part(names[k], body[bounds[k]:bounds[k + 1]], (ins[k], outs[k]), slots, helpers, prelude)
                  for k in range(len(names)))
    protos = [f"void {n}(const casadi_real** arg, casadi_real** res, casadi_real* s);" for n in names]
    driver = [*protos, lines[head], f"  casadi_real s[{max(len(slots), 1)}];",
              *(f"  {n}(arg, res, s);" for n in names), "  return 0;"]
    return SplitSource("\n".join(lines[:head] + driver + lines[ret + 1:]), parts)
