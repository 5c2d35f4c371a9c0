#!/usr/bin/env python3
"""Runs docs/tutorial.md exactly as written and checks that every command still prints what
the tutorial shows, so the tutorial cannot rot.

The tutorial's shell blocks (```sh) are run in order (a ` #` and what follows it on a line is
a comment and is not run), each command line in one shell that
keeps its working folder between blocks (a `cd` carries over), as a terminal session would:
`export NAME=VALUE` carries over too, a line ending in `&` runs in the background and `wait`
waits for every background line (each must succeed), starting in a fresh folder
that sees the checkout's `host-tools` and `docs` (links), as the repository's root would. The `mil` on the
PATH is the one this checkout builds (`cargo build --release -p mil`, run here first).
A ```text block right after a ```sh block is the output of that block's commands (stdout,
in order), compared line by line: words must be equal, numbers equal within 2 % (or 0.02
absolute, for figures near zero; on a line marked "(informational)", such as the run's
speed, any number); a line `...` in the tutorial stands for any number of lines. Prints the time the whole path took.

Usage: python3 docs/tutorial-check.py [--keep] [--update]
  --keep    leave the working folder
  --update  write the outputs into the tutorial's ```text blocks instead of checking them
            (after a change that alters what the commands print: review the diff)
"""

import os
import shlex
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TUTORIAL = os.path.join(ROOT, "docs", "tutorial.md")
NUMBER = re.compile(r"0x[0-9A-Fa-f]+|[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def blocks(text):
    """The (kind, body) fenced blocks of the markdown, in order."""
    out = []
    for m in re.finditer(r"^```(\w*)\n(.*?)^```", text, re.S | re.M):
        out.append((m.group(1), m.group(2)))
    return out


def split(line):
    """A line as its words and numbers: text parts and floats, in order."""
    parts, last = [], 0
    for m in NUMBER.finditer(line):
        parts.append(line[last:m.start()])
        text = m.group()
        parts.append(float(int(text, 16)) if text.startswith("0x") else float(text))
        last = m.end()
    parts.append(line[last:])
    return parts


def same_line(expected, got):
    a, b = split(expected.rstrip()), split(got.rstrip())
    if len(a) != len(b):
        return False
    # A figure marked (informational), such as a run's speed, depends on the machine: only
    # its words are compared.
    informational = "(informational)" in expected
    for x, y in zip(a, b):
        if isinstance(x, float) and informational:
            if not isinstance(y, float):
                return False
        elif isinstance(x, float):
            if not isinstance(y, float):
                return False
            if abs(x - y) > max(0.02 * abs(x), 0.02):
                return False
        elif " ".join(x.split()) != " ".join(y.split()):
            return False
    return True


def matches(expected, got):
    """Line-by-line match, `...` standing for any lines; returns the first mismatch."""
    exp, out = expected.rstrip("\n").split("\n"), got.rstrip("\n").split("\n")

    def go(i, j):
        if i == len(exp):
            return None if j == len(out) else f"unexpected line: {out[j]!r}"
        if exp[i].strip() == "...":
            for k in range(j, len(out) + 1):
                if go(i + 1, k) is None:
                    return None
            return f"no match after '...' for: {exp[i + 1] if i + 1 < len(exp) else '(end)'!r}"
        if j == len(out):
            return f"missing line: {exp[i]!r}"
        if not same_line(exp[i], out[j]):
            return f"expected {exp[i]!r}\n     got {out[j]!r}"
        return go(i + 1, j + 1)

    return go(0, 0)


def main():
    keep = "--keep" in sys.argv
    update = "--update" in sys.argv
    subprocess.run(["cargo", "build", "--release", "--locked", "-p", "mil"], cwd=ROOT, check=True)
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(ROOT, "target"))
    env = dict(os.environ)
    env["PATH"] = os.path.join(os.path.abspath(target), "release") + os.pathsep + env["PATH"]
    env["MIL_CHECKOUT"] = ROOT
    # The tutorial starts in the repository's root: a fresh folder that sees the checkout's
    # files, so that what the tutorial writes stays out of the checkout.
    work = tempfile.mkdtemp(prefix="mil-tutorial-")
    for name in ("host-tools", "docs"):
        os.symlink(os.path.join(ROOT, name), os.path.join(work, name))
    cwd = work
    with open(TUTORIAL) as f:
        markdown = f.read()
    fenced = blocks(markdown)
    outputs = {}
    commands, failures = 0, []
    background = []  # (line, process, stderr file)
    started = time.monotonic()
    for n, (kind, body) in enumerate(fenced):
        if kind != "sh":
            continue
        expected = fenced[n + 1][1] if n + 1 < len(fenced) and fenced[n + 1][0] == "text" else None
        output = ""
        for line in body.split("\n"):
            line = line.split(" #")[0].strip() if not line.lstrip().startswith("#") else ""
            if not line:
                continue
            commands += 1
            print(f"$ {line}", flush=True)
            if line.startswith("export "):
                for item in shlex.split(line[len("export "):]):
                    name, _, value = item.partition("=")
                    env[name] = value
                continue
            if line.endswith("&"):
                err = tempfile.TemporaryFile()
                p = subprocess.Popen(["bash", "-c", f"set -e; {line[:-1]}"], cwd=cwd, env=env,
                                     stdout=subprocess.DEVNULL, stderr=err)
                background.append((line, p, err))
                continue
            if line == "wait":
                for bline, p, err in background:
                    if p.wait() != 0:
                        err.seek(0)
                        print(err.read().decode(errors="replace"))
                        failures.append(f"`{bline}` exited with {p.returncode}")
                background = []
                if failures:
                    break
                continue
            # `cd` carries over: run the command, then print the folder it ended in.
            r = subprocess.run(
                ["bash", "-c", f'set -e; {line}\necho "@@cwd@@$PWD"'],
                cwd=cwd, env=env, capture_output=True, text=True,
            )
            if r.returncode != 0:
                print(r.stdout + r.stderr)
                failures.append(f"`{line}` exited with {r.returncode}")
                break
            stdout, _, tail = r.stdout.rpartition("@@cwd@@")
            cwd = tail.strip() or cwd
            output += stdout
            sys.stdout.write(stdout)
        if failures:
            break
        outputs[n + 1] = output
        if expected is not None and not update:
            problem = matches(expected, output)
            if problem:
                failures.append(f"block {n}: output differs from the tutorial:\n     {problem}")
    for bline, p, err in background:
        if p.poll() is None:
            p.kill()
            p.wait()
            if not failures:
                failures.append(f"`{bline}` was never waited for")
        # A background line that failed is often why a later line did: show what it said.
        if failures:
            err.seek(0)
            said = err.read().decode(errors="replace").strip()
            if said:
                print(f"[background `{bline}`]\n{said}")
    elapsed = time.monotonic() - started
    if update and not failures:
        parts, k = [], 0
        for i, m in enumerate(re.finditer(r"^```(\w*)\n(.*?)^```", markdown, re.S | re.M)):
            if m.group(1) == "text" and i in outputs:
                parts.append(markdown[k:m.start(2)] + outputs[i])
                k = m.end(2)
        parts.append(markdown[k:])
        with open(TUTORIAL, "w") as f:
            f.write("".join(parts))
        print(f"wrote the outputs into {TUTORIAL}")
    if not keep:
        shutil.rmtree(work, ignore_errors=True)
    else:
        print(f"working folder kept: {work}")
    print(f"\ntutorial: {commands} commands in {elapsed:.1f} s")
    if failures:
        for f in failures:
            print(f"FAILED: {f}")
        sys.exit(1)
    print("tutorial: every command ran and printed what docs/tutorial.md shows")


if __name__ == "__main__":
    main()
