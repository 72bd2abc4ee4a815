#!/usr/bin/env python3
"""Writes a NACA 4-digit aerofoil as a Selig-format points file (a title line, then "x y" pairs from
the trailing edge over the upper surface to the leading edge and back along the lower surface).

  naca4.py 0012 cases/geometry/naca0012.dat [--points-per-surface 81]

Unit chord, leading edge at (0, 0). The closed-trailing-edge thickness coefficient (-0.1036
instead of -0.1015) makes the trailing edge a point, as a solid obstacle needs. Cosine spacing
clusters points at both edges. No third-party modules: it runs under any python3.
"""
import argparse
import math
import os


def naca4(digits, n):
    m, p, t = int(digits[0]) / 100, int(digits[1]) / 10, int(digits[2:]) / 100
    upper, lower = [], []
    for k in range(n):
        x = 0.5 * (1 - math.cos(math.pi * k / (n - 1)))
        yt = 5 * t * (0.2969 * math.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3 - 0.1036 * x**4)
        if m > 0 and x < p:
            yc, dyc = m / p**2 * (2 * p * x - x * x), 2 * m / p**2 * (p - x)
        elif m > 0:
            yc, dyc = m / (1 - p) ** 2 * (1 - 2 * p + 2 * p * x - x * x), 2 * m / (1 - p) ** 2 * (p - x)
        else:
            yc, dyc = 0.0, 0.0
        theta = math.atan(dyc)
        upper.append((x - yt * math.sin(theta), yc + yt * math.cos(theta)))
        lower.append((x + yt * math.sin(theta), yc - yt * math.cos(theta)))
    # Trailing edge -> upper surface -> leading edge -> lower surface -> trailing edge.
    return upper[::-1] + lower[1:]


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("digits", help="four digits, e.g. 0012")
    parser.add_argument("output")
    parser.add_argument("--points-per-surface", type=int, default=81)
    args = parser.parse_args()
    if len(args.digits) != 4 or not args.digits.isdigit():
        parser.error("digits: expected four digits such as 0012")
    points = naca4(args.digits, args.points_per_surface)
    tmp = args.output + ".tmp"
    with open(tmp, "w") as f:
        f.write(f"NACA {args.digits}\n")
        for x, y in points:
            f.write(f"{x:.7f} {y: .7f}\n")
    os.replace(tmp, args.output)


if __name__ == "__main__":
    main()
