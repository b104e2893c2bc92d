#!/usr/bin/env python3
"""Check that the examples print what their header comments say, and that the README
shows the quick-start example and its output as they are.

Usage: tools/check_examples.py [--update] [--runner CMD] [EXAMPLE ...]

Each example/NAME.f90 with a comment line mentioning "Output" followed, in the same
comment block, by an indented block ("!!     ...") is run (by default with
`fpm run --profile release --example NAME`; `--runner 'DIR/{name}'` runs a built
executable instead) and its standard output compared with that block, line by line:

- text between numbers must match exactly (trailing blanks ignored);
- integers must match exactly;
- real numbers must agree to a relative 1e-12 (they are printed with fewer digits, so in
  practice the printed digits must match), except round-off-level values: when both
  the expected and the printed value are at most 1e-30 in magnitude (about 5000 epsilon
  of real128) they pass whatever their digits;
- on lines that report CPU time (containing "s/step", "speed-up" or "seconds") the
  numbers are not compared, only the text (with runs of blanks as one blank: a number of
  another width shifts the columns);
- a line that is `...` (blanks aside) stands for any number of printed lines (output whose
  order depends on threads, or that is too long to show).

`--update` rewrites the header blocks with today's output instead of comparing.

README.md is checked too: a fenced block preceded by `<!-- example: PATH -->` must equal
that example's program (the file without its leading comment lines), the next fenced
block its expected output; a block preceded by `<!-- excerpt: PATH -->` must occur in
that file verbatim. Exit status 0 when everything matches, 1 otherwise.
"""
import argparse
import pathlib
import re
import shlex
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
ROUND_OFF = 1e-30
RELATIVE = 1e-12
TIMING = re.compile(r"s/step|speed-up|seconds")
NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")
BLOCK_LINE = re.compile(r"^!!     (.*)$")


def header_block(lines):
    """(start, end, expected lines) of the output block: the indented lines that follow
    the first comment line mentioning "Output", in the same comment block."""
    seen_output = False
    start = None
    for i, line in enumerate(lines):
        if not line.startswith("!"):
            if seen_output:
                break
            continue
        if not seen_output:
            seen_output = "Output" in line
            continue
        match = BLOCK_LINE.match(line)
        if match and start is None:
            start = i
        elif not match and start is not None:
            return start, i, [BLOCK_LINE.match(l).group(1).rstrip() for l in lines[start:i]]
    if start is not None:
        return start, i, [BLOCK_LINE.match(l).group(1).rstrip() for l in lines[start:i]]
    return None


def compare_line(expected, actual):
    """None when the lines agree under the rules above, else a reason."""
    timing = bool(TIMING.search(expected))
    exp_numbers = NUMBER.findall(expected)
    act_numbers = NUMBER.findall(actual)
    exp_text, act_text = NUMBER.split(expected), NUMBER.split(actual.rstrip())
    if timing:
        exp_text = [re.sub(r" +", " ", t) for t in exp_text]
        act_text = [re.sub(r" +", " ", t) for t in act_text]
    if exp_text != act_text:
        return "text differs"
    if len(exp_numbers) != len(act_numbers):
        return "number of fields differs"
    if timing:
        return None
    for e, a in zip(exp_numbers, act_numbers):
        if re.fullmatch(r"[-+]?\d+", e) and re.fullmatch(r"[-+]?\d+", a):
            if int(e) != int(a):
                return f"integer {a} instead of {e}"
            continue
        x, y = float(e), float(a)
        if abs(x) <= ROUND_OFF and abs(y) <= ROUND_OFF:
            continue
        if abs(x - y) > RELATIVE * max(abs(x), abs(y)):
            return f"{a} instead of {e}"
    return None


def compare_block(expected, actual):
    """Reasons why the printed lines do not match the expected ones (empty when they do);
    an expected `...` matches any run of printed lines, the shortest that lets the rest
    match."""
    if all(e.strip() != "..." for e in expected):
        problems = []
        if len(expected) != len(actual):
            problems.append(f"{len(actual)} lines printed, {len(expected)} expected")
        for number, (e, a) in enumerate(zip(expected, actual), 1):
            reason = compare_line(e, a)
            if reason:
                problems.append(f"line {number}: {reason}\n  expected: {e}\n  printed:  {a}")
        return problems

    def matches(i, j):
        if i == len(expected):
            return j == len(actual)
        if expected[i].strip() == "...":
            return any(matches(i + 1, k) for k in range(j, len(actual) + 1))
        return j < len(actual) and compare_line(expected[i], actual[j]) is None and \
            matches(i + 1, j + 1)

    if matches(0, 0):
        return []
    return ["the printed lines do not match the expected ones (with '...' lines):\n"
            + "\n".join("  printed:  " + a for a in actual)]


