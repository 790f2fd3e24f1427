#!/usr/bin/env python3
"""Import cycles between the crate's top-level modules (src/X.rs or src/X/), read from the
`crate::X` paths in each file's code (use lines and inline paths; comments are skipped).
Prints every arrow module -> module and each cycle; exits 1 if there is a cycle.

    python3 tools/import_cycles.py [SRC_DIR]
"""
import re
import sys
from pathlib import Path


def module_of(path: Path, src: Path) -> str:
    rel = path.relative_to(src)
    return rel.parts[0].removesuffix(".rs")


def arrows(src: Path) -> dict:
    graph = {}
    for path in sorted(src.rglob("*.rs")):
        here = module_of(path, src)
        if here in ("main", "lib"):
            continue
        code = "\n".join(line.split("//")[0] for line in path.read_text().splitlines())
        targets = set(re.findall(r"\bcrate::([a-z_][a-z0-9_]*)", code))
        # `use crate::{a::x, b::y}` names modules inside the braces.
        for group in re.findall(r"\bcrate::\{([^}]*)\}", code):
            targets.update(re.findall(r"(?:^|,)\s*([a-z_][a-z0-9_]*)", group))
        graph.setdefault(here, set()).update(t for t in targets if t != here)
    return graph


def cycles(graph: dict) -> list:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def main() -> int:
    src = Path(sys.argv[1] if len(sys.argv) > 1 else "src")
    graph = arrows(src)
    for module in sorted(graph):
        print(f"{module} -> {', '.join(sorted(graph[module])) or '(nothing)'}")
    found = cycles(graph)
    for component in found:
        print("cycle:", " <-> ".join(component))
    print(f"{len(found)} cycle(s) among {len(graph)} modules")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
