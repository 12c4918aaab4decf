"""How long `Suite.check` takes on suites with long lists, at n and 2n entries: a linear check doubles.

Each case is one sensor of tests/models/quadruped.xml with a list of n entries (`element` with a `within` of
n bodies, misses that each get a message, a contact sensor's `data`, MuJoCo sensors refused for their
joint). The columns are seconds at n and 2n and their ratio (about 2 where the check is linear; 4 where it
is quadratic). Loading the YAML is not counted.

    python benchmarks/validate_lists.py [--n 4000]
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import sensorcfg

MODEL = Path(__file__).resolve().parent.parent / "tests" / "models" / "quadruped.xml"

CASES: dict[str, Callable[[int], str]] = {
    "element + within lists": lambda n: f"  s: {{kind: xpos, element: {['body:shin_fl'] * n}, "
                                        f"within: {['body:torso'] * n}}}\n",
    "element misses": lambda n: f"  s: {{kind: xpos, element: {[f'body:b{i}' for i in range(n)]}}}\n",
    "within misses": lambda n: f"  s: {{kind: xpos, element: body:torso, within: {[f'body:b{i}' for i in range(n)]}}}\n",
    "globs": lambda n: f"  s: {{kind: xpos, element: {['site:*'] * n}}}\n",
    "contact data misses": lambda n: f"  s: {{kind: contact, element: body:torso, data: {[f'x{i}' for i in range(n)]}}}\n",
    "refused MuJoCo sensors (n / 20)": lambda n: "".join(f"  s{i}: {{kind: ballquat, element: joint:hip_fl}}\n"
                                                        for i in range(n // 20)),
}


def seconds(text: str) -> float:
    suite = sensorcfg.loads(text)
    start = time.perf_counter()
    suite.check(str(MODEL))
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, default=4000)
    n = parser.parse_args().n
    print(f"{'case':34s} {'n':>8s} {'2n':>8s} {'ratio':>6s}")
    for name, make in CASES.items():
        a, b = (seconds("sensors:\n" + make(k)) for k in (n, 2 * n))
        print(f"{name:34s} {a:8.3f} {b:8.3f} {b / a:6.2f}")


if __name__ == "__main__":
    main()
