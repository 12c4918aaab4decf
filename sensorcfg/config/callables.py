"""How a suite names a Python callable: 'module:function' (`generic` sensors, `custom` noise).

The one spelling rule for both, checked when the suite is loaded (no import, no model), with a message that
says which part is wrong; its pattern is the JSON Schema's, so editors and the loader agree. The module is
a dotted import path, the function a dotted attribute path; every part a Python name in ASCII (letters,
digits and '_', not starting with a digit).
"""

from __future__ import annotations

import re

from ..errors import quote

__all__ = ["CALLABLE_PATTERN", "callable_problem"]

_NAME = r"[A-Za-z_][A-Za-z0-9_]*"
_DOTTED = rf"{_NAME}(?:\.{_NAME})*"
CALLABLE_PATTERN = rf"^{_DOTTED}:{_DOTTED}$"  # the JSON Schema's (ECMAScript and Python read it alike)
_FORM = re.compile(CALLABLE_PATTERN.replace("^", r"\A").replace("$", r"\Z"))
_PART = re.compile(rf"\A{_NAME}\Z")


def callable_problem(text: str, example: str) -> str | None:
    """What is wrong with `text` as 'module:function' (None when nothing is), `example` showing the form."""
    if _FORM.match(text):
        return None
    head = f"a callable is written 'module:function' (for example {example!r}); got {quote(text)}"
    if text.count(":") != 1:
        count = "no" if ":" not in text else "more than one"
        return f"{head}: it has {count} ':' (one separates the module from the function)"
    module, _, function = text.partition(":")
    for what, side, path in (("module", "before", module), ("function", "after", function)):
        if not path:
            return f"{head}: the {what}'s name {side} ':' is missing"
        for part in path.split("."):
            if not part:
                return f"{head}: the {what} {quote(path)} has an empty part between dots"
            if part.strip() != part and _PART.match(part.strip()):
                return f"{head}: remove the spaces around {quote(part.strip())}"
            if not _PART.match(part):
                renamed = re.sub(r"[^A-Za-z0-9_]", "_", part)
                fix = f"; rename it, for example to {quote(renamed)}" if _PART.match(renamed) else ""
                return (f"{head}: {quote(part)} is not a Python name (a name starts with an ASCII letter or '_' and "
                        f"holds ASCII letters, digits and '_'){fix}")
    return head  # (not reached: each way to miss the pattern is named above)
