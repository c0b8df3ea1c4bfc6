#!/usr/bin/env python3
"""The daemon's rooms include downwards only, and no folder has an include loop.

Usage: include_order_test.py DAEMON_DIR

The rooms, lowest first (docs/daemon.md, "Rooms"): a file in a room may include
its own room's headers and those of any lower room, never a higher one's. Inside
a room, the files' includes form no loop (a.hpp -> b.hpp -> a.hpp), so each
room reads bottom-up too. Exit 0 when both hold, else 1 naming every include
that breaks them.
"""
import pathlib
import re
import sys

ROOMS = ["concurrency", "files", "cli", "log", "toml", "sim", "scene", "store", "uinput", "input", "haptics",
         "simloop", "server", "keeper", "host", "devices", "main"]
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def main() -> int:
    root = pathlib.Path(sys.argv[1])
    rank = {room: i for i, room in enumerate(ROOMS)}
    failures = []
    graph = {}  # within a room: file -> files it includes
    folders = sorted(p.name for p in root.iterdir() if p.is_dir() and any(p.iterdir()))
    for folder in folders:
        if folder not in rank:
            failures.append(f"daemon/{folder}/: a folder that is not a room (add it to ROOMS, in order)")
    for path in sorted(root.rglob("*")):
        if path.suffix not in (".hpp", ".cpp", ".h") or not path.is_file():
            continue
        rel = path.relative_to(root)
        room = rel.parts[0]
        if room not in rank:
            continue
        for target in INCLUDE.findall(path.read_text(errors="replace")):
            other = target.split("/")[0]
            if other not in rank:
                continue  # generated headers (proto), the clients' library
            if rank[other] > rank[room]:
                failures.append(f"daemon/{rel}: includes {target}: {room} is below {other}")
            elif other == room:
                graph.setdefault(str(rel), set()).add(target)
    # A loop inside a room: depth-first search for a back edge.
    state = {}

    def visit(node, stack):
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                loop = stack[stack.index(nxt):] + [nxt]
                failures.append("include loop: " + " -> ".join(loop))
            elif nxt not in state:
                visit(nxt, stack)
        stack.pop()
        state[node] = 2

    for node in sorted(graph):
        if node not in state:
            visit(node, [])
    for f in failures:
        print(f)
    if not failures:
        print(f"{len(ROOMS)} rooms: every include goes down or stays in its room; no include loop in a folder")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
