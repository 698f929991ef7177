#!/usr/bin/env python3
"""Fails on a circle of imports between the core's modules, so that they stay in layers: each
imports only modules below it (ARCHITECTURE.md, "Crates and modules").

A file imports another when its code (comments and strings removed) names it through a path:
`crate::a::b`, `super::x`, `self::x` or a declared child module's `child::x`, in a `use` tree or
in an expression. A path is followed down the module folders to the file that holds its item,
and through `use` re-exports to the file that defines it (`crate::Triangle` is triangle.rs, not
lib.rs). Declaring a module (`mod x;`) is not an import.

The rule, at every level of core/src: the submodules of a module, each taken with every file
below it, import one another one way only. The module's own file (lib.rs, a mod.rs) may import
its submodules and be imported by them: it declares them and holds what they share. So
`far` -> `triangle` -> `far` fails, and so does `format::validate` -> `format::wide` ->
`format::validate`; `format::wide` -> `format` (its mod.rs) -> `format::wide` does not.

    python3 scripts/core-imports.py         # exit 1 and each circle with the imports closing it
    python3 scripts/core-imports.py --graph # every file and the files it imports
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SRC = os.path.join(ROOT, "core", "src")


def strip(text):
    """The code without comments, strings and character literals (kept as blanks, lines kept)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    out.append("\n" if text[i] == "\n" else "")
                    i += 1
        elif c == "r" and re.match(r'r#*"', text[i:]) and not re.match(r"\w", text[i - 1 : i]):
            hashes = re.match(r"r(#*)\"", text[i:]).group(1)
            end = text.find('"' + hashes, i + 2 + len(hashes))
            out.append('""' + "\n" * text.count("\n", i, end))
            i = end + 1 + len(hashes)
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            out.append('""' + "\n" * text.count("\n", i, j))
            i = j + 1
        elif c == "'" and re.match(r"'(\\.|[^\\'])'", text[i:]):
            i += len(re.match(r"'(\\[^']*|[^\\'])'", text[i:]).group(0))
            out.append("' '")
        else:
            out.append(c)
            i += 1
    return "".join(out)


def module_of(path):
    """The module of a file under core/src: a/b.rs -> ("a", "b"), a/mod.rs -> ("a",), lib.rs -> ().
    """
    rel = os.path.relpath(path, SRC)[: -len(".rs")].split(os.sep)
    if rel[-1] in ("mod", "lib"):
        rel = rel[:-1]
    return tuple(rel)


def file_of(module):
    """The file of a module path, or None."""
    if not module:
        return os.path.join(SRC, "lib.rs")
    base = os.path.join(SRC, *module)
    for f in (base + ".rs", os.path.join(base, "mod.rs")):
        if os.path.isfile(f):
            return f
    return None


def use_paths(tree, prefix=()):
    """The full paths (and the names they bind) of a `use` tree: `a::{b, c::{d as e}, self}`."""
    tree = tree.strip()
    m = re.match(r"^((?:[\w$]+\s*::\s*)*)\{(.*)\}$", tree, re.S)
    if m:
        head = tuple(s.strip() for s in m.group(1).split("::") if s.strip())
        body, depth, part, parts = m.group(2), 0, "", []
        for ch in body:
            if ch == "," and depth == 0:
                parts.append(part)
                part = ""
                continue
            depth += (ch == "{") - (ch == "}")
            part += ch
        parts.append(part)
        for p in parts:
            if p.strip():
                yield from use_paths(p, prefix + head)
        return
    m = re.match(r"^(.*?)(?:\s+as\s+(\w+))?$", tree, re.S)
    segs = tuple(s.strip() for s in m.group(1).split("::"))
    if segs == ("self",):
        path = prefix
    else:
        path = prefix + segs
    name = m.group(2) or (path[-1] if path else None)
    yield path, name


