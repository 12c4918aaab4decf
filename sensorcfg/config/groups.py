"""Observation groups: `groups: {policy: [...], critic: [...]}`, each a list of the suite's observations
(sensors and clean twins, by name or glob) that an engine concatenates into one vector per simulation.

The order is the rule users rely on: entries in list order; a glob's matches in the order the suite returns
its observations (file order, each twin right after its sensor), leaving out those already placed earlier
in the group, disabled sensors and camera images (a glob never fails for what it skips; a name does). Each
observation lies at consecutive columns, flattened in C order (buffer axis first). Checked here, without a
model, at the line of each entry; `sensorcfg.groups` lays the columns out once shapes are known.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Collection, Mapping

from ..errors import Problem, did_you_mean
from .locate import problem_at
from .models import SensorConfig
from .source import Doc
from .tables import GLOB_CHARS, IMAGE_KINDS

__all__ = ["resolve_groups"]


def _refusal(name: str, cfg: SensorConfig) -> str | None:
    """Why observation `name` cannot be a group's member (None: it can)."""
    if cfg.enabled is False:
        return f"sensor {name!r} is disabled (enabled: false): enable it, or leave it out of the group"
    if cfg.kind in IMAGE_KINDS:
        return (f"sensor {name!r} is a camera image ({cfg.kind}); a group concatenates vectors: read images "
                "from the observation dict, or leave it out of the group")
    return None


def resolve_groups(groups: Mapping[str, tuple[str, ...]], sensors: Mapping[str, SensorConfig], doc: Doc,
                   problems: list[Problem], written: Collection[str] = ()) -> dict[str, tuple[str, ...]]:
    """Each group's observation names in column order; problems appended at the entry they are about. A name
    `written` in the file but not among `sensors` (left out for a problem of its own) is not reported again."""
    out: dict[str, tuple[str, ...]] = {}
    for group, entries in groups.items():
        members: list[str] = []
        before = len(problems)
        for i, entry in enumerate(entries):
            here = ("groups", group, i)
            if GLOB_CHARS & set(entry):
                matched = [n for n in sensors if fnmatch.fnmatchcase(n, entry) and n not in members
                           and _refusal(n, sensors[n]) is None]
                if not matched:
                    problems.append(problem_at(doc, here, f"{entry!r} matches no observation that is not already "
                                               f"in group {group!r}; the suite's observations are: "
                                               f"{', '.join(list(sensors)[:12])}{' ...' if len(sensors) > 12 else ''}"))
                members += matched
                continue
            if entry not in sensors and entry in written:
                continue
            if entry not in sensors:
                hint = (did_you_mean(entry, list(sensors))
                        or f"; the suite's observations are: {', '.join(list(sensors)[:12])}")
                problems.append(problem_at(doc, here, f"the suite has no observation named {entry!r}{hint}"))
            elif entry in members:
                problems.append(problem_at(doc, here, f"{entry!r} is already in group {group!r} (each observation "
                                           "lies at one place of a group): remove this entry"))
            elif (why := _refusal(entry, sensors[entry])) is not None:
                problems.append(problem_at(doc, here, why))
            else:
                members.append(entry)
        if not members and len(problems) == before:
            problems.append(problem_at(doc, ("groups", group), f"group {group!r} is empty: list the observations "
                                       "it concatenates", key=True))
        out[group] = tuple(members)
    return out
