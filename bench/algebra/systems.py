#!/usr/bin/env python3
"""Benchmark systems for bench/algebra-peers.sh, written out expanded (like
terms combined: msolve misreads uncombined input) for each peer.

  systems.py NAME FIELD DIR   writes DIR/NAME.{in,ms,sing,giac}

NAME: katsura-N (N+1 variables x0..xN), cyclic-N (x1..xN), or one of the
systems from the literature below (PoSSo / SymbolicData definitions):
eco-N (Morgan's economics model, x1..xN), noon-N (Noonburg's neural
network, x1..xN, coefficients scaled to integers), reimer-N (Reimer,
x1..xN). FIELD: 0 (the rationals) or a prime.
"""
import sys
from collections import defaultdict


def poly_mul(a, b):
    out = defaultdict(int)
    for ma, ca in a.items():
        for mb, cb in b.items():
            out[tuple(x + y for x, y in zip(ma, mb))] += ca * cb
    return {m: c for m, c in out.items() if c}


def poly_add(a, b, s=1):
    out = defaultdict(int, a)
    for m, c in b.items():
        out[m] += s * c
    return {m: c for m, c in out.items() if c}


def var(i, n):
    e = [0] * n
    e[i] = 1
    return {tuple(e): 1}


def const(c, n):
    return {tuple([0] * n): c} if c else {}


def katsura(n):
    k = n + 1
    names = [f"x{i}" for i in range(k)]
    x = lambda i: var(abs(i), k) if abs(i) <= n else {}
    polys = []
    for m in range(n):
        p = {}
        for l in range(-n, n + 1):
            p = poly_add(p, poly_mul(x(l), x(m - l)))
        polys.append(poly_add(p, x(m), -1))
    s = {}
    for l in range(-n, n + 1):
        s = poly_add(s, x(l))
    polys.append(poly_add(s, const(1, k), -1))
    return names, polys


def cyclic(n):
    names = [f"x{i}" for i in range(1, n + 1)]
    polys = []
    for d in range(1, n):
        p = {}
        for i in range(n):
            t = const(1, n)
            for j in range(d):
                t = poly_mul(t, var((i + j) % n, n))
            p = poly_add(p, t)
        polys.append(p)
    t = const(1, n)
    for i in range(n):
        t = poly_mul(t, var(i, n))
    polys.append(poly_add(t, const(1, n), -1))
    return names, polys


def eco(n):
    """(x_k + sum_{i=1}^{n-k-1} x_i x_{i+k}) x_n - k for k = 1..n-1, and
    x_1 + ... + x_{n-1} + 1."""
    names = [f"x{i}" for i in range(1, n + 1)]
    x = lambda i: var(i - 1, n)
    polys = []
    for k in range(1, n):
        p = x(k)
        for i in range(1, n - k):
            p = poly_add(p, poly_mul(x(i), x(i + k)))
        polys.append(poly_add(poly_mul(p, x(n)), const(k, n), -1))
    s = const(1, n)
    for i in range(1, n):
        s = poly_add(s, x(i))
    polys.append(s)
    return names, polys


def noon(n):
    """10 x_i (sum_{j != i} x_j^2) - 11 x_i + 10 for i = 1..n."""
    names = [f"x{i}" for i in range(1, n + 1)]
    x = lambda i: var(i - 1, n)
    polys = []
    for i in range(1, n + 1):
        s = {}
        for j in range(1, n + 1):
            if j != i:
                s = poly_add(s, poly_mul(x(j), x(j)))
        p = poly_mul(poly_mul(const(10, n), x(i)), s)
        p = poly_add(p, poly_mul(const(11, n), x(i)), -1)
        polys.append(poly_add(p, const(10, n)))
    return names, polys


def reimer(n):
    """2 sum_j (-1)^(j+1) x_j^(k+1) - 1 for k = 1..n."""
    names = [f"x{i}" for i in range(1, n + 1)]
    polys = []
    for k in range(1, n + 1):
        p = const(-1, n)
        for j in range(1, n + 1):
            t = const(2 if j % 2 == 1 else -2, n)
            for _ in range(k + 1):
                t = poly_mul(t, var(j - 1, n))
            p = poly_add(p, t)
        polys.append(p)
    return names, polys


def text(p, names):
    def term(m, c):
        mono = "*".join(f"{v}^{e}" if e > 1 else v for v, e in zip(names, m) if e)
        if not mono:
            return str(c)
        if c == 1:
            return mono
        if c == -1:
            return "-" + mono
        return f"{c}*{mono}"

    # grevlex-ish order for readability: by degree, descending
    items = sorted(p.items(), key=lambda mc: (-sum(mc[0]), [-e for e in mc[0]]))
    s = "+".join(term(m, c) for m, c in items)
    return s.replace("+-", "-") or "0"


def main():
    name, field, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    kind, _, n = name.partition("-")
    if kind == "katsura":
        names, polys = katsura(int(n))
    elif kind == "cyclic":
        names, polys = cyclic(int(n))
    elif kind in ("eco", "noon", "reimer"):
        names, polys = {"eco": eco, "noon": noon, "reimer": reimer}[kind](int(n))
    else:
        sys.exit(f"systems.py: unknown system {name}")
    ps = [text(p, names) for p in polys]
    base = f"{out}/{name}-{field}"
    with open(base + ".in", "w") as f:
        f.write("\n".join(ps) + "\n")
    with open(base + ".ms", "w") as f:
        f.write(",".join(names) + "\n" + str(field) + "\n" + ",\n".join(ps) + "\n")
    with open(base + ".sing", "w") as f:
        f.write(
            f"option(redSB); option(redTail);\nring r = {field}, ({','.join(names)}), dp;\n"
            f"ideal I = {', '.join(ps)};\nideal G = std(I);\n\"basis: \" + string(size(G));\nquit;\n"
        )
    with open(base + ".giac", "w") as f:
        mod = f" % {field}" if field else ""
        gens = ", ".join(f"({p}){mod}" for p in ps)
        f.write(f"G := gbasis([{gens}], [{', '.join(names)}], revlex):;\nprint(\"basis: \" + size(G));\n")
    print(",".join(names))


if __name__ == "__main__":
    main()
