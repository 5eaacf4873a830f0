#!/usr/bin/env python3
"""The house check (docs/architecture.md): run from the repository root; exits 1 naming what
is wrong.

- no import circle: within every module of the library, and within the binary's `cli`, the
  children depend on each other one way (a -> b when code in a names something in b by a
  `crate::`, `super::` or `self::` path; unit tests left out);
- the layer order of docs/architecture.md: a top-level module of the library uses only the
  modules of the layers below its own ([`LAYERS`], top first), none beside it;
- no file in src/ over 600 lines;
- the library (everything in src/ but main.rs and cli/) uses none of clap, indicatif,
  signal-hook, anyhow.
"""
import os
import re
import sys

MAX_LINES = 600
# The library's layers, top first (docs/architecture.md, "Layers").
LAYERS = [
    ["serve"],
    ["pass", "alarm", "fleet"],
    ["report"],
    ["diagnose"],
    ["audit", "train", "history", "site"],
    ["identify"],
    ["bank"],
    ["model", "atomic", "stopwatch"],
]
BINARY_ONLY = ("clap", "indicatif", "signal_hook", "anyhow")


EDGES = {}


def layer_breaches():
    """The uses of the library's top-level modules against [`LAYERS`], as messages (after
    `circles("src", "lib.rs")` has read the edges)."""
    rank = {m: i for i, layer in enumerate(LAYERS) for m in layer}
    out = []
    top = {}
    for m, ts in EDGES["lib.rs"].items():
        if not m:
            continue
        for t in ts:
            if t and t[0] != m[0]:
                top.setdefault(m[0], set()).add(t[0])
    for a in sorted({m[0] for m in EDGES["lib.rs"] if m}):
        if a not in rank:
            out.append(f"module {a} is in none of the documented layers (LAYERS)")
    for a, ts in sorted(top.items()):
        for b in sorted(ts):
            if a in rank and b in rank and rank[b] <= rank[a]:
                where = "beside it" if rank[b] == rank[a] else "above it"
                out.append(f"layer order: {a} uses {b}, {where} (docs/architecture.md)")
    return out


def circles(root, crate_root):
    """The import circles among sibling modules of the crate at `root` (`lib.rs` or
    `main.rs`), as (parent, [children])."""
    
    def modpath(f):
        rel = os.path.relpath(f, root)[:-3].split(os.sep)
        if rel[-1] in ('mod',): rel = rel[:-1]
        if rel == [crate_root[:-3]]: return []
        return rel
    
    files = []
    for d, _, fs in os.walk(root):
        for f in fs:
            if f.endswith('.rs'): files.append(os.path.join(d, f))
    mods = {tuple(modpath(f)): f for f in files}
    if crate_root == 'main.rs':
        mods = {k: v for k, v in mods.items() if k == () or k[0] == 'cli'}
    else:
        mods = {k: v for k, v in mods.items() if not (k and k[0] in ('cli', 'main'))}
    
    def strip_tests(s):
        i = s.find('#[cfg(test)]\nmod tests')
        return s if i < 0 else s[:i]
    
    def resolve(cur, path):
        parts = path.split('::')
        if parts[0] == 'crate': base = []; parts = parts[1:]
        elif parts[0] == 'super':
            base = list(cur)
            while parts and parts[0] == 'super':
                base = base[:-1]; parts = parts[1:]
        elif parts[0] == 'self': base = list(cur); parts = parts[1:]
        else:
            # a child of the current module, or of its parent if imported by a use
            base = list(cur)
        full = base + parts
        best = None
        for n in range(len(full), -1, -1):
            if tuple(full[:n]) in mods:
                best = tuple(full[:n]); break
        return best
    
    edges = {}
    pat = re.compile(r'\b((?:crate|super|self)(?:::[A-Za-z_][A-Za-z0-9_]*)+)')
    usepat = re.compile(r'use\s+((?:crate|super|self)::[^;]+);', re.S)
    for m, f in mods.items():
        s = strip_tests(open(f).read())
        s = re.sub(r'//.*', '', s)
        targets = set()
        for u in usepat.findall(s):
            # expand one level of braces
            u = re.sub(r'\s+', '', u)
            mm = re.match(r'(.*?)::\{(.*)\}$', u)
            if mm:
                pre = mm.group(1)
                for item in re.split(r',(?![^{]*\})', mm.group(2)):
                    item = item.split('{')[0].rstrip(':')
                    if item: targets.add(resolve(m, pre + '::' + item))
            else: targets.add(resolve(m, u.split(' as ')[0]))
        for p in pat.findall(s): targets.add(resolve(m, p))
        # `mod x;` children used by bare paths are the module's own: not sibling edges
        edges[m] = {t for t in targets if t is not None and t != m}
    
    EDGES[crate_root] = edges
    # sibling graphs
    circles = []
    parents = {k[:-1] for k in mods if k}
    for par in sorted(parents):
        kids = sorted({k[len(par)] for k in mods if len(k) > len(par) and k[:len(par)] == par})
        g = {a: set() for a in kids}
        for m, ts in edges.items():
            if len(m) > len(par) and m[:len(par)] == par:
                a = m[len(par)]
                for t in ts:
                    if len(t) > len(par) and t[:len(par)] == par and t[len(par)] != a:
                        g[a].add(t[len(par)])
        # Tarjan
        index = {}; low = {}; st = []; on = set(); out = []; c = [0]
        def sc(v):
            index[v] = low[v] = c[0]; c[0] += 1; st.append(v); on.add(v)
            for w in g[v]:
                if w not in index: sc(w); low[v] = min(low[v], low[w])
                elif w in on: low[v] = min(low[v], index[w])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = st.pop(); on.discard(w); comp.append(w)
                    if w == v: break
                if len(comp) > 1: out.append(comp)
        for v in kids:
            if v not in index: sc(v)
        for comp in out:
            circles.append(('::'.join(par) or '(crate)', sorted(comp)))
    return circles
    

def main():
    bad = 0
    for crate_root in ("lib.rs", "main.rs"):
        for par, comp in circles("src", crate_root):
            print(f"import circle in {par}: {' <-> '.join(comp)}")
            bad += 1
    for msg in layer_breaches():
        print(msg)
        bad += 1
    for d, _, fs in os.walk("src"):
        for f in fs:
            if not f.endswith(".rs"):
                continue
            p = os.path.join(d, f)
            n = sum(1 for _ in open(p))
            if n > MAX_LINES:
                print(f"{p}: {n} lines, over {MAX_LINES}")
                bad += 1
            if p == os.path.join("src", "main.rs") or p.startswith(os.path.join("src", "cli")):
                continue
            text = open(p).read()
            for dep in BINARY_ONLY:
                if re.search(r"\b%s::" % dep, text):
                    print(f"{p}: uses {dep}, which only the binary may")
                    bad += 1
    if bad:
        print(f"house check: {bad} problem(s)")
        sys.exit(1)
    print("house check: no import circle, the layers in order, no file in src/ over 600 lines, the library free of the binary's crates")


if __name__ == "__main__":
    main()
