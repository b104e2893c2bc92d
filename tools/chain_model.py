#!/usr/bin/env python3
"""Write the model file of a chain of K planar pendula (the twin of `holosym simulate
--system chain --links K`): unit masses and rod lengths, g = 1 along -y, every link at
0.5 rad from the downward vertical and at rest.

Usage: python3 tools/chain_model.py K [OUTPUT]   (default: standard output)

The model lists x1 y1 ... xK yK and their momenta, H = sum |p_k|^2/(2 m) + g m sum y_k and
the K rod constraints; the initial positions are the partial sums of the rods. Used by
`make bench-models` for the speed table of docs/performance.md and by the tests.
"""
import sys


def chain_model(links, angle="0.5"):
    k = range(1, links + 1)
    out = [f"# A chain of {links} planar pendula (tools/chain_model.py {links}).",
           f"parameters  m = 1, l = 1, g = 1, theta = {angle}",
           "coordinates " + " ".join(f"x{i} y{i}" for i in k) + "",
           "momenta     " + " ".join(f"px{i} py{i}" for i in k)]
    kinetic = " + ".join(f"px{i}^2 + py{i}^2" for i in k)
    potential = " + ".join(f"y{i}" for i in k)
    out.append(f"hamiltonian ({kinetic})/(2*m) + g*m*({potential})")
    out.append("constraint  x1^2 + y1^2 - l^2")
    for i in range(2, links + 1):
        out.append(f"constraint  (x{i} - x{i-1})^2 + (y{i} - y{i-1})^2 - l^2")
    out.append("let         dx = l*sin(theta), dy = -l*cos(theta)")
    out.append("let         X1 = dx, Y1 = dy")
    for i in range(2, links + 1):
        out.append(f"let         X{i} = X{i-1} + dx, Y{i} = Y{i-1} + dy")
    out.append("initial     " + ", ".join(f"x{i} = X{i}, y{i} = Y{i}" for i in k))
    # Long statements wrapped with continuation lines.
    wrapped = []
    for line in out:
        while len(line) > 96:
            cut = line.rfind(" ", 0, 94)
            wrapped.append(line[:cut] + " \\")
            line = "            " + line[cut + 1:]
        wrapped.append(line)
    return "\n".join(wrapped) + "\n"


def main():
    if len(sys.argv) not in (2, 3) or not sys.argv[1].isdigit() or int(sys.argv[1]) < 1:
        sys.exit("usage: chain_model.py K [OUTPUT]  (K >= 1 links)")
    text = chain_model(int(sys.argv[1]))
    if len(sys.argv) == 3:
        with open(sys.argv[2], "w") as f:
            f.write(text)
    else:
        sys.stdout.write(text)


if __name__ == "__main__":
    main()
