#!/usr/bin/env python3
"""Implicitization cases for bench/algebra-implicit.sh, and the exact
comparison of two implicit equations.

  implicit.py cases DIR       writes DIR/NAME.sing (Singular's eliminate) and
                              prints one line per case: NAME|X|Y|Z
  implicit.py same A B        exit 0 when the polynomials in files A and B
                              (isoray's and Singular's printed forms, in
                              x, y, z) are equal up to a rational factor
  implicit.py vanishes A X Y Z
                              exit 0 when the polynomial in file A vanishes,
                              in exact rational arithmetic, at the images of
                              eight random rational points (s, t) (where no
                              peer gives a reference: a Schwartz–Zippel
                              check, not a proof)

The cases: the surfaces documented in docs/ALGEBRA.md and issue 18, then ten
random rational parametrizations (fixed seed) of degrees 1 to 3 in s, t
(numerators of that degree; with cubic numerators, two terms and linear
denominators) with a different denominator in each coordinate.
"""
import random
import re
import sys
from fractions import Fraction

DOCUMENTED = [
    ("sphere", "2*s/(s^2+t^2+1)", "2*t/(s^2+t^2+1)", "(s^2+t^2-1)/(s^2+t^2+1)"),
    ("issue-18", "(s+t^2)/(t+1)", "(s^2-t)/(s+2)", "(s*t)/(s-t+1)"),
    ("plane", "s+t", "s", "t"),
]


def rand_poly(rng, deg, terms, constant):
    """A polynomial in s, t of total degree `deg` (at least one term of that
    degree), with `terms` terms and coefficients in -3..3 (no zeros)."""
    monos = [(a, d - a) for d in range(deg + 1) for a in range(d + 1)]
    top = [m for m in monos if sum(m) == deg]
    chosen = {rng.choice(top)}
    if constant:
        chosen.add((0, 0))
    while len(chosen) < min(terms, len(monos)):
        chosen.add(rng.choice(monos))
    out = []
    for a, b in sorted(chosen, reverse=True):
        c = rng.choice([-3, -2, -1, 1, 2, 3])
        mono = "*".join(v if e == 1 else f"{v}^{e}" for v, e in (("s", a), ("t", b)) if e)
        out.append(f"{c}*{mono}" if mono else str(c))
    return "+".join(out).replace("+-", "-")


def random_cases(count=10, seed=18):
    rng = random.Random(seed)
    cases = []
    for k in range(count):
        deg = 1 + k % 3
        coords = []
        dens = set()
        for _ in range(3):
            # Cubic numerators get two terms (three give implicit equations
            # of degree 25 that no peer finishes in minutes).
            num = rand_poly(rng, deg, 3 if deg < 3 else 2, False)
            while True:
                # Denominators of degree 1 to deg (1 for cubic numerators),
                # with a constant term, all different.
                den = rand_poly(rng, 1 if deg == 3 else rng.randint(1, deg), 2, True)
                if den not in dens:
                    dens.add(den)
                    break
            coords.append(f"({num})/({den})")
        cases.append((f"random-{k + 1}-deg{deg}", *coords))
    return cases


def split(expr):
    m = re.fullmatch(r"\((.*)\)/\((.*)\)", expr)
    if m:
        return m.group(1), m.group(2)
    m = re.fullmatch(r"(.*)/\((.*)\)", expr)
    if m:
        return m.group(1), m.group(2)
    return expr, "1"


def singular_script(x, y, z):
    (px, qx), (py, qy), (pz, qz) = split(x), split(y), split(z)
    return (
        "ring r = 0, (s,t,w,x,y,z), dp;\nshort = 0;\n"
        f"ideal I = ({qx})*x - ({px}), ({qy})*y - ({py}), ({qz})*z - ({pz}), "
        f"1 - w*({qx})*({qy})*({qz});\n"
        "ideal E = eliminate(I, s*t*w);\nprint(E[1]);\nquit;\n"
    )


def parse(text):
    """A polynomial in x, y, z as {(a, b, c): Fraction}."""
    text = re.sub(r"\s+", "", text)
    out = {}
    for sign, body in re.findall(r"([+-]?)([^+-]+)", text):
        coef = Fraction(1)
        exps = [0, 0, 0]
        for f in body.split("*"):
            if re.fullmatch(r"\d+(/\d+)?", f):
                coef *= Fraction(f)
                continue
            m = re.fullmatch(r"([xyz])(?:\^(\d+))?", f)
            if not m:
                raise ValueError(f"cannot read factor {f!r}")
            exps["xyz".index(m.group(1))] += int(m.group(2) or 1)
        if sign == "-":
            coef = -coef
        key = tuple(exps)
        out[key] = out.get(key, 0) + coef
    return {k: v for k, v in out.items() if v}


def same(a, b):
    pa, pb = parse(open(a).read()), parse(open(b).read())
    if not pa or set(pa) != set(pb):
        return False
    k = max(pa)
    r = pa[k] / pb[k]
    return all(pa[m] == r * pb[m] for m in pa)


def vanishes(path, coords, points=8, seed=7):
    p = parse(open(path).read())
    if not p:
        return False
    rng = random.Random(seed)
    done = 0
    while done < points:
        env = {"s": Fraction(rng.randint(-50, 50), rng.randint(1, 50)),
               "t": Fraction(rng.randint(-50, 50), rng.randint(1, 50))}
        try:
            xyz = [eval(c.replace("^", "**"), {"__builtins__": {}}, env) for c in coords]
        except ZeroDivisionError:
            continue
        value = sum(c * xyz[0] ** a * xyz[1] ** b * xyz[2] ** e for (a, b, e), c in p.items())
        if value != 0:
            return False
        done += 1
    return True


def main():
    if sys.argv[1] == "cases":
        for name, x, y, z in DOCUMENTED + random_cases():
            with open(f"{sys.argv[2]}/{name}.sing", "w") as f:
                f.write(singular_script(x, y, z))
            print(f"{name}|{x}|{y}|{z}")
    elif sys.argv[1] == "vanishes":
        sys.exit(0 if vanishes(sys.argv[2], sys.argv[3:6]) else 1)
    elif sys.argv[1] == "same":
        sys.exit(0 if same(sys.argv[2], sys.argv[3]) else 1)
    else:
        sys.exit("implicit.py: cases DIR | same A B | vanishes A X Y Z")


if __name__ == "__main__":
    main()
