#!/usr/bin/env python3
"""Prints how many tests the last ctest run skipped, each with the one-line reason the test gave, and
every test that failed and then passed when ctest ran it again (--repeat until-pass), with the first
line of its failure: such a test depends on the machine's load or timing and wants a fix.

usage: ctest_skips.py BUILD_DIR

Reads BUILD_DIR/Testing/Temporary/LastTest.log, where ctest keeps every test's output: a GoogleTest
case skipped with GTEST_SKIP() << "reason" prints "Skipped" and then the reason; a pytest file prints
"SKIPPED [n] file:line: reason" with -rs, or "N skipped" in its summary.
"""
import os
import re
import sys


def tests_in(log):
    """Yields (name, output) for every test in a ctest LastTest.log ("N/M Test: name" starts each)."""
    name, lines = None, []
    for line in log.splitlines():
        m = re.match(r"\d+/\d+ Test: (.+)$", line)
        if m:
            if name:
                yield name, "\n".join(lines)
            name, lines = m.group(1), []
        else:
            lines.append(line)
    if name:
        yield name, "\n".join(lines)


def gtest_reason(output):
    lines = output.splitlines()
    for i, line in enumerate(lines):
        if line.rstrip().endswith(": Skipped") and i + 1 < len(lines):
            return lines[i + 1].strip()
    return None


def first_failure_line(output):
    for line in output.splitlines():
        if ": Failure" in line or "Expected" in line or "Value of:" in line:
            return line.strip()
    return "(its output is above, where ctest printed the failure)"


def retried(runs):
    """(name, output of its first failed run) for each test that failed once and passed later."""
    first_failure, passed = {}, set()
    for name, output in runs:
        if "\nTest Failed." in output:
            first_failure.setdefault(name, output)
        elif "Test Passed." in output:
            passed.add(name)
    return [(name, out) for name, out in first_failure.items() if name in passed]


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    path = os.path.join(sys.argv[1], "Testing", "Temporary", "LastTest.log")
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            log = f.read()
    except OSError as e:
        print(f"ctest_skips: {path}: {e.strerror}")
        return
    skipped = []
    runs = list(tests_in(log))
    for name, output in runs:
        if "[  SKIPPED ]" in output:
            skipped.append((name, gtest_reason(output) or "(no reason given)"))
            continue
        m = re.search(r"(\d+) skipped", output)
        if m and name.startswith("python."):
            reasons = re.findall(r"SKIPPED \[\d+\] [^:]+:\d+: (.*)", output)
            skipped.append((name, f"{m.group(1)} case(s) skipped" +
                            (": " + "; ".join(reasons) if reasons else "")))
    print(f"{len(skipped)} skipped")
    for name, reason in skipped:
        print(f"  {name}: {reason}")
    flaky = retried(runs)
    if flaky:
        print(f"{len(flaky)} passed only when run again (load- or timing-dependent):")
        for name, output in flaky:
            print(f"  {name}: {first_failure_line(output)}")


if __name__ == "__main__":
    main()