def run_example(name, runner):
    if runner:
        command = shlex.split(runner.format(name=name))
    else:
        # Build first: fpm writes its build progress to standard output.
        build = subprocess.run(["fpm", "build", "--profile", "release"], cwd=ROOT,
                               capture_output=True, text=True)
        if build.returncode != 0:
            raise RuntimeError(f"fpm build failed:\n{build.stdout[-2000:]}{build.stderr[-2000:]}")
        command = ["fpm", "run", "--profile", "release", "--example", name]
    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(command)} exited with {result.returncode}:\n"
                           f"{result.stderr[-2000:]}")
    return [l.rstrip() for l in result.stdout.rstrip("\n").split("\n")]


def program_text(path):
    """The example without its leading comment lines."""
    lines = path.read_text().split("\n")
    i = 0
    while i < len(lines) and lines[i].startswith("!"):
        i += 1
    return "\n".join(lines[i:]).strip("\n")


def fenced_blocks_after(text, marker):
    """For each `<!-- marker: PATH -->`: (PATH, first fenced block, second fenced block)."""
    found = []
    for match in re.finditer(r"<!-- " + marker + r": (\S+) -->", text):
        rest = text[match.end():]
        blocks = re.findall(r"```[a-z]*\n(.*?)\n```", rest, flags=re.S)
        found.append((match.group(1), blocks[0] if blocks else None,
                      blocks[1] if len(blocks) > 1 else None))
    return found


def check_readme(expected_outputs):
    failures = 0
    readme = (ROOT / "README.md").read_text()
    for path, code, output in fenced_blocks_after(readme, "example"):
        if code is None or code.strip("\n") != program_text(ROOT / path):
            print(f"README.md: the code block after <!-- example: {path} --> is not {path}")
            failures += 1
        name = pathlib.Path(path).stem
        if output is None or name not in expected_outputs or \
                [l.rstrip() for l in output.split("\n")] != expected_outputs[name]:
            print(f"README.md: the output block of {path} differs from its header")
            failures += 1
        else:
            print(f"ok   README.md shows {path} and its output")
    for path, code, _ in fenced_blocks_after(readme, "excerpt"):
        if code is None or code not in (ROOT / path).read_text():
            print(f"README.md: the block after <!-- excerpt: {path} --> is not in {path}")
            failures += 1
        else:
            print(f"ok   README.md excerpt of {path}")
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("examples", nargs="*", help="names (default: all with an Output block)")
    parser.add_argument("--update", action="store_true", help="rewrite the header blocks")
    parser.add_argument("--runner", help="command per example, '{name}' replaced")
    args = parser.parse_args()

    paths = sorted((ROOT / "example").glob("*.f90"))
    if args.examples:
        paths = [ROOT / "example" / f"{name}.f90" for name in args.examples]
    failures = 0
    checked = 0
    expected_outputs = {}
    for path in paths:
        lines = path.read_text().split("\n")
        block = header_block(lines)
        if block is None:
            print(f"skip {path.name}: no Output block in its header")
            continue
        start, end, expected = block
        actual = run_example(path.stem, args.runner)
        checked += 1
        if args.update:
            lines[start:end] = [("!!     " + l).rstrip() for l in actual]
            path.write_text("\n".join(lines))
            print(f"updated {path.name}")
            expected_outputs[path.stem] = actual
            continue
        expected_outputs[path.stem] = expected
        problems = compare_block(expected, actual)
        if problems:
            failures += 1
            print(f"FAIL {path.name}")
            for problem in problems:
                print("  " + problem)
        else:
            print(f"ok   {path.name} ({len(actual)} lines)")
    if not args.examples:
        failures += check_readme(expected_outputs)
    if checked == 0:
        print("no example checked")
        return 1
    if failures:
        print(f"{failures} mismatch(es)")
    else:
        print(f"{checked} of {checked} examples print what their headers say")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