class Crate:
    def __init__(self):
        self.files = []
        for d, _, names in os.walk(SRC):
            self.files += [os.path.join(d, f) for f in names if f.endswith(".rs")]
        self.code = {f: strip(open(f, encoding="utf-8").read()) for f in self.files}
        # Each module's `use` items: bound name -> full path (absolute, from the crate root).
        self.uses = {}
        self.children = {}
        self.inline = {}
        for f in self.files:
            code = self.code[f]
            self.children[f] = set(re.findall(r"\bmod\s+(\w+)\s*;", code))
            self.inline[f] = []
            for m in re.finditer(r"\bmod\s+(\w+)\s*\{", code):
                depth, i = 1, m.end()
                while depth and i < len(code):
                    depth += (code[i] == "{") - (code[i] == "}")
                    i += 1
                self.inline[f].append((m.start(), i, m.group(1)))
        for f in self.files:
            binds = {}
            for m in re.finditer(r"\buse\s+([^;]*);", self.code[f]):
                if self.scope(f, m.start()) != module_of(f):
                    continue  # an inline module's imports are not the file's names
                for path, name in use_paths(m.group(1)):
                    absolute = self.absolute(module_of(f), f, path)
                    if absolute is not None and name and name not in ("*", "_"):
                        binds[name] = absolute
            self.uses[f] = binds

    def absolute(self, mod, f, path):
        """A path as written in module `mod` (file f), from the crate root; None if external."""
        if not path:
            return None
        head = path[0]
        if head in ("crate", "$crate"):
            return path[1:]
        if head in ("self", "super"):
            base = list(mod)
            while path and path[0] in ("self", "super"):
                if path[0] == "super":
                    base.pop()
                path = path[1:]
            return tuple(base) + path
        if head in self.children[f]:
            return tuple(mod) + path
        return None

    def resolve(self, path, seen=0):
        """The file that holds the item at an absolute path, following `pub use` re-exports."""
        mod = ()
        for i, seg in enumerate(path):
            if file_of(mod + (seg,)):
                mod = mod + (seg,)
                continue
            # Not a module: an item of `mod`, or a name that `mod` imports (a re-export).
            f = file_of(mod)
            target = self.uses[f].get(seg)
            if target is not None and seen < 10 and target != mod + (seg,):
                return self.resolve(target + path[i + 1 :], seen + 1)
            break
        return file_of(mod)

    def scope(self, f, at):
        """The module at offset `at` of file f: the file's, or an inline `mod x { ... }` in it."""
        mod = module_of(f)
        for start, end, name in self.inline[f]:
            if start <= at < end:
                mod = mod + (name,)
        return mod

    def imports(self, f):
        """The files f names, each with the first line that names it."""
        code, out = self.code[f], {}
        found = []
        for m in re.finditer(r"\buse\s+([^;]*);", code):
            line = code.count("\n", 0, m.start()) + 1
            for path, _ in use_paths(m.group(1)):
                found.append((m.start(), line, path))
        rest = re.sub(r"\buse\s+[^;]*;", lambda m: re.sub(r"[^\n]", " ", m.group(0)), code)
        heads = "|".join([r"\$?crate", "super", "self"] + sorted(self.children[f]))
        for m in re.finditer(r"(?<![\w:$])((?:" + heads + r")(?:\s*::\s*\w+)+)", rest):
            line = rest.count("\n", 0, m.start()) + 1
            found.append((m.start(), line, tuple(s.strip() for s in m.group(1).split("::"))))
        for at, line, path in found:
            absolute = self.absolute(self.scope(f, at), f, path)
            if absolute is None:
                continue
            target = self.resolve(absolute)
            if target and target != f:
                out[target] = min(line, out.get(target, line))
        return out


def components(graph):
    """Tarjan's strongly connected components, iteratively."""
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(graph[w]))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    comps.append(sorted(comp))
    return comps


def main():
    crate = Crate()
    graph = {f: crate.imports(f) for f in crate.files}
    rel = lambda f: os.path.relpath(f, ROOT)
    if "--graph" in sys.argv:
        for f in sorted(graph):
            print(rel(f), "->", " ".join(sorted(rel(t) for t in graph[f])))
        return 0
    # At each level, the submodules of a module, each with all the files below it, must import
    # one another one way only. The module's own file (lib.rs, mod.rs) may name its submodules
    # and be named by them: it declares them and holds what they share.
    circles = 0
    for parent in sorted(crate.files):
        under = {}
        for f in crate.files:
            mod, top = module_of(f), module_of(parent)
            if f != parent and mod[: len(top)] == top and len(mod) > len(top):
                under[f] = mod[len(top)]
        children = set(under.values()) & crate.children[parent]
        level = {c: set() for c in children}
        for f, c in under.items():
            for t in graph[f]:
                if t in under and under[t] != c and under[t] in children:
                    level[c].add(under[t])
        for comp in components(level):
            if len(comp) < 2:
                continue
            circles += 1
            own = parent.endswith(("mod.rs", "lib.rs"))
            where = rel(os.path.dirname(parent)) if own else rel(parent)[: -len(".rs")]
            print(f"circle between the modules {', '.join(comp)} of {where}:")
            for f, c in sorted(under.items()):
                for t, line in sorted(graph[f].items()):
                    if c in comp and under.get(t) in comp and under[t] != c:
                        print(f"  {rel(f)}:{line} imports {rel(t)}")
    if circles:
        print(
            f"core-imports: {circles} circles of imports in core/src; move what the modules share"
            " down into the lower one, or into their parent's own file",
            file=sys.stderr,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
