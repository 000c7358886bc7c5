#!/usr/bin/env python3
"""Fails when the modules of a crate import each other in a cycle.

For every crate under workflow/, services/, tests/ and tools/, builds the graph "module A mentions
`crate::B…` or `super::B…` (outside comments and `#[cfg(test)]` code)" over its top-level modules and, inside
each directory module, over its submodules, and prints every strongly connected component with more than one
module. Exit code 1 when there is one. Usage: `python3 .ci/cycles.py [CRATE_SRC_DIR...]`.
"""
import os
import re
import sys


def module_files(src):
    """Module path ('a::b') -> file, for every .rs file below src."""
    mods = {}
    for root, _, files in os.walk(src):
        for name in files:
            if not name.endswith(".rs"):
                continue
            parts = os.path.relpath(os.path.join(root, name), src)[:-3].split(os.sep)
            if parts[-1] == "mod":
                parts = parts[:-1]
            if parts in (["lib"], ["main"]):
                parts = []
            mods["::".join(parts)] = os.path.join(root, name)
    return mods


def code_of(path):
    """The file's text without line comments and without anything from the first `#[cfg(test)]` on."""
    text = open(path, encoding="utf-8").read()
    cut = text.find("#[cfg(test)]")
    if cut >= 0:
        text = text[:cut]
    return "\n".join(line.split("//", 1)[0] for line in text.split("\n"))


def expand(text, start):
    """The paths of the use-tree starting at text[start] (after `crate::` or `super::`)."""
    m = re.compile(r"\s*((?:\w+\s*::\s*)*)(\{|\w+|\*)").match(text, start)
    if not m:
        return []
    prefix = [p.strip() for p in m.group(1).split("::") if p.strip()]
    head = m.group(2)
    if head != "{":
        return [prefix + ([head] if head != "*" else [])]
    depth, i, items, item_start = 1, m.end(), [], m.end()
    while i < len(text) and depth:
        c = text[i]
        if c == "{":
            depth += 1
        elif c == "}":
            depth -= 1
        if (c == "," and depth == 1) or depth == 0:
            items.append(text[item_start:i])
            item_start = i + 1
        i += 1
    paths = []
    for item in items:
        item = item.strip()
        if item and item != "self":
            paths += [prefix + p for p in expand(item, 0)]
        elif item == "self":
            paths.append(prefix)
    return paths


def graph(src, depth):
    mods = module_files(src)
    g = {}
    for module, path in mods.items():
        parts = module.split("::") if module else []
        if parts and parts[-1] in ("tests", "test"):
            continue
        key = "::".join(parts[:depth])
        code = code_of(path)
        deps = set()
        for m in re.finditer(r"\b(crate|super)\s*::", code):
            base = [] if m.group(1) == "crate" else parts[:-1]
            for target in expand(code, m.end()):
                full = base + target
                for k in range(len(full), 0, -1):
                    if "::".join(full[:k]) in mods:
                        deps.add("::".join(full[:k][:depth]))
                        break
        deps.discard(key)
        g.setdefault(key, set()).update(d for d in deps if d and (depth == 1 or d.count("::") == key.count("::")))
    return g


def components(g):
    """Strongly connected components of more than one node (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(g.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def main(args):
    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
    srcs = args or sorted(
        os.path.join(root, group, name, "src")
        for group in ("workflow", "services", "tests", "tools")
        for name in os.listdir(os.path.join(root, group))
        if os.path.isdir(os.path.join(root, group, name, "src"))
    )
    found = 0
    for src in srcs:
        seen = set()
        for depth in (1, 2):
            g = graph(src, depth)
            for comp in components(g):
                if tuple(comp) in seen:
                    continue
                seen.add(tuple(comp))
                found += 1
                print(f"{os.path.relpath(src, root)}: import cycle among {', '.join(comp)}")
                for v in comp:
                    print(f"    {v} -> {', '.join(sorted(w for w in g[v] if w in comp))}")
    if found:
        print(f"{found} import cycle(s); move the shared items to a module the others import", file=sys.stderr)
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
